"""Contact surfaces in unusual places of the mesh: a group of facets inside the mesh (a
mesh fused along the interface) is rejected with the same count of facets on any number
of ranks; a slave and a master on one body (self-contact) carry the force of the same
problem split into two bodies; a slave and a master that share a node (a slit's faces,
which meet at its tip) are rejected with an error that says what to do.

The meshes are block-structured 2D quadrilateral meshes written by rank 0 with gmsh
(:func:`write_blocks_msh`): blocks that name the same corner point share it, so that two
blocks are conforming (one body) where their edges join and apart where their corners
are distinct points at the same place.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from dolfinx_mortar.errors import SceneError
from dolfinx_mortar.mesh import load_mesh
from dolfinx_mortar.runner import prepare, run
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
            tags = [lines[(a, b)] if (a, b) in lines else lines[(b, a)] for a, b in edges]
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


# A C-shaped body (session 50's probe adv44): the back [0, 0.5] × [0, 1.1], the arms
# [0.5, 3] × [0, 0.5] and [0.5, 3] × [0.6, 1.1], a slot 0.1 high between them; regions
# "lo" (y < 0.55) and "up". The C's points; "m2u", "m3u" are the split's copies of the
# back's points at y = 0.55 (the full C uses m2, m3 there).
_C_POINTS = {
    "a0": (0.0, 0.0),
    "a1": (0.5, 0.0),
    "a2": (0.5, 0.5),
    "a3": (0.0, 0.5),
    "m2": (0.5, 0.55),
    "m3": (0.0, 0.55),
    "m2u": (0.5, 0.55),
    "m3u": (0.0, 0.55),
    "b2": (0.5, 0.6),
    "b3": (0.0, 0.6),
    "c2": (0.5, 1.1),
    "c3": (0.0, 1.1),
    "d1": (3.0, 0.0),
    "d2": (3.0, 0.5),
    "e1": (3.0, 0.6),
    "e2": (3.0, 1.1),
}


def _c_mesh(path, split: bool, h: float = 0.125) -> None:
    """The C (``split`` False: one body) or the C cut along its mirror line y = 0.55 into
    two bodies, the same nodes with the back's nodes on the cut doubled (``split``);
    element size ``h`` (``bench/bench_self_contact.py`` refines it)."""
    m2, m3 = ("m2u", "m3u") if split else ("m2", "m3")
    blocks = [
        ("lo", ("a0", "a1", "a2", "a3")),
        ("lo", ("a3", "a2", "m2", "m3")),
        ("up", (m3, m2, "b2", "b3")),
        ("up", ("b3", "b2", "c2", "c3")),
        ("lo", ("a1", "d1", "d2", "a2")),
        ("up", ("b2", "e1", "e2", "c2")),
    ]
    groups = {
        "left": [("a0", "a3"), ("a3", "m3"), (m3, "b3"), ("b3", "c3")],
        "arm_lo_top": [("a2", "d2")],
        "arm_up_bot": [("b2", "e1")],
        "arm_lo_bot": [("a1", "d1")],
        "arm_up_top": [("c2", "e2")],
    }
    if split:
        groups |= {"sym_lo": [("m3", "m2")], "sym_up": [("m3u", "m2u")]}
    points = {p: x for p, x in _C_POINTS.items() if split or p not in ("m2u", "m3u")}
    _write(path, points, blocks, groups, h)


def _c_scene(path, split: bool) -> dict:
    """The C clamped at its back, its arms' outer faces moved 0.12 towards each other in
    u_y (the slot of 0.1 closes, then the arms press), in 4 steps; the arms' inner faces
    are the pair (segment integration, Uzawa to 1e-10). ``split``: the two halves held
    at u_y = 0 on the cut, the mirror symmetry's condition."""

    def held(boundary, uy):
        return {"boundary": boundary, "components": [1], "path": [[0.0, 0.0], [1.0, uy]]}

    dirichlet = [
        {"boundary": "left", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]},
        held("arm_up_top", -0.12),
        held("arm_lo_bot", 0.12),
    ]
    if split:
        dirichlet += [held("sym_lo", 0.0), held("sym_up", 0.0)]
    return {
        "kinematics": "small",
        "mesh": {"file": str(path)},
        "material": [dict(_MATERIAL, region=r) for r in ("lo", "up")],
        "contact": [
            {
                "slave": "arm_lo_top",
                "master": "arm_up_bot",
                "integration": "segment",
                "uzawa_tol": 1e-10,
            }
        ],
        "dirichlet": dirichlet,
        "steps": {"n": 4},
    }


