"""Twisting a Hertz contact until full slip: the torque plateau (3π/16) μ P a.

Generator ``twist3d`` (full lower hemisphere R = 8 on a 20 × 20 × 20 block),
tetrahedra, both bodies linear elastic E = 200, ν = 0.3, small kinematics,
Coulomb friction μ = 0.3 (slave ``sphere_surface``, master ``block_top``).
``block_bottom`` is clamped. ``sphere_top`` is a rigid platen: over t ∈ [0, 1] it
moves down by DEPTH (normal load P ≈ 77, a ≈ 1.6), over t ∈ [1, 2] it turns about
the z axis by θ(t) up to THETA (u = (−θ y, θ x, −DEPTH): a field Dirichlet
condition added with :meth:`~dolfinx_mortar.problem.ContactProblem.add_dirichlet_field`,
which a uniform scene path cannot express). P is the measured normal reaction and
the torque M_z = Σ (x R_y − y R_x) over the reactions R of ``sphere_top``; once every
contact node slips it stays on the plateau M = (3π/16) μ P a with
a = (3 P R / (4 E*))^(1/3), E* = E/(2(1 − ν²)), from the measured P.

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_twist3d.py [--refine K] [--integration segment]
        [--uzawa-acceleration newton|aitken|...]

The multipliers are updated by the exact (Newton) update between Uzawa rounds
(``--uzawa-acceleration newton``, the demo's default; the library's "auto" has been the
same here since session 41, Aitken with friction in 3D before).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

R, E, NU, MU = 8.0, 200.0, 0.3, 0.3
DEPTH = 0.3
THETA = 0.15
H_CONTACT = 0.3
SLAVE, MASTER = "sphere_surface", "block_top"


def analytic(P_: float) -> dict:
    e_star = E / (2.0 * (1.0 - NU**2))
    a = (3.0 * P_ * R / (4.0 * e_star)) ** (1.0 / 3.0)
    return {"a": a, "M": 3.0 * math.pi / 16.0 * MU * P_ * a}


def scene(
    refine: int = 0,
    integration: str = "element",
    n_twist: int = 6,
    h_contact: float = H_CONTACT,
    uzawa_tol: float = 1e-3,
) -> dict:
    return {
        "title": f"twist3d, refine {refine}, {integration}",
        "kinematics": "small",
        "mesh": {
            "generator": "twist3d",
            "params": {
                "R": R,
                "h_contact": h_contact / 2**refine,
                "c_zone": 1.8,
                "h_far": 4.0,
            },
        },
        "material": cm.elastic(("sphere", "block"), E, NU),
        "contact": [
            {
                "slave": SLAVE,
                "master": MASTER,
                "friction": MU,
                "integration": integration,
                "penalty": "auto",
                "uzawa_tol": uzawa_tol,
                "uzawa_max": 40,
            }
        ],
        "dirichlet": [
            {
                "boundary": "block_bottom",
                "components": [0, 1, 2],
                "path": [[0, 0, 0, 0], [2, 0, 0, 0]],
            }
        ],
        "steps": {
            "t_end": 2.0,
            "n": 2,
            "output_times": [0.25, 0.5, 0.75] + [1.0 + k / n_twist for k in range(1, n_twist)],
        },
        "output": {"fields": ["contact_pressure", "tangential_traction", "contact_state"]},
    }


def theta(t: float) -> float:
    return THETA * min(max(t - 1.0, 0.0), 1.0)


def platen_field(t, x):
    """The top face: down by DEPTH over [0, 1], then a rigid (linearised) rotation about
    the z axis by θ(t)."""
    th = theta(t)
    return np.stack([-th * x[1], th * x[0], np.full_like(x[0], -DEPTH * min(t, 1.0))])


class TorqueMeter:
    """Torque M_z of the reactions of ``sphere_top`` after each step (collective)."""

    def __init__(self):
        self.problem = None
        self.history = []

    def setup(self, problem):
        self.problem = problem
        problem.add_dirichlet_field("sphere_top", platen_field)

    def progress(self, step, record):
        p = self.problem
        X, F = p.nodal_reactions("sphere_top")
        local = float(np.sum(X[:, 0] * F[:, 1] - X[:, 1] * F[:, 0]))
        Pz = -float(record["reactions"]["sphere_top"][2])
        self.history.append((record["t"], p.comm.allreduce(local), Pz))


def evaluate(summary: dict, history) -> dict:
    ts = [t for t, _, _ in history]
    Ms = [abs(m) for _, m, _ in history]
    P_ = history[-1][2]
    ref = analytic(P_)
    last = summary["steps"][-1]
    return {
        "M": Ms[-1],
        "M_exact": ref["M"],
        "M_err": Ms[-1] / ref["M"] - 1.0,
        "a": ref["a"],
        "torque_history": list(zip(ts, Ms, strict=True)),
        "stick_nodes": last["stick_nodes"],
        "slip_nodes": last["slip_nodes"],
        "P_measured": P_,
        "P_contact": float(last["contact_force"][f"{SLAVE}:{MASTER}"][2]),
        **cm.solver_stats(summary),
        "dofs": summary.get("dofs"),
    }


def main(argv=None) -> dict:
    # the exact multiplier update (also what "auto" gives here): the same wall time as
    # Aitken on the default path, 2-4 Uzawa rounds per step instead of 4-14, at most 16
    # Newton iterations per step instead of 35 (BENCHMARKS §8, session 21)
    ap = cm.parser(
        "Twisting a Hertz contact (torque plateau)",
        "results/demo_twist3d",
        acceleration="newton",
        frame=True,
    )
    ap.add_argument(
        "--h-contact",
        type=float,
        default=H_CONTACT,
        help=f"contact-zone element size at refine 0 [{H_CONTACT}]",
    )
    ap.add_argument("--uzawa-tol", type=float, default=1e-3, help="Uzawa tolerance [1e-3]")
    ap.add_argument("--twist-steps", type=int, default=6, help="steps of the twist [6]")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    meter = TorqueMeter()
    sc = scene(
        args.refine,
        args.integration,
        n_twist=args.twist_steps,
        h_contact=args.h_contact,
        uzawa_tol=args.uzawa_tol,
    )
    summary, wall = cm.run_scene(
        cm.set_frame(cm.set_acceleration(sc, args.uzawa_acceleration), args.frame),
        args.out,
        comm,
        setup=meter.setup,
        progress=meter.progress,
    )
    meter.problem.destroy()  # setup received it: its holder frees it
    m = cm.on_root(evaluate, summary, meter.history, comm=comm)
    m["wall_time"] = wall
    hist = ", ".join(f"{t:.3g}:{M:.4g}" for t, M in m["torque_history"])
    cm.report(
        f"twist3d: {args.integration}, h = {args.h_contact / 2**args.refine:g}, {comm.size} rank(s), "
        f"{m['dofs']} dofs",
        [
            (
                "torque plateau",
                f"{m['M']:.4f} (exact {m['M_exact']:.4f}, {100 * m['M_err']:+.2f} %)",
            ),
            ("torque history (t:M)", hist),
            ("normal load P", f"{m['P_measured']:.4f} (contact force {m['P_contact']:.4f})"),
            ("stick / slip nodes", f"{m['stick_nodes']} / {m['slip_nodes']}"),
            *cm.solver_rows(m, wall),
        ],
        comm,
    )
    return m


if __name__ == "__main__":
    cm.script(main, "demo_twist3d")
