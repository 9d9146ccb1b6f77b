"""An initial overlap deeper than the pairing's reach (session 52, task O).

A quarter shrink fit: a solid shaft of radius 1 + δ and a ring 1 ≤ r ≤ 2 (coarse gmsh
triangles, 12 facets on either arc, slave facets 0.131 in size), meshes that overlap
by δ at t = 0, symmetry rollers on both cut planes, small strain, E = 200, ν = 0.3.
Slave ``ring_inner`` on master ``shaft_surface``. The pairing's reach is a slave
facet's box inflated by half its size, at most 2 facet sizes deep
(docs/method-notes.md, "Pairing"), so:

- δ = 0.06: every node pairs at u = 0: no warning, p = Lamé's;
- δ = 0.15: the 4 nodes at the cut planes (axis-aligned facets) start unpaired, the
  others (diagonal boxes) pair and push the bodies apart, which brings the 4 into reach:
  a warning at set-up, then a run that ends "ok" with p = Lamé's (the counter-case of a
  graded mesh: an error at set-up would refuse it);
- δ = 0.3 (2.3 facet sizes): no node pairs, the residual is 0 and Newton converges at
  u = 0 with the bodies overlapping: before, "ok" with no contact force; now a warning at
  set-up and the run "failed" after its first step, naming the pair and the nodes;
- δ = 0.1 and 0.15 with friction μ = 0.3 (session 52): the exact answer is all stick
  with τ = 0; before, the states of the first, deeply penetrating iterates froze the
  stick/slip states with 4 nodes open, and the run failed at every cutback.

Lamé (plane strain, solid shaft): p = δ / (C_ring + C_shaft),
C_ring = b(1+ν)((1−2ν)b² + c²)/(E(c² − b²)), C_shaft = b(1+ν)(1−2ν)/E.
"""

from __future__ import annotations

import logging

import numpy as np
import pytest
from conftest import written_once
from mpi4py import MPI

from dolfinx_mortar.runner import prepare, run
from dolfinx_mortar.scene import parse_scene

E, NU, B, C = 200.0, 0.3, 1.0, 2.0
WARNING = "start inside the master's body beyond the pairing's reach"


def _lame(delta: float) -> float:
    ring = B * (1 + NU) * ((1 - 2 * NU) * B * B + C * C) / (E * (C * C - B * B))
    shaft = B * (1 + NU) * (1 - 2 * NU) / E
    return delta / (ring + shaft)


def _write_shrink_msh(path, delta: float, n_arc: int = 12, h: float = 0.25) -> None:
    """Quarter shaft (radius B + delta) and ring (B..C), overlapping by delta; groups
    shaft, ring, shaft_surface, ring_inner, ring_outer, {shaft,ring}_{x0,y0} (rank 0)."""
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("shrink")
    g = gmsh.model.geo

    def quarter(r_in, r_out):
        o = g.addPoint(0, 0, 0, h)
        po = [g.addPoint(r_out, 0, 0, h), g.addPoint(0, r_out, 0, h)]
        arc_o = g.addCircleArc(po[0], o, po[1])
        if r_in > 0:
            pi = [g.addPoint(r_in, 0, 0, h), g.addPoint(0, r_in, 0, h)]
            arc_i = g.addCircleArc(pi[0], o, pi[1])
            y0, x0 = g.addLine(pi[0], po[0]), g.addLine(po[1], pi[1])
            loop = g.addCurveLoop([y0, arc_o, x0, -arc_i])
        else:
            arc_i = None
            y0, x0 = g.addLine(o, po[0]), g.addLine(po[1], o)
            loop = g.addCurveLoop([y0, arc_o, x0])
        return g.addPlaneSurface([loop]), arc_o, arc_i, x0, y0

    shaft, s_out, _, s_x0, s_y0 = quarter(0.0, B + delta)
    ring, r_out, r_in, r_x0, r_y0 = quarter(B, C)
    g.synchronize()
    for arc in (s_out, r_in):
        gmsh.model.mesh.setTransfiniteCurve(arc, n_arc + 1)
    for dim, tag, name in (
        (2, shaft, "shaft"),
        (2, ring, "ring"),
        (1, s_out, "shaft_surface"),
        (1, r_in, "ring_inner"),
        (1, r_out, "ring_outer"),
        (1, s_x0, "shaft_x0"),
        (1, s_y0, "shaft_y0"),
        (1, r_x0, "ring_x0"),
        (1, r_y0, "ring_y0"),
    ):
        gmsh.model.setPhysicalName(dim, gmsh.model.addPhysicalGroup(dim, [tag]), name)
    gmsh.model.mesh.generate(2)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(str(path))
    gmsh.finalize()


@pytest.fixture
def shrink_msh(shared_tmp):
    """Factory: shrink_msh(delta) -> path of the mesh (collective)."""

    def make(delta: float):
        return written_once(shared_tmp / f"shrink_{delta:g}.msh", _write_shrink_msh, delta)

    return make


def _scene(msh, out, friction: float = 0.0) -> dict:
    rollers = [[0.0, 0.0], [1.0, 0.0]]
    return {
        "title": "shrink fit",
        "kinematics": "small",
        "mesh": {"file": str(msh)},
        "material": [
            {"region": r, "model": "linear-elastic", "E": E, "nu": NU} for r in ("shaft", "ring")
        ],
        "contact": [
            {
                "slave": "ring_inner",
                "master": "shaft_surface",
                "uzawa_tol": 1e-8,
                "friction": friction,
            }
        ],
        "dirichlet": [
            {"boundary": f"{body}_{cut}", "components": [k], "path": rollers}
            for body in ("shaft", "ring")
            for cut, k in (("x0", 0), ("y0", 1))
        ],
        "steps": {"t_end": 1.0, "n": 1},
        "output": {"dir": str(out), "fields": ["contact_pressure", "gap", "contact_state"]},
    }