def _force(data, out, comm) -> np.ndarray:
    """The pair's contact force at the end of ``data`` run on ``comm``."""
    s = run(parse_scene(dict(data, output={"dir": str(out)}), out.parent), comm)
    assert s["status"] == "ok", s["error"]
    return np.asarray(s["steps"][-1]["contact_force"]["arm_lo_top:arm_up_bot"])


@pytest.mark.mpi_not3
def test_self_contact_carries_the_force_of_the_two_body_split(shared_tmp):
    """Self-contact: the slave and master groups on one body. The C's two arms pressed
    together carry the contact force of the same mesh cut along the mirror line into two
    bodies held at u_y = 0 on the cut (the symmetry's condition, which the one-body
    solution meets only as far as the discretization is mirror-symmetric: the slave is
    the lower arm). On this mesh the normal (y) forces differ by 2.8e-5 of the force at
    h = 0.125, 6.1e-7 at h/2 and 1.9e-8 at h/4, the tangential (x) ones by 6.5e-5 and
    8.6e-6 (session 50): a discretization error that vanishes with h, bounded here by
    1e-4 and 2e-4 of the force. A self-contact that failed (the arms passing through each
    other, a force on one side only) would be off by the whole force: the slot closes,
    so without contact there would be none. On several ranks the forces are also the
    serial ones (1e-8): serially and on 2 ranks (mpi_not3, session 66; the pairing across
    3 ranks against serial runs is test_contact_parallel's, whose pairs are found as
    these, one body or two)."""
    comm = MPI.COMM_WORLD
    forces = {}
    for split in (False, True):
        path = shared_tmp / f"c_{'split' if split else 'full'}.msh"
        _c_mesh(path, split)
        data = _c_scene(path, split)
        forces[split] = _force(data, shared_tmp / f"c_{split}_{comm.size}", comm)
        if comm.size > 1 and comm.rank == 0:
            serial = _force(data, shared_tmp / f"c_{split}_serial", MPI.COMM_SELF)
            np.testing.assert_allclose(forces[split], serial, rtol=1e-8, atol=1e-8)
        comm.barrier()
    one, two = forces[False], forces[True]
    assert 30.0 < -one[1] < 42.0, one  # pressing, less than the arms' reactions (42)
    assert abs(one[1] - two[1]) <= 1e-4 * abs(two[1]), (one, two)
    assert abs(one[0] - two[0]) <= 2e-4 * abs(two[1]), (one, two)


def test_a_slave_and_master_that_share_a_node_get_an_error_that_says_what_to_do(shared_tmp):
    """A slit: a block [0, 3] × [0, 1] cut along y = 0.5 from x = 0.5 to its right end,
    the cut's faces named as slave and master. They meet at the slit's tip (0.5, 0.5),
    one node of both. The message read as if self-contact were forbidden ("must lie on
    bodies with nodes of their own"); it now says that one body is fine and how to leave
    the shared node out. One line, the same on every rank (a SceneError on each)."""
    points = {
        "a0": (0.0, 0.0),
        "a1": (0.5, 0.0),
        "d1": (3.0, 0.0),
        "a3": (0.0, 0.5),
        "tip": (0.5, 0.5),
        "dlo": (3.0, 0.5),
        "dup": (3.0, 0.5),
        "f": (0.0, 1.0),
        "g": (0.5, 1.0),
        "e": (3.0, 1.0),
    }
    blocks = [
        ("c", ("a0", "a1", "tip", "a3")),
        ("c", ("a3", "tip", "g", "f")),
        ("c", ("a1", "d1", "dlo", "tip")),
        ("c", ("tip", "dup", "e", "g")),
    ]
    groups = {
        "left": [("a0", "a3"), ("a3", "f")],
        "slit_lo": [("tip", "dlo")],
        "slit_up": [("tip", "dup")],
    }
    path = shared_tmp / "slit.msh"
    _write(path, points, blocks, groups, 0.25)
    data = {
        "kinematics": "small",
        "mesh": {"file": str(path)},
        "material": [dict(_MATERIAL, region="c")],
        "contact": [{"slave": "slit_lo", "master": "slit_up"}],
        "dirichlet": [{"boundary": "left", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]}],
    }
    with pytest.raises(SceneError) as err:
        prepare(parse_scene(data, shared_tmp), MPI.COMM_WORLD)
    assert err.value.key == "contact[0].master"
    assert err.value.reason == (
        "contact surfaces 'slit_lo' and 'slit_up' share 1 mesh node(s): a slave and its "
        "master may be surfaces of one body (self-contact) but must not share a node; leave "
        "the facets at the shared node(s) out of one of the groups (where two surfaces of "
        "one body meet, e.g. at a slit's tip), or give bodies fused there nodes of their own"
    )
    assert len(set(MPI.COMM_WORLD.allgather(str(err.value)))) == 1
