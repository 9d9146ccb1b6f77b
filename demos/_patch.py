"""The contact patch test shared by ``demo_patch2d.py`` and ``demo_patch3d.py``.

Two stacked blocks (generators ``patch2d`` / ``patch3d``, L = 1, H = 0.5 each,
non-matching interface meshes: 5 and 7 elements along x in 2D, 4 and 5 along x
and y in 3D), both linear-elastic E = 100, nu = 0.3, small kinematics. A uniform
pressure p0 = 2 on ``upper_top``; ``lower_bottom`` has u_{d-1} = 0 (vertical),
``lower_left``/``upper_left`` u_x = 0 and, in 3D, ``lower_front``/``upper_front``
u_y = 0. Both blocks have the same material, so the exact solution is the uniform
stress sigma_{d-1,d-1} = -p0 in both (equal lateral expansion, no sliding) and the
interface pressure is p0 at every slave node.

Contact: slave ``upper_bottom`` (the finer side), master ``lower_top``; with
``--swap`` slave ``lower_top`` (the coarser side), master ``upper_bottom``.
Lumped recovery (``--recovery``), penalty "auto", Uzawa to 1e-8, one load step.

Metrics: max |p/p0 - 1| over all slave nodes, the normal contact force against
p0 × area, the number of slave nodes not in contact. Expected: round-off with
``--integration segment`` (``--recovery constrained``: Newton's tolerance, 5e-12 in 2D and
3e-10 in 3D; BENCHMARKS.md §4, session 53); a quadrature error with ``element``: <= 2 % on quadrilaterals,
triangles and hexahedra (2D 0.1–0.5 %, 3D 1.2–1.9 %) and on tetrahedra with the default
rule of degree 12 (3D ``--tri``: 2.8e-3 slave finer, 8.9e-3 coarser; BENCHMARKS.md §90,
§94); 5–7 % on tetrahedra with ``--quadrature-degree 4`` (7.0e-2, 5.0e-2; 6 points, the
default before session 66 and of frictional pairs; BENCHMARKS.md §4), 1.30e-2 and 1.21e-2
with ``--quadrature-degree 6`` (the pair's ``quadrature_degree``: 12 points on a triangle).
"""

from __future__ import annotations

import _common as cm
import numpy as np
from mpi4py import MPI

E, NU = 100.0, 0.3
P0 = 2.0
L = 1.0


def scene(
    dim: int,
    refine: int = 0,
    integration: str = "element",
    swap: bool = False,
    quads=True,
    recovery: str = "lumped",
):
    """Scene dict of the patch test in ``dim`` = 2 or 3 dimensions."""
    n_lower, n_upper = (5, 7) if dim == 2 else (4, 5)
    k = 2**refine
    slave, master = ("lower_top", "upper_bottom") if swap else ("upper_bottom", "lower_top")
    zero = [0.0] * dim
    dirichlet = [
        {"boundary": "lower_bottom", "components": [dim - 1], "path": [[0.0, 0.0], [1.0, 0.0]]},
        {"boundary": "lower_left", "components": [0], "path": [[0.0, 0.0], [1.0, 0.0]]},
        {"boundary": "upper_left", "components": [0], "path": [[0.0, 0.0], [1.0, 0.0]]},
    ]
    if dim == 3:
        dirichlet += [
            {"boundary": "lower_front", "components": [1], "path": [[0.0, 0.0], [1.0, 0.0]]},
            {"boundary": "upper_front", "components": [1], "path": [[0.0, 0.0], [1.0, 0.0]]},
        ]
    return {
        "title": f"patch{dim}d, refine {refine}, {integration}, slave {slave}",
        "kinematics": "small",
        "mesh": {
            "generator": f"patch{dim}d",
            "params": {
                "L": L,
                "H": 0.5,
                "n_lower": n_lower * k,
                "n_upper": n_upper * k,
                "n_y": 3 * k,
                "quads": quads,
            },
        },
        "material": [
            {"region": "lower", "model": "linear-elastic", "E": E, "nu": NU},
            {"region": "upper", "model": "linear-elastic", "E": E, "nu": NU},
        ],
        "contact": [
            {
                "slave": slave,
                "master": master,
                "recovery": recovery,
                "integration": integration,
                "penalty": "auto",
                "uzawa_tol": 1e-8,
            }
        ],
        "dirichlet": dirichlet,
        "traction": [{"boundary": "upper_top", "path": [[0.0, *zero], [1.0, *zero[:-1], -P0]]}],
        "steps": {"t_end": 1.0, "n": 1},
        "output": {"fields": ["contact_pressure", "gap", "contact_state"]},
    }


