"""3D Hertz: a sphere (R = 8) pressed onto a block, frictionless.

Quarter model (generator ``hertz3d``, x >= 0, y >= 0): the quarter hemisphere
carries P/4 of the total load P = 10, as the uniform traction -P/(pi R²) on its
flat top ``sphere_top`` (area pi R²/4); ``block_bottom`` is clamped,
``symmetry_x`` has u_x = 0 and ``symmetry_y`` u_y = 0. Both bodies linear-elastic
(E = 200, nu = 0.3), small kinematics; contact slave ``sphere_surface``, master
``block_top``, lumped recovery (``--recovery``), penalty "auto", Uzawa to 1e-6, 2 load steps.

Reference: a = (3 P R*/(4 E*))^(1/3), p0 = 3P/(2 pi a²) with R* = R, E* = E/(2(1 - nu²))
and the MEASURED load P = 4 × the z-component of the contact force (the faceted top
has slightly less area than pi R²/4, so the applied force is slightly below P/4).

Measured peak pressure and radius. The lumped nodal pressures scatter node to node
on this coarse unstructured tetrahedral surface (the maximum nodal pressure is printed,
``max nodal p error``, but it measures that scatter more than the peak), so both
measures are integrals of p_h, the piecewise-linear interpolant of the nodal pressures
on a Delaunay triangulation of the slave nodes projected onto z = 0:

- ``p0``: the mean of p_h over the quarter disc r < a/2 divided by its exact value for
  the Hertz profile, 8/3 (1 - (3/4)^(3/2)) p0 = 0.93462 p0 (a from the measured load);
- ``a``: the moment estimate a = sqrt(5/2 · ∫ r² p_h dA / ∫ p_h dA), exact for the
  Hertz profile; the bracket [largest active r, smallest inactive r beyond it] is
  printed as well;
- ``l2``: ‖p_h - p‖/‖p‖ over the quarter disc r < 1.25 a.

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_hertz3d.py [--refine K] [--integration segment] [--order 2]

(``--order 2``: P2 tetrahedra, whose slave facets carry P1 mixed fields: the vertex
functions of a P2 triangle integrate to zero.)

The default mesh (h_contact = 0.25, block 10 × 10 × 10) is coarse (about 3 slave
elements across the contact radius) so that it runs in seconds.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402

R = 8.0
E, NU = 200.0, 0.3
P = 10.0
H_CONTACT = 0.25
SLAVE, MASTER = "sphere_surface", "block_top"


def scene(
    refine: int = 0,
    integration: str = "element",
    W: float = 10.0,
    steps: int = 2,
    recovery: str = "lumped",
    order: int = 1,
) -> dict:
    """The scene dict of the quarter model at refinement level ``refine``, with P1 or P2
    tetrahedra (``order``)."""
    h = H_CONTACT / 2**refine
    return {
        "title": f"hertz3d quarter model, refine {refine}, P{order}, {integration}, {recovery}",
        "kinematics": "small",
        "mesh": {
            "generator": "hertz3d",
            "params": {
                "R": R,
                "W": W,
                "H": W,
                "h_contact": h,
                "c_zone": 1.25,
                "h_far": 2.5,
                "grading": 0.3,
                "order": order,
            },
        },
        "material": [
            {"region": "sphere", "model": "linear-elastic", "E": E, "nu": NU},
            {"region": "block", "model": "linear-elastic", "E": E, "nu": NU},
        ],
        "contact": [
            {
                "slave": SLAVE,
                "master": MASTER,
                "recovery": recovery,
                "integration": integration,
                "penalty": "auto",
                "uzawa_tol": 1e-6,
            }
        ],
        "dirichlet": [
            {"boundary": "block_bottom", "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]},
            {"boundary": "symmetry_x", "components": [0], "path": [[0.0, 0.0], [1.0, 0.0]]},
            {"boundary": "symmetry_y", "components": [1], "path": [[0.0, 0.0], [1.0, 0.0]]},
        ],
        "traction": [
            {
                "boundary": "sphere_top",
                "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, -P / (math.pi * R**2)]],
            }
        ],
        "steps": {"t_end": 1.0, "n": steps},
        "output": {"fields": ["contact_pressure", "gap", "contact_state"]},
    }


#: mean of sqrt(1 - r²/a²) over the disc r < a/2: 8/3 (1 - (3/4)^(3/2))
CENTRAL_MEAN = 8.0 / 3.0 * (1.0 - 0.75**1.5)


def _triangle_rule():
    """Symmetric 6-point rule on the triangle (degree 4): barycentrics and weights."""
    a, b = 0.816847572980459, 0.091576213509771
    c, d = 0.108103018168070, 0.445948490915965
    lam = np.array([[a, b, b], [b, a, b], [b, b, a], [c, d, d], [d, c, d], [d, d, c]])
    w = np.array([0.109951743655322] * 3 + [0.223381589678011] * 3)
    return lam, w


def pressure_measures(x: np.ndarray, y: np.ndarray, p: np.ndarray, a: float, p0: float) -> dict:
    """Integral measures of the nodal pressures on the quarter surface (see the module doc)."""
    from scipy.interpolate import LinearNDInterpolator
    from scipy.spatial import Delaunay

    pts = np.column_stack([x, y])
    tri = Delaunay(pts)
    X, Y, Pn = x[tri.simplices], y[tri.simplices], np.clip(p[tri.simplices], 0.0, None)
    area = 0.5 * np.abs(
        (X[:, 1] - X[:, 0]) * (Y[:, 2] - Y[:, 0]) - (X[:, 2] - X[:, 0]) * (Y[:, 1] - Y[:, 0])
    )
    lam, w = _triangle_rule()  # exact for p_h r² (degree 3) on each triangle
    xq, yq, pq = X @ lam.T, Y @ lam.T, Pn @ lam.T
    m0 = float(np.sum(area[:, None] * w * pq))
    m2 = float(np.sum(area[:, None] * w * pq * (xq**2 + yq**2)))
    a_mom = math.sqrt(2.5 * m2 / m0) if m0 > 0 else float("nan")

    # p_h sampled on a fine polar grid (midpoint rule in r and theta, weight r)
    ph_of = LinearNDInterpolator(tri, p, fill_value=0.0)

    def polar(rc, n_r=400, n_t=200):
        rr = (np.arange(n_r) + 0.5) / n_r * rc
        tt = (np.arange(n_t) + 0.5) / n_t * (0.5 * math.pi)
        rg, tg = np.meshgrid(rr, tt)
        ph = ph_of(rg * np.cos(tg), rg * np.sin(tg))
        pe = p0 * np.sqrt(np.clip(1.0 - (rg / a) ** 2, 0.0, None))
        return ph, pe, rg

    ph, _, rg = polar(0.5 * a)
    p0_h = float(np.sum(ph * rg) / np.sum(rg)) / CENTRAL_MEAN
    ph, pe, rg = polar(1.25 * a)
    l2 = math.sqrt(float(np.sum((ph - pe) ** 2 * rg) / np.sum(pe**2 * rg)))

    r = np.hypot(x, y)
    act = p > cm.ACTIVE_TOL * float(p.max())
    r_act = float(r[act].max()) if act.any() else 0.0
    beyond = r[(~act) & (r > r_act)]
    r_out = float(beyond.min()) if len(beyond) else r_act
    return {"a_mom": a_mom, "p0_h": p0_h, "l2": l2, "a_lo": r_act, "a_hi": r_out, "force": m0}


def evaluate(summary: dict, out_dir) -> dict:
    """Metrics of a finished run (rank 0: reads the final CSV)."""
    from dolfinx_mortar.analytic import effective_modulus, hertz3d

    F = cm.contact_force(summary, f"{SLAVE}:{MASTER}")
    P_meas = 4.0 * float(F[2])
    ref = hertz3d(P_meas, R, effective_modulus(E, NU))
    d = cm.final_csv(out_dir, SLAVE)
    x, y, p = d["x"], d["y"], d["p_N"]
    est = pressure_measures(x, y, p, ref["a"], ref["p0"])
    pmax = float(p.max())
    return {
        "P_measured": P_meas,
        "P_applied": P,
        "a": ref["a"],
        "p0": ref["p0"],
        "p0_measured": est["p0_h"],
        "p0_err": est["p0_h"] / ref["p0"] - 1.0,
        "p_max": pmax,
        "p_max_err": pmax / ref["p0"] - 1.0,
        "a_measured": est["a_mom"],
        "a_err": est["a_mom"] / ref["a"] - 1.0,
        "a_lo": est["a_lo"],
        "a_hi": est["a_hi"],
        "l2": est["l2"],
        "force_interpolant": 4.0 * est["force"],
        "negative": int(np.sum(p < 0.0)),
        "n_active": int(np.sum(p > cm.ACTIVE_TOL * pmax)),
        "newton_iterations": cm.newton_iterations(summary),
        "uzawa_rounds": [int(s["uzawa_rounds"]) for s in summary["steps"]],
        "cutbacks": int(sum(int(s.get("cutbacks", 0)) for s in summary["steps"])),
        "newton_order": cm.newton_orders(summary),
        "newton_order_text": cm.format_orders(summary),
        "round_off": [st.get("residual_round_off") for st in summary["steps"]],
        "slave_nodes": len(x),
        "dofs": summary.get("dofs"),
        "ranks": summary.get("ranks"),
    }


def main(argv=None) -> dict:
    ap = cm.parser(
        __doc__.splitlines()[0],
        "results/demo_hertz3d",
        recovery=True,
        acceleration=True,
        quadrature=True,
    )
    ap.add_argument("--W", type=float, default=10.0, help="block width and height [10]")
    ap.add_argument("--steps", type=int, default=2, help="load steps [2]")
    ap.add_argument("--order", type=int, choices=(1, 2), default=1, help="element order [1]")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    sc = scene(args.refine, args.integration, args.W, args.steps, args.recovery, args.order)
    cm.set_acceleration(sc, args.uzawa_acceleration)
    cm.set_quadrature(sc, args.quadrature_degree)
    summary, wall = cm.run_scene(sc, args.out, round_off=True)
    m = cm.on_root(evaluate, summary, args.out, comm=comm)
    m["wall_time"] = wall
    cm.report(
        f"hertz3d (quarter model): h_contact = {H_CONTACT / 2**args.refine:g}, "
        f"P{args.order}, {args.integration}, {args.recovery}, "
        f"{m['ranks']} rank(s), {m['dofs']} dofs, {m['slave_nodes']} slave nodes",
        [
            ("measured load P = 4 Fz", f"{m['P_measured']:.5f} (applied {P:g})"),
            ("Hertz a, p0", f"{m['a']:.5f}, {m['p0']:.5f}"),
            (
                "p0 error (central mean)",
                f"{100 * m['p0_err']:+.3f} % (p0_h = {m['p0_measured']:.5f})",
            ),
            ("max nodal p error", f"{100 * m['p_max_err']:+.3f} % (p_max = {m['p_max']:.5f})"),
            ("radius error (moment)", f"{100 * m['a_err']:+.3f} % (a_h = {m['a_measured']:.5f})"),
            ("L2 pressure error", f"{100 * m['l2']:.2f} % (r < 1.25 a)"),
            ("active-radius bracket", f"[{m['a_lo']:.4f}, {m['a_hi']:.4f}]"),
            ("∫ p_h dA (× 4) / P", f"{m['force_interpolant'] / m['P_measured']:.5f}"),
            ("negative nodal pressures", str(m["negative"])),
            ("Newton iterations per step", str(m["newton_iterations"])),
            ("Uzawa rounds per step", str(m["uzawa_rounds"])),
            ("step cutbacks", str(m["cutbacks"])),
            ("observed Newton order", m["newton_order_text"]),
            ("residual round-off level", ", ".join(f"{f:.1e}" for f in m["round_off"])),
            ("wall time", f"{wall:.2f} s"),
        ],
        comm,
    )
    return m


if __name__ == "__main__":
    cm.script(main, "demo_hertz3d")
