"""A block wider than its base: master facets at right angles to the slave (session 50).

Base [0, 1] × [0, 0.5] (10 × 5 quadrilaterals), block [−0.3, 1.3] × [0.5, 0.8] (15 × 3,
so its bottom nodes sit at x = 0.02 and 0.98, just inside the base's corners), meshed
apart, both linear elastic (E = 100, ν = 0.3, small strain). The base's bottom is
clamped, the block's top pressed down by 0.02 in one step. Slave: the block's bottom;
master: either the base's top (``top``) or its top and its two vertical sides
(``skin``). The block can never touch the sides, so both masters must give the same
solution.

Before session 50 every pairing accepted a master facet for a slave point where
n_s·ν < 0: the sides, perpendicular to the slave at rest, tilt by ~1° under the load and
were then accepted by the slave points over the void beside the base, with their
horizontal distance as the gap. With element integration the slave node at x = 0.02
averaged those positive gaps with the penetration of its other points and read open
(p_N = 0) while it sank 6.5e-3 into the base, and the contact force fell from 3.1216 to
2.9770 (−4.6 %); segment integration counted the sides' thin projections (3.1292 to
3.1282, −3.2e-4); node integration was not affected (its points are the slave's nodes,
none of them beside a side). Now a master facet faces a slave point only where
n_s·ν < −cos θ_max, θ_max = 85° (:data:`dolfinx_mortar.kernels.gap.MAX_FACING_ANGLE`;
docs/method-notes.md, "Pairing"). The mesh gives the probe's figures.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import written_once
from mpi4py import MPI

from dolfinx_mortar.runner import run
from dolfinx_mortar.scene import parse_scene

PRESS = 0.02


def _write_overhang_msh(path, skin: bool) -> None:
    """The two bodies, transfinite quadrilaterals; groups base, blk, base_bot, blk_top,
    blk_bot and base_master (the base's top, with ``skin`` also its two sides)."""
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("overhang")
    occ, mesh = gmsh.model.occ, gmsh.model.mesh
    base = occ.addRectangle(0.0, 0.0, 0.0, 1.0, 0.5)
    blk = occ.addRectangle(-0.3, 0.5, 0.0, 1.6, 0.3)
    occ.synchronize()
    groups: dict[str, list[int]] = {}
    for name, surf, y0, y1, nx, ny in (
        ("base", base, 0.0, 0.5, 10, 5),
        ("blk", blk, 0.5, 0.8, 15, 3),
    ):
        gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, [surf]), name)
        for _, curve in gmsh.model.getBoundary([(2, surf)], oriented=False):
            _, cy, _ = occ.getCenterOfMass(1, curve)
            horizontal = abs(cy - y0) < 1e-9 or abs(cy - y1) < 1e-9
            mesh.setTransfiniteCurve(curve, (nx if horizontal else ny) + 1)
            if name == "base" and abs(cy - y0) < 1e-9:
                groups.setdefault("base_bot", []).append(curve)
            elif name == "base" and (abs(cy - y1) < 1e-9 or (skin and not horizontal)):
                groups.setdefault("base_master", []).append(curve)
            elif name == "blk" and horizontal:
                groups.setdefault("blk_bot" if abs(cy - y0) < 1e-9 else "blk_top", []).append(curve)
        mesh.setTransfiniteSurface(surf)
        mesh.setRecombine(2, surf)
    for name, curves in groups.items():
        gmsh.model.setPhysicalName(1, gmsh.model.addPhysicalGroup(1, curves), name)
    mesh.generate(2)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(str(path))
    gmsh.finalize()


@pytest.fixture
def overhang_msh(shared_tmp):
    return {
        master: written_once(shared_tmp / f"overhang_{master}.msh", _write_overhang_msh, skin)
        for master, skin in (("top", False), ("skin", True))
    }


def _run(msh, integration: str) -> tuple[dict, dict]:
    """The pressed overhang; returns the summary and, per slave node (reference x), its
    nodal pressure and its vertical distance to the base's top (current configuration,
    the top's nodes joined by straight lines; < 0: penetration)."""
    scene = {
        "kinematics": "small",
        "mesh": {"file": str(msh)},
        "material": [
            {"region": b, "model": "linear-elastic", "E": 100.0, "nu": 0.3} for b in ("base", "blk")
        ],
        "contact": [
            {
                "slave": "blk_bot",
                "master": "base_master",
                "integration": integration,
                "uzawa_tol": 1e-10,
            }
        ],
        "dirichlet": [
            {"boundary": "base_bot", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]},
            {"boundary": "blk_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -PRESS]]},
        ],
        "steps": {"t_end": 1.0, "n": 1},
    }
    held = []
    summary = run(parse_scene(scene, msh.parent), MPI.COMM_WORLD, setup=held.append)
    p = held[0]
    try:
        X = p.V.tabulate_dof_coordinates()[:, :2]
        x = X + p.u.x.array.reshape(-1, 2)[: len(X)]
        c = p.contacts[0]
        slave = c.node_blocks - p.V.dofmap.index_map.local_range[0]  # owned slave nodes
        on_top = np.abs(X[:, 1] - 0.5) < 1e-9
        on_top[slave] = False
        top = np.flatnonzero(on_top & (X[:, 0] > -1e-9) & (X[:, 0] < 1.0 + 1e-9))
        top = top[np.argsort(x[top, 0])]
        nodes = {}
        for i, node in enumerate(slave):
            if x[top[0], 0] < x[node, 0] < x[top[-1], 0]:
                y_top = np.interp(x[node, 0], x[top, 0], x[top, 1])
                nodes[round(float(X[node, 0]), 6)] = (float(c.p[i]), float(x[node, 1] - y_top))
    finally:
        p.destroy()
    return summary, nodes


@pytest.mark.parametrize("integration", ["element", "segment", "node"])
def test_unreachable_master_sides_change_nothing(overhang_msh, integration):
    """The skin master gives the top master's contact force, and no slave node over the
    base reads open (p_N = 0) while it penetrates.

    The sides face away from every slave point by ~89° (perpendicular at rest, tilted by
    the load), beyond θ_max = 85°, so both masters pair the same points with the same
    facets and the two runs do the same arithmetic: the forces agree to round-off
    (measured: equal to the last digit; rel 1e-9 leaves room for the order of sums,
    and lies far below the errors this guards against: 4.6 % with element integration,
    3.2e-4 with segment integration). The penetration bound 1e-3 is 5 % of the press;
    the node that read open sank 6.5e-3 (the nodes in contact: |gap| < 2e-4)."""
    forces, tables = {}, {}
    for master, msh in overhang_msh.items():
        s, tables[master] = _run(msh, integration)
        assert s["status"] == "ok", s["error"]
        forces[master] = s["steps"][-1]["contact_force"]["blk_bot:base_master"][1]
    assert forces["top"] > 2.9
    assert forces["skin"] == pytest.approx(forces["top"], rel=1e-9)
    for master, table in tables.items():
        for xref, (p, gap) in table.items():
            assert not (p == 0.0 and gap < -1e-3), (integration, master, xref, p, gap)
