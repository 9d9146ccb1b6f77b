"""Contact surfaces in unusual places of the mesh: a group of facets inside the mesh (a
mesh fused along the interface) is rejected with the same count of facets on any number
of ranks.

The meshes are block-structured 2D quadrilateral meshes written by rank 0 with gmsh
(:func:`write_blocks_msh`): blocks that name the same corner point share it, so that two
blocks are conforming (one body) where their edges join and apart where their corners
are distinct points at the same place.
"""

from __future__ import annotations

import math

import pytest
from mpi4py import MPI

from dolfinx_mortar.errors import SceneError
from dolfinx_mortar.mesh import load_mesh
from dolfinx_mortar.runner import prepare
from dolfinx_mortar.scene import parse_scene

pytestmark = pytest.mark.mpi


def write_blocks_msh(path, points: dict, blocks: list, groups: dict, h: float) -> None:
    """Quadrilateral mesh of rectangular blocks (rank 0 only; gmsh's geo kernel).

    ``points``: name -> (x, y); ``blocks``: (region, (p0, p1, p2, p3)) with the corners
    counterclockwise; ``groups``: facet group name -> list of (pa, pb) block edges. An
    edge of length L gets max(1, round(L / h)) elements (opposite block edges alike)."""
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("blocks")
        geo = gmsh.model.geo
        tag = {p: geo.addPoint(x, y, 0.0) for p, (x, y) in points.items()}
        lines = {}

        def line(a, b):
            if (b, a) in lines:
                return -lines[(b, a)]
            if (a, b) not in lines:
                lines[(a, b)] = geo.addLine(tag[a], tag[b])
            return lines[(a, b)]

        regions = {}
        for region, corners in blocks:
            loop = [line(corners[i], corners[(i + 1) % 4]) for i in range(4)]
            s = geo.addPlaneSurface([geo.addCurveLoop(loop)])
            regions.setdefault(region, []).append(s)
        geo.synchronize()
        for (a, b), ln in lines.items():
            length = math.dist(points[a], points[b])
            gmsh.model.mesh.setTransfiniteCurve(ln, max(1, round(length / h)) + 1)
        for surfaces in regions.values():
            for s in surfaces:
                gmsh.model.mesh.setTransfiniteSurface(s)
                gmsh.model.mesh.setRecombine(2, s)
        for region, surfaces in regions.items():
            gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, surfaces), region)
        for name, edges in groups.items():
            tags = [abs(line(a, b)) for a, b in edges]
            gmsh.model.setPhysicalName(1, gmsh.model.addPhysicalGroup(1, tags), name)
        gmsh.model.mesh.generate(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def _write(path, *args) -> None:
    """:func:`write_blocks_msh` on rank 0 (collective: the others wait for the file)."""
    if MPI.COMM_WORLD.rank == 0:
        write_blocks_msh(path, *args)
    MPI.COMM_WORLD.barrier()


_MATERIAL = {"model": "linear-elastic", "E": 100.0, "nu": 0.3}


def test_facets_inside_the_mesh_are_counted_once_on_any_partition(shared_tmp):
    """A strip [0, 4] × [0, 1] of two blocks conforming along y = 0.5 (one body), the
    interface "iface" named as a slave: 16 facets inside the mesh. Under the shared-facet
    ghost mode a facet on a partition boundary is on both ranks, with both its cells, and
    each rank counted it: the error said "has 10 facet(s)" on 2 ranks for a probe's 5
    (session 50). Each facet now counts on its owner only, and the message is the serial
    one on 1, 2 and 3 ranks; on several ranks the test checks that the ranks do hold
    some interface facet twice (the case that was counted twice)."""
    points = {
        "a": (0.0, 0.0),
        "b": (4.0, 0.0),
        "c": (4.0, 0.5),
        "d": (0.0, 0.5),
        "e": (4.0, 1.0),
        "f": (0.0, 1.0),
    }
    blocks = [("lower", ("a", "b", "c", "d")), ("upper", ("d", "c", "e", "f"))]
    groups = {"bottom": [("a", "b")], "iface": [("d", "c")], "top": [("e", "f")]}
    path = shared_tmp / "fused.msh"
    _write(path, points, blocks, groups, 0.25)
    comm = MPI.COMM_WORLD
    md = load_mesh(comm, file=path)
    held = md.facet_tags.find(md.facet_groups["iface"]).size
    if comm.size > 1:  # some interface facet is on two ranks
        assert comm.allreduce(held) > 16
    data = {
        "kinematics": "small",
        "mesh": {"file": str(path)},
        "material": [dict(_MATERIAL, region=r) for r in ("lower", "upper")],
        "contact": [{"slave": "iface", "master": "top"}],
        "dirichlet": [{"boundary": "bottom", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]}],
    }
    with pytest.raises(SceneError) as err:
        prepare(parse_scene(data, shared_tmp), comm)
    assert err.value.key == "contact[0].slave"
    assert "contact surface 'iface' has 16 facet(s) inside the mesh" in str(err.value)
