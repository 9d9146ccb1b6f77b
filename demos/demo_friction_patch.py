"""Frictional contact patch test: uniform pressure and shear, in stick or in uniform sliding.

Two stacked blocks (generators ``patch2d`` / ``patch3d``, non-matching interface
meshes), linear elastic with E = 100 and ν = 0 (so a uniform stress state needs
no lateral constraint), small kinematics, Coulomb friction μ = 0.5 on the
interface (slave ``upper_bottom``, master ``lower_top``). ``lower_bottom`` is
clamped. The exact solution is the uniform stress σ_yy = −p0, σ_xy = q (z for
y in 3D) in both blocks, loaded by the tractions of that stress on every other
boundary face: (q, −p0) on ``upper_top`` and the vertical shear (0, ∓q) on the
sides x = 0 and x = L.

- ``--mode stick`` (default): q = 0.4 p0 < μ p0. Every slave node must stick with
  p_N = p0 and the tangential traction of the master on the slave p_T0 = −q.
- ``--mode slide``: the lower block is longer (it overhangs the upper one by 0.2,
  so the slave never leaves it) and rigid (every boundary of it clamped, the
  master surface included); ``upper_top`` is driven sideways by 0.05 (u_x
  prescribed) under the pressure p0, with the side shear q = μ p0 of the
  sliding state. Every node must slip with p_N = p0 and p_T0 = −μ p0.

Both to round-off with ``--integration segment``, to the quadrature error of the
element rule with ``element``: ≤ 2 % on quadrilaterals, triangles and hexahedra, 6.9 %
(p_N) and 3.3 % (p_T) in 3D stick with ``--tri`` (tetrahedra; BENCHMARKS.md §4). The
slide mode's master is rigid: round-off there with either.

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_friction_patch.py [--dim 3] [--mode slide] [--integration segment]
        [--uzawa-acceleration newton]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

E, NU, MU = 100.0, 0.0, 0.5
P0, L, H = 2.0, 1.0, 0.5
Q_STICK = 0.4 * P0
SLIDE = 0.05


def scene(dim: int, mode: str, integration: str, refine: int = 0, quads: bool = True) -> dict:
    """Scene dict of the frictional patch test (see the module docstring)."""
    n_lower, n_upper = (5, 7) if dim == 2 else (4, 5)
    k = 2**refine
    q = Q_STICK if mode == "stick" else MU * P0
    z = dim - 1  # the normal direction
    zero = [0.0] * dim

    def vec(normal, shear):
        v = [0.0] * dim
        v[z], v[0] = normal, shear
        return v

    side = []
    for body in ("lower", "upper") if mode == "stick" else ("upper",):
        side += [
            {"boundary": f"{body}_left", "path": [[0.0, *zero], [1.0, *vec(-q, 0.0)]]},
            {"boundary": f"{body}_right", "path": [[0.0, *zero], [1.0, *vec(q, 0.0)]]},
        ]
    dirichlet = [
        {
            "boundary": "lower_bottom",
            "components": list(range(dim)),
            "path": [[0, *zero], [1, *zero]],
        }
    ]
    if mode == "stick":
        top = [{"boundary": "upper_top", "path": [[0.0, *zero], [1.0, *vec(-P0, q)]]}]
    else:
        top = [{"boundary": "upper_top", "path": [[0.0, *zero], [1.0, *vec(-P0, 0.0)]]}]
        dirichlet.append(
            {"boundary": "upper_top", "components": [0], "path": [[0.0, 0.0], [1.0, SLIDE]]}
        )
        rigid = ["lower_top", "lower_left", "lower_right"]
        if dim == 3:
            rigid += ["lower_front", "lower_back"]
        for b in rigid:
            dirichlet.append(
                {"boundary": b, "components": list(range(dim)), "path": [[0, *zero], [1, *zero]]}
            )
    return {
        "title": f"friction patch {dim}D {mode}, {integration}, refine {refine}",
        "kinematics": "small",
        "mesh": {
            "generator": f"patch{dim}d",
            "params": {
                "L": L,
                "H": H,
                "n_lower": n_lower * k,
                "n_upper": n_upper * k,
                "n_y": 3 * k,
                "margin": 0.0 if mode == "stick" else 0.2,
                "quads": quads,
            },
        },
        "material": cm.elastic(("lower", "upper"), E, NU),
        "contact": [
            {
                "slave": "upper_bottom",
                "master": "lower_top",
                "friction": MU,
                "integration": integration,
                "penalty": "auto",
                "uzawa_tol": 1e-9,
                "uzawa_max": 40,
            }
        ],
        "dirichlet": dirichlet,
        "traction": top + side,
        "steps": {"t_end": 1.0, "n": 2},
        "output": {"fields": ["contact_pressure", "tangential_traction", "contact_state"]},
    }


def evaluate(summary: dict, out_dir, dim: int, mode: str) -> dict:
    """Metrics of a finished run (rank 0: reads the final CSV)."""
    d = cm.final_csv(out_dir, "upper_bottom")
    q = Q_STICK if mode == "stick" else MU * P0
    want_state = 1 if mode == "stick" else 2
    pt = d["p_T0"]
    F = cm.contact_force(summary, "upper_bottom:lower_top")
    area = L ** (dim - 1)
    return {
        "p_err": float(np.max(np.abs(d["p_N"] / P0 - 1.0))),
        "q_err": float(np.max(np.abs(-pt / q - 1.0))),
        "q_cross": float(np.max(np.abs(d["p_T1"]))) / q if dim == 3 else 0.0,
        "wrong_state": int(np.sum(d["state"] != want_state)),
        "slave_nodes": len(pt),
        "force_normal_err": abs(F[dim - 1] / (P0 * area) - 1.0),
        "force_tangential_err": abs(-F[0] / (q * area) - 1.0),
        **cm.solver_stats(summary),
        "modelled": summary["modelled"]["contact_pairs"]["upper_bottom:lower_top"],
    }


def main(argv=None) -> dict:
    ap = cm.parser(
        "Frictional contact patch test",
        "results/demo_friction_patch",
        frame=True,
        acceleration=True,
    )
    ap.add_argument("--dim", type=int, choices=(2, 3), default=2, help="dimension [2]")
    ap.add_argument("--mode", choices=("stick", "slide"), default="stick", help="[stick]")
    ap.add_argument("--tri", action="store_true", help="triangles/tetrahedra")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    sc = scene(args.dim, args.mode, args.integration, args.refine, quads=not args.tri)
    cm.set_acceleration(cm.set_frame(sc, args.frame), args.uzawa_acceleration)
    summary, wall = cm.run_scene(sc, args.out, comm)
    m = cm.on_root(evaluate, summary, args.out, args.dim, args.mode, comm=comm)
    m["wall_time"] = wall
    cm.report(
        f"friction patch {args.dim}D, {args.mode}, {args.integration}: "
        f"{m['slave_nodes']} slave nodes, {comm.size} rank(s)",
        [
            ("max |p_N/p0 - 1|", f"{m['p_err']:.3e}"),
            ("max |p_T/q - 1|", f"{m['q_err']:.3e}"),
            ("nodes in the wrong state", str(m["wrong_state"])),
            (
                "contact force errors (n, t)",
                f"{m['force_normal_err']:.2e}, {m['force_tangential_err']:.2e}",
            ),
            ("dissipation per step", str(m["dissipation"])),
            ("Newton iterations", str(m["newton_iterations"])),
            ("Uzawa rounds", str(m["uzawa_rounds"])),
            ("wall time", f"{wall:.2f} s"),
        ],
        comm,
    )
    return m


if __name__ == "__main__":
    cm.script(main, "demo_friction_patch")