def evaluate(summary: dict, out_dir, dim: int, slave: str, master: str) -> dict:
    """Metrics of a finished patch test (rank 0: reads the final CSV)."""
    d = cm.final_csv(out_dir, slave)
    p = d["p_N"]
    F = cm.contact_force(summary, f"{slave}:{master}")
    # the force the master exerts on the slave: +y(z) on the upper block, -y(z) on the lower
    sign = 1.0 if slave.startswith("upper") else -1.0
    area = L ** (dim - 1)
    Fn = sign * float(F[dim - 1])
    return {
        "p_err": float(np.max(np.abs(p / P0 - 1.0))),
        "p_min": float(p.min()),
        "p_max": float(p.max()),
        "force": Fn,
        "force_err": abs(Fn - P0 * area) / (P0 * area),
        "tangential_force": float(np.max(np.abs(F[: dim - 1]))),
        "open_nodes": int(np.sum(d["state"] == 0)),
        "slave_nodes": len(p),
        "newton_iterations": cm.newton_iterations(summary),
        "uzawa_rounds": [int(s["uzawa_rounds"]) for s in summary["steps"]],
        "dofs": summary.get("dofs"),
        "ranks": summary.get("ranks"),
    }


def main(dim: int, argv=None) -> dict:
    ap = cm.parser(
        f"Contact patch test, {dim}D",
        f"results/demo_patch{dim}d",
        recovery=True,
        acceleration=True,
        quadrature=True,
    )
    ap.add_argument(
        "--swap", action="store_true", help="slave = lower_top (the coarser side), master = upper"
    )
    ap.add_argument(
        "--tri", action="store_true", help="triangles/tetrahedra instead of quads/hexahedra"
    )
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    sc = scene(dim, args.refine, args.integration, args.swap, not args.tri, args.recovery)
    cm.set_quadrature(sc, args.quadrature_degree)
    cm.set_acceleration(sc, args.uzawa_acceleration)
    slave, master = sc["contact"][0]["slave"], sc["contact"][0]["master"]
    summary, wall = cm.run_scene(sc, args.out, comm)
    m = cm.on_root(evaluate, summary, args.out, dim, slave, master, comm=comm)
    m["wall_time"] = wall
    m["integration"] = args.integration
    m["recovery"] = args.recovery
    m["slave"] = slave
    cm.report(
        f"patch{dim}d: slave {slave} ({'coarser' if args.swap else 'finer'}), master {master}, "
        f"{args.integration}, {args.recovery}, refine {args.refine}, {m['ranks']} rank(s), {m['dofs']} dofs, "
        f"{m['slave_nodes']} slave nodes",
        [
            ("max |p/p0 - 1|", f"{m['p_err']:.3e} (p in [{m['p_min']:.6f}, {m['p_max']:.6f}])"),
            ("contact force / (p0 area) - 1", f"{m['force'] / (P0 * L ** (dim - 1)) - 1:+.3e}"),
            ("max |tangential force|", f"{m['tangential_force']:.3e}"),
            ("open slave nodes", str(m["open_nodes"])),
            ("Newton iterations", str(m["newton_iterations"])),
            ("Uzawa rounds", str(m["uzawa_rounds"])),
            ("wall time", f"{wall:.2f} s"),
        ],
        comm,
    )
    return m
