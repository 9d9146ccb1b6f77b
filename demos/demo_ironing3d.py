"""Ironing in 3D: a stiff cylindrical-shell die pressed into a soft slab, then slid along it.

Generator ``ironing3d`` (after Puso and Laursen): the die is the lower half of a
cylindrical shell (outer radius 3, wall 0.2, width 5.2 along y, wider than the slab),
E = 1000, ν = 0.3; the slab 11 × 4 × 3 (x from −4, so the contact zone never reaches its
free end), E = 1, ν = 0.3; both neo-Hookean, finite kinematics, P1 tetrahedra; Coulomb
friction μ = 0.3 (``--mu``), the SLAB surface ``slab_top`` as slave and ``die_surface``
as master (as in the 2D demo: the finer die as master). ``slab_bottom`` is clamped;
``die_top`` (the two flat ends of the shell) is driven: u_z goes to −PRESS (0.6, ``--press``)
over t ∈ [0, 1] in ``--press-steps`` (5), then u_x goes to +SLIDE (2, ``--slide``) over
t ∈ [1, 2] in ``--slide-steps`` (21), u_y = 0 throughout. With 20 steps a step ends at
u_x = 0.5, the slab element size, where Newton once stalled at a residual of 1e-3…1e-2
however far the step was cut back (a row of slab nodes on a kink of the faceted die,
where the element-integration gap is only C⁰, probably); at session 66 20 steps
complete as well (F_x/F_z 0.3027, at most 13 Newton iterations per solve, no cutback),
and the default stays 21. Penalty "auto", ε_T = E*/h,
Uzawa to ``--uzawa-tol`` (1e-2: with friction the rounds converge slowly; at 1e-3 a step
took 14–20 rounds); Newton steps penetration-limited (``--step-depth-limit`` 0.25, as in
2D: no slab node out of contact goes deeper than 0.25 h in one Newton step).

Forces per converged step: R = the reaction on ``die_top``; F_x = R_x (the drag) and
F_z = −R_z (the normal force). Metrics: the plateau ratio F_x/F_z and the oscillation
of F_x and F_z (relative range and detrended std, as in ``demo_ironing2d``) over the
window u_x ≥ 1 (gross slip), whether the whole path finished without a failed step,
Newton iterations. ``--plot`` writes F_x and F_z against u_x to ``ironing3d_forces.png``.

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_ironing3d.py [--refine 1] [--plot]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import numpy as np  # noqa: E402
from demo_ironing2d import (  # noqa: E402
    STEP_DEPTH_LIMIT,
    plot,
    report_run,
    run_scene,
    window_stats,
)
from mpi4py import MPI  # noqa: E402

E_DIE, E_SLAB, NU = 1000.0, 1.0, 0.3
PRESS, SLIDE, MU = 0.6, 2.0, 0.3
#: level-0 element sizes: slab along the path, die, far field
H_CONTACT, H_DIE, H_FAR = 0.5, 0.4, 1.5
WINDOW = 1.0
E_STAR = 1.0 / ((1.0 - NU**2) / E_DIE + (1.0 - NU**2) / E_SLAB)


def scene(
    mu: float = MU,
    refine: int = 0,
    integration: str = "element",
    n_press: int = 5,
    n_slide: int = 21,
    press: float = PRESS,
    slide: float = SLIDE,
    uzawa_tol: float = 1e-2,
    step_depth_limit: float = STEP_DEPTH_LIMIT,
) -> dict:
    """The scene dict (SCENES.md) at refinement level ``refine`` (element sizes halved)."""
    h = H_CONTACT / 2**refine
    return {
        "title": f"ironing3d, mu {mu}, refine {refine}, {integration}",
        "kinematics": "finite",
        "mesh": {
            "generator": "ironing3d",
            "params": {
                "h_contact": h,
                "h_die": H_DIE / 2**refine,
                "h_far": H_FAR / 2**refine,
                "x_left": -4.0,
                "L": 11.0,
                "c_zone": 2.4,
                "slide": slide,
            },
        },
        "material": [
            {"region": "die", "model": "neo-hookean", "E": E_DIE, "nu": NU},
            {"region": "slab", "model": "neo-hookean", "E": E_SLAB, "nu": NU},
        ],
        "contact": [
            {
                "slave": "slab_top",
                "master": "die_surface",
                "friction": mu,
                "integration": integration,
                "penalty": "auto",
                "penalty_tangential": E_STAR / h,
                "uzawa_tol": uzawa_tol,
                "uzawa_max": 40,
            }
        ],
        "dirichlet": [
            {
                "boundary": "slab_bottom",
                "components": [0, 1, 2],
                "path": [[0, 0, 0, 0], [2, 0, 0, 0]],
            },
            {
                "boundary": "die_top",
                "components": [0, 1, 2],
                "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, -press], [2.0, slide, 0.0, -press]],
            },
        ],
        "steps": {
            "t_end": 2.0,
            "n": 2,
            "output_times": [k / n_press for k in range(1, n_press)]
            + [1.0 + k / n_slide for k in range(1, n_slide)],
        },
        "solver": {"step_depth_limit": step_depth_limit},
        "output": {"fields": ["contact_pressure", "tangential_traction", "contact_state"]},
    }


def evaluate(summary: dict, mu: float, slide: float, h: float) -> dict:
    """Force history and metrics (rank 0; summary.json only)."""
    steps = summary["steps"]
    t = np.array([float(st["t"]) for st in steps])
    R = np.array([st["reactions"]["die_top"] for st in steps], float).reshape(-1, 3)
    fx, fz = R[:, 0], -R[:, 2]
    ux = np.where(t > 1.0, slide * (t - 1.0), 0.0)
    ratio = np.divide(fx, fz, out=np.full_like(fx, np.nan), where=fz > 0)
    stats = cm.solver_stats(summary)
    m = {
        "mu": mu,
        "t": t.tolist(),
        "u_x": ux.tolist(),
        "F_x": fx.tolist(),
        "F_z": fz.tolist(),
        "F_y": R[:, 1].tolist(),
        "ratio": ratio.tolist(),
        "stick_nodes": [int(st["stick_nodes"]) for st in steps],
        "slip_nodes": [int(st["slip_nodes"]) for st in steps],
        "t_reached": float(t[-1]) if len(t) else 0.0,
        **stats,
        "status": summary.get("status"),
        "error": summary.get("error"),
        "dofs": summary.get("dofs"),
        "ranks": summary.get("ranks"),
    }
    win = ux >= WINDOW - 1e-9
    if m["status"] == "ok" and win.sum() >= 3:
        m["plateau_ratio"] = float(np.mean(ratio[win]))
        m["plateau_ratio_range"] = [float(ratio[win].min()), float(ratio[win].max())]
        m["osc_F_x"] = window_stats(ux[win], fx[win], h)
        m["osc_F_z"] = window_stats(ux[win], fz[win], h)
    return m


def main(argv=None) -> dict:
    ap = cm.parser(
        "Ironing 3D (cylindrical-shell die slid along a soft slab)",
        "results/demo_ironing3d",
        frame=True,
    )
    ap.add_argument("--mu", type=float, default=MU, help=f"friction coefficient [{MU}]")
    ap.add_argument("--press-steps", type=int, default=5, help="steps of the press [5]")
    ap.add_argument("--slide-steps", type=int, default=21, help="steps of the slide [21]")
    ap.add_argument("--press", type=float, default=PRESS, help=f"die indentation [{PRESS}]")
    ap.add_argument("--slide", type=float, default=SLIDE, help=f"die travel [{SLIDE}]")
    ap.add_argument("--uzawa-tol", type=float, default=1e-2, help="Uzawa tolerance [1e-2]")
    cm.add_step_depth_limit(ap, STEP_DEPTH_LIMIT)
    ap.add_argument("--plot", action="store_true", help="write F_x, F_z against u_x")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    h = H_CONTACT / 2**args.refine
    sc = scene(
        mu=args.mu,
        refine=args.refine,
        integration=args.integration,
        n_press=args.press_steps,
        n_slide=args.slide_steps,
        press=args.press,
        slide=args.slide,
        uzawa_tol=args.uzawa_tol,
        step_depth_limit=args.step_depth_limit,
    )
    summary, wall = run_scene(cm.set_frame(sc, args.frame), args.out, comm)
    m = cm.on_root(evaluate, summary, args.mu, args.slide, h, comm=comm)
    m["wall_time"] = wall
    if args.plot and comm.rank == 0:
        m["png"] = plot(m, Path(args.out) / "ironing3d_forces.png", "F_z", "ironing3d")
    rows = [("status, cutbacks", f"{m['status']}, {m['cutbacks']} (t reached {m['t_reached']:g})")]
    if "plateau_ratio" in m:
        ox, oz = m["osc_F_x"], m["osc_F_z"]
        lo, hi = m["plateau_ratio_range"]
        rows += [
            (
                f"plateau F_x/F_z (u_x ≥ {WINDOW:g})",
                f"{m['plateau_ratio']:.4f} [{lo:.4f}, {hi:.4f}] (μ = {args.mu})",
            ),
            ("plateau F_x, F_z", f"{ox['mean']:.5f}, {oz['mean']:.5f}"),
            (
                "F_x (max−min)/mean, detr. std",
                f"{100 * ox['range']:.2f} %, {100 * ox['std']:.2f} %",
            ),
            (
                "F_z (max−min)/mean, detr. std",
                f"{100 * oz['range']:.2f} %, {100 * oz['std']:.2f} %",
            ),
        ]
    rows += [
        (
            "solves finished by full steps, restarted after a NaN",
            f"{m['full_step_solves']}, {m['backtracked_solves']}",
        ),
        ("failed attempts from the predictor", str(m["predictor_failures"])),
        ("Newton steps shortened (depth limit)", str(m["limited_steps"])),
        ("Newton: max per solve", str(m["max_newton_per_solve"])),
        ("max Uzawa rounds", str(max(m["uzawa_rounds"], default=0))),
        ("wall time", f"{wall:.1f} s"),
    ]
    title = (
        f"ironing3d: μ = {args.mu}, {args.integration}, h = {h:g}, {m['ranks']} rank(s), "
        f"{m['dofs']} dofs, {args.press_steps}+{args.slide_steps} steps"
    )
    return report_run(title, rows, m, comm)


if __name__ == "__main__":
    cm.script(main, "demo_ironing3d")
