"""Segment integration: a facet's choice of the dual tangential weights is fixed per step
attempt (session 51).

Two stacked linear elastic blocks [0, 1]² × [0, 0.3] and [0, 1]² × [0.3, 0.6] (4 × 4 × 2
and 3 × 3 × 2 hexahedra, meshed apart, E = 1000, ν = 0.3, small strain) with flush
edges; slave: the lower block's top, μ = 0.3, segment integration, dual tangential
weights (the default). The lower block's bottom is clamped; the upper block's top is
lifted by 0.0011 (t 0–1), pressed to −0.003 while shifted by 5e-4 along x (t 1–2) and
lifted back (t 2–2.625), in steps of 0.125 (the probe's scene, /tmp/adv46
``two_lift_ng.toml``, cut at t = 2.625).

A facet uses Ψ only where its points paired now and at t_n cover its whole area to
FULL_COVER_TOL = 1e-6. With segment integration that area is a sum of clipped segments
that moves with u: at the flush edges the two bodies' Poisson expansions differ by a
sliver of 0.9–2e-6 of a facet near the unloading steps' solutions, so the choice
switched between Newton iterates (the residual jumped by 3e-4, Newton cycled at
‖R‖ ≈ 4–7e-4) and, with the choice fixed per Newton solve only, between the solves of
the Uzawa rounds. Before the fix the step t = 2.625 failed twice (2 cutbacks); now the
choice is made at the step attempt's first evaluation (TangentialTerms._dual_facets), and
no step is cut back.
"""

from __future__ import annotations

import pytest
from conftest import written_once
from mpi4py import MPI

from dolfinx_mortar.runner import run
from dolfinx_mortar.scene import parse_scene


def _write_two_blocks_msh(path) -> None:
    """Two stacked structured hexahedral blocks (the probe's generator: the same entities,
    groups and their order, hence the same mesh file; the flip depended on round-off)."""
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    occ, L, h, nz = gmsh.model.occ, 1.0, 0.3, 2
    boxes = {"middle": (occ.addBox(0, 0, 0, L, L, h), 4), "top": (occ.addBox(0, 0, h, L, L, h), 3)}
    occ.synchronize()
    groups = {}
    for name, (v, n) in boxes.items():
        curves = set()
        for _, f in gmsh.model.getBoundary([(3, v)], combined=False, oriented=False):
            for _, c in gmsh.model.getBoundary([(2, f)], combined=False, oriented=False):
                curves.add(abs(c))
        for c in curves:
            bb = gmsh.model.getBoundingBox(1, c)
            gmsh.model.mesh.setTransfiniteCurve(c, (nz if abs(bb[5] - bb[2]) > 1e-6 else n) + 1)
        z0 = gmsh.model.getBoundingBox(3, v)[2]
        for _, f in gmsh.model.getBoundary([(3, v)], combined=False, oriented=False):
            gmsh.model.mesh.setTransfiniteSurface(f)
            gmsh.model.mesh.setRecombine(2, f)
            bb = gmsh.model.getBoundingBox(2, f)
            if abs(bb[0]) < 1e-6 and abs(bb[3]) < 1e-6:
                key = "x0"
            elif abs(bb[1]) < 1e-6 and abs(bb[4]) < 1e-6:
                key = "y0"
            elif abs(bb[2] - z0) < 1e-6 and abs(bb[5] - z0) < 1e-6:
                key = "bottom"
            elif abs(bb[2] - z0 - h) < 1e-6 and abs(bb[5] - z0 - h) < 1e-6:
                key = "top"
            else:
                continue
            groups[f"{name}_{key}"] = [f]
        gmsh.model.mesh.setTransfiniteVolume(v)
    i = 1
    for name, (v, _) in boxes.items():
        gmsh.model.addPhysicalGroup(3, [v], i)
        gmsh.model.setPhysicalName(3, i, name)
        i += 1
    for name, fs in groups.items():
        gmsh.model.addPhysicalGroup(2, fs, i)
        gmsh.model.setPhysicalName(2, i, name)
        i += 1
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.model.mesh.generate(3)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(str(path))
    gmsh.finalize()


@pytest.fixture
def two_blocks_msh(shared_tmp):
    return written_once(shared_tmp / "two_blocks.msh", _write_two_blocks_msh)


@pytest.mark.mpi2
def test_unloading_in_stick_needs_no_cutback(two_blocks_msh):
    scene = {
        "kinematics": "small",
        "mesh": {"file": str(two_blocks_msh)},
        "material": [
            {"region": b, "model": "linear-elastic", "E": 1000.0, "nu": 0.3}
            for b in ("middle", "top")
        ],
        "contact": [
            {
                "slave": "middle_top",
                "master": "top_bottom",
                "friction": 0.3,
                "recovery": "lumped",
                "integration": "segment",
                "penalty": "auto",
                "uzawa_tol": 1e-6,
            }
        ],
        "dirichlet": [
            {"boundary": "middle_bottom", "path": [[0.0, 0.0, 0.0, 0.0], [4.0, 0.0, 0.0, 0.0]]},
            {
                "boundary": "top_top",
                "path": [
                    [0.0, 0.0, 0.0, 0.0],
                    [1.0, 0.0, 0.0, 0.0011],
                    [2.0, 0.0005, 0.0, -0.003],
                    [3.0, 0.0, 0.0, 0.0011],
                    [4.0, 0.0005, 0.0, -0.003],
                ],
            },
        ],
        "steps": {"t_end": 2.625, "n": 21},
    }
    held = []
    out = two_blocks_msh.parent / "out"
    summary = run(
        parse_scene(scene, two_blocks_msh.parent), MPI.COMM_WORLD, out_dir=out, setup=held.append
    )
    held[0].destroy()
    assert summary["status"] == "ok"
    steps = summary["steps"]
    assert [round(s["t"], 6) for s in steps] == [round(0.125 * (i + 1), 6) for i in range(21)]
    # in contact from t = 1.375 on (pressed, then unloaded in stick)
    assert all(s["cutbacks"] == 0 for s in steps), [(s["t"], s["cutbacks"]) for s in steps]