def _run(msh, out, caplog, friction: float = 0.0) -> tuple[dict, list[str]]:
    with caplog.at_level(logging.WARNING, logger="dolfinx_mortar"):
        summary = run(parse_scene(_scene(msh, out, friction), msh.parent), MPI.COMM_WORLD)
    return summary, [r.getMessage() for r in caplog.records if WARNING in r.getMessage()]


def _pressures(out) -> np.ndarray:
    return np.asarray(_table(out)["p_N"])


def _assert_lame(p: np.ndarray, delta: float) -> None:
    """The 13 nodal pressures ``p`` of the coarse quarter fit against Lamé's: the mean
    within 3 %, each node within 8 % (the coarse mesh)."""
    assert p.size == 13
    assert abs(p.mean() / _lame(delta) - 1) < 0.03
    assert np.allclose(p, _lame(delta), rtol=0.08)


def _table(out) -> np.ndarray:
    return np.genfromtxt(out / "contact_ring_inner_1.csv", delimiter=",", names=True)


@pytest.mark.mpi
def test_an_overlap_beyond_the_reach_stops_the_run(shrink_msh, shared_tmp, caplog):
    summary, warnings = _run(shrink_msh(0.3), shared_tmp / "deep", caplog)
    assert len(warnings) == 1
    assert "contact[0] (ring_inner:shaft_surface): 13 slave node(s)" in warnings[0]
    assert "the first at (0, 1), more than 0.262 deep" in warnings[0]
    assert summary["status"] == "failed"
    assert summary["steps"] == []  # the converged state at u = 0 was refused
    error = summary["error"]
    assert error.startswith("step to t = 1 converged, but contact[0] (ring_inner:shaft_surface)")
    assert "13 slave node(s) that started inside the master's body" in error
    assert "still unpaired after the first step, the first at (0, 1)" in error
    assert "prescribe the fit through the load path" in error


@pytest.mark.mpi
@pytest.mark.mpi_not3
def test_a_shallow_overlap_runs_without_a_warning(shrink_msh, shared_tmp, caplog):
    out = shared_tmp / "shallow"
    summary, warnings = _run(shrink_msh(0.06), out, caplog)
    assert warnings == []
    assert summary["status"] == "ok"
    _assert_lame(_pressures(out), 0.06)


@pytest.mark.mpi
@pytest.mark.mpi_not3
def test_nodes_pulled_into_reach_by_the_others_run_ok(shrink_msh, shared_tmp, caplog):
    """The counter-case: 4 nodes start beyond the reach (warned), the first step pairs
    them, and the run ends "ok" with Lamé's pressure at every node."""
    out = shared_tmp / "pulled"
    summary, warnings = _run(shrink_msh(0.15), out, caplog)
    assert len(warnings) == 1
    assert "4 slave node(s)" in warnings[0]
    assert summary["status"] == "ok"
    _assert_lame(_pressures(out), 0.15)


@pytest.mark.mpi
@pytest.mark.parametrize("delta", [0.1, 0.15])
@pytest.mark.mpi_not3
def test_a_frictional_shrink_fit_converges(shrink_msh, shared_tmp, caplog, delta):
    """μ = 0.3 (session 52): the exact answer is a radial fit, all stick with τ = 0.
    Before, the first iterates (p = ε δ ≈ 8400 at u = 0, then 2600 at the nodes the
    first step pairs) froze the stick/slip states on a slip reversal at the 5th Jacobian
    with 4 nodes OPEN; closing again, they followed the free law and slipped to and fro
    until max_it, at every cutback (residual 1.896 at δ = 0.1, 2.125 at δ = 0.15). An
    iterate with an active node deeper than DEEP_PENETRATION_TOL h is now not compared."""
    out = shared_tmp / f"friction_{delta:g}"
    summary, _ = _run(shrink_msh(delta), out, caplog, friction=0.3)
    assert summary["status"] == "ok", summary.get("error")
    assert summary["steps"][0]["cutbacks"] == 0
    d = _table(out)
    p, p_t = np.asarray(d["p_N"]), np.abs(np.asarray(d["p_T0"]))
    _assert_lame(p, delta)  # measured +1.6 % at either δ
    assert np.all(p_t <= 0.3 * p)
    assert p_t.max() < 0.1 * 0.3 * p.min()  # all stick, |τ| ≤ 0.05 μ p measured
    assert np.all(np.asarray(d["state"]) == 1)


def test_the_warning_comes_at_set_up(shrink_msh, caplog):
    """`dolfinx-mortar check` builds the problem (prepare): the warning comes there."""
    msh = shrink_msh(0.3)
    with caplog.at_level(logging.WARNING, logger="dolfinx_mortar"):
        problem, _ = prepare(
            parse_scene(_scene(msh, msh.parent / "unused"), msh.parent), MPI.COMM_WORLD
        )
    try:
        assert sum(WARNING in r.getMessage() for r in caplog.records) == 1
        (term,) = problem.contacts
        assert MPI.COMM_WORLD.allreduce(term.unseen_start.size) == 13
    finally:
        problem.destroy()
