"""Sliding wedge: a block pressed onto an incline, then pushed uphill until gross slip.

Generator ``wedge2d`` (tan α = 0.1): the block (1 × 1) sits on the incline of the
wedge; both linear elastic, E = 1000, ν = 0.3, plane strain; Coulomb friction μ
(0.3 by default, ``--mu``) between ``block_bottom`` (slave) and ``wedge_top``
(master). ``wedge_bottom`` is clamped. Over t ∈ [0, 1] the vertical traction on
``block_top`` rises to 1 (F_y = 1) while ``block_left`` is held (u_x = 0); over
t ∈ [1, 2] ``block_left`` is pushed uphill (u_x → 0.05). The horizontal push
F_x is the reaction of ``block_left``. Once the block slides, F_x stays on the
plateau F_x/F_y = (tan α + μ)/(1 − μ tan α) (0.41237 for μ = 0.3, 0.63158 for
μ = 0.5), the value at which slip starts under a monotonic push.

Metrics: the plateau ratio and its error, the step at which every node slips,
the ratio history, Newton iterations.

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_wedge.py [--mu 0.5] [--integration segment]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

TAN_ALPHA = 0.1
E, NU = 1000.0, 0.3
PUSH = 0.05
SLAVE, MASTER = "block_bottom", "wedge_top"


def exact_ratio(mu: float) -> float:
    """Gross-slip ratio F_x/F_y of a block pushed up an incline of slope tan α."""
    return (TAN_ALPHA + mu) / (1.0 - mu * TAN_ALPHA)


def scene(mu: float, refine: int = 0, integration: str = "element", n_push: int = 8) -> dict:
    return {
        "title": f"wedge, mu {mu}, refine {refine}, {integration}",
        "kinematics": "small",
        "mesh": {
            "generator": "wedge2d",
            "params": {"tan_alpha": TAN_ALPHA, "h_contact": 0.1 / 2**refine, "h_far": 0.25},
        },
        "material": cm.elastic(("block", "wedge"), E, NU),
        "contact": [
            {
                "slave": SLAVE,
                "master": MASTER,
                "friction": mu,
                "integration": integration,
                "penalty": "auto",
                "uzawa_tol": 1e-6,
                "uzawa_max": 40,
            }
        ],
        "dirichlet": [
            {"boundary": "wedge_bottom", "components": [0, 1], "path": [[0, 0, 0], [2, 0, 0]]},
            {
                "boundary": "block_left",
                "components": [0],
                "path": [[0.0, 0.0], [1.0, 0.0], [2.0, PUSH]],
            },
        ],
        "traction": [
            {"boundary": "block_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -1.0], [2.0, 0.0, -1.0]]}
        ],
        "steps": {
            "t_end": 2.0,
            "n": 2,
            "output_times": [1.0 + k / n_push for k in range(1, n_push)],
        },
        "output": {"fields": ["contact_pressure", "tangential_traction", "contact_state"]},
    }


def evaluate(summary: dict, mu: float) -> dict:
    pair = f"{SLAVE}:{MASTER}"
    ratios, all_slip = [], []
    for st in summary["steps"]:
        fx = float(st["reactions"]["block_left"][0])
        fy = -float(st["contact_force"][pair][1])  # the block presses the wedge down by F_y
        ratios.append(fx / (-fy) if fy else 0.0)
        all_slip.append(st["active_nodes"] > 0 and st["stick_nodes"] == 0)
    F = np.asarray(summary["steps"][-1]["contact_force"][pair], float)
    fx = float(summary["steps"][-1]["reactions"]["block_left"][0])
    ratio = fx / F[1]
    first = next((i for i, s in enumerate(all_slip) if s), None)
    return {
        "mu": mu,
        "ratio": ratio,
        "exact": exact_ratio(mu),
        "ratio_err": ratio / exact_ratio(mu) - 1.0,
        "gross_slip_step": first,
        "t_gross_slip": summary["steps"][first]["t"] if first is not None else None,
        "ratios": [fx_ / 1.0 for fx_ in ratios],
        "slip_nodes": summary["steps"][-1]["slip_nodes"],
        "stick_nodes": summary["steps"][-1]["stick_nodes"],
        **cm.solver_stats(summary),
    }


def main(argv=None) -> dict:
    ap = cm.parser("Block pushed up a wedge until gross slip", "results/demo_wedge", frame=True)
    ap.add_argument("--mu", type=float, default=0.3, help="friction coefficient [0.3]")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    sc = cm.set_frame(scene(args.mu, args.refine, args.integration), args.frame)
    summary, wall = cm.run_scene(sc, args.out, comm)
    m = cm.on_root(evaluate, summary, args.mu, comm=comm)
    m["wall_time"] = wall
    cm.report(
        f"wedge: μ = {args.mu}, tan α = {TAN_ALPHA}, {args.integration}, {comm.size} rank(s)",
        [
            (
                "plateau F_x/F_y",
                f"{m['ratio']:.6f} (exact {m['exact']:.6f}, {m['ratio_err']:+.2e})",
            ),
            ("gross slip from t", str(m["t_gross_slip"])),
            ("stick / slip nodes (end)", f"{m['stick_nodes']} / {m['slip_nodes']}"),
            *cm.solver_rows(m, wall),
        ],
        comm,
    )
    return m


if __name__ == "__main__":
    cm.script(main, "demo_wedge")
