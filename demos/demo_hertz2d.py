"""2D Hertz: a cylinder (R = 8) pressed onto a block, plane strain, frictionless.

Half model (generator ``hertz2d``, x >= 0): the quarter disc carries half the load,
P/2 = 5 per unit length, as the uniform traction -P/(2R) on its flat top
``cylinder_top`` (length R); ``block_bottom`` is clamped, ``symmetry`` has u_x = 0.
Both bodies linear-elastic (E = 200, nu = 0.3), small kinematics, quadrilaterals
(``--tri``: triangles); contact slave
``cylinder_surface``, master ``block_top``, lumped recovery (``--recovery``), penalty "auto",
Uzawa to 1e-6, 4 load steps.

The nodal pressures of the final step are mirrored onto x < 0 and compared with
Hertz's p(x) = p0 sqrt(1 - x²/a²), a = 2 sqrt(P R*/(pi E*)), p0 = 2P/(pi a), with
R* = R (flat block), E* = E/(2(1 - nu²)) and the MEASURED load P = 2 × the
y-component of the contact force (BENCHMARKS.md: a = 0.9628, p0 = 6.612 at P = 10).

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_hertz2d.py [--refine K] [--order 2] [--integration segment]
                                          [--tri] [--load P]

Known figures (h_contact = 0.1 ≈ a/10, Q1): L2 ≈ 1.9 %, p_max ≈ 0.3 %; 1.2 % L2 with Q2.
P1 triangles (``--tri``) are stiffer at the same h: L2 ≈ 3.6 %, half-width −4.4 %.
"""

from __future__ import annotations

import sys
from pathlib import Path

from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402

R = 8.0
E, NU = 200.0, 0.3
P = 10.0  # total load per unit length (the half model carries P/2)
H_CONTACT = 0.1
SLAVE, MASTER = "cylinder_surface", "block_top"


def scene(
    refine: int = 0,
    order: int = 1,
    integration: str = "element",
    steps: int = 4,
    quads: bool = True,
    recovery: str = "lumped",
    load: float = P,
) -> dict:
    """The scene dict (SCENES.md) of the half model at refinement level ``refine``;
    ``quads``: quadrilaterals (True) or triangles; ``load``: the total load P per unit
    length (the half model carries P/2)."""
    return {
        "title": f"hertz2d half model, refine {refine}, order {order}, {integration}, {recovery}",
        "kinematics": "small",
        "mesh": {
            "generator": "hertz2d",
            "params": {
                "R": R,
                "h_contact": H_CONTACT / 2**refine,
                "order": order,
                "quads": quads,
            },
        },
        "material": [
            {"region": "cylinder", "model": "linear-elastic", "E": E, "nu": NU},
            {"region": "block", "model": "linear-elastic", "E": E, "nu": NU},
        ],
        "contact": [
            {
                "slave": SLAVE,
                "master": MASTER,
                "friction": 0.0,
                "recovery": recovery,
                "integration": integration,
                "penalty": "auto",
                "uzawa_tol": 1e-6,
            }
        ],
        "dirichlet": [
            {"boundary": "block_bottom", "components": [0, 1], "path": [[0.0, 0, 0], [1.0, 0, 0]]},
            {"boundary": "symmetry", "components": [0], "path": [[0.0, 0.0], [1.0, 0.0]]},
        ],
        "traction": [
            {"boundary": "cylinder_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -load / (2.0 * R)]]}
        ],
        "steps": {"t_end": 1.0, "n": steps},
        "output": {"fields": ["contact_pressure", "gap", "contact_state"]},
    }


def evaluate(summary: dict, out_dir, nu: float = NU, load: float = P) -> dict:
    """Metrics of a finished run (rank 0: reads the final CSV); ``nu``: Poisson's ratio of
    both bodies (the reference's E*); ``load``: the applied total load P."""
    from dolfinx_mortar.analytic import effective_modulus, hertz2d

    F = cm.contact_force(summary, f"{SLAVE}:{MASTER}")
    P_meas = 2.0 * float(F[1])
    ref = hertz2d(P_meas, R, effective_modulus(E, nu))
    d = cm.final_csv(out_dir, SLAVE)
    x, p = cm.mirror(d["x"], d["p_N"])
    m = cm.profile_metrics(x, p, ref["a"], ref["p0"])
    m.update(
        P_measured=P_meas,
        a=ref["a"],
        p0=ref["p0"],
        force_balance=abs(float(F[1]) - 0.5 * load) / (0.5 * load),
        oscillation=cm.oscillation_index(p, ref["p0"]),
        newton_iterations=cm.newton_iterations(summary),
        uzawa_rounds=[int(s["uzawa_rounds"]) for s in summary["steps"]],
        cutbacks=int(sum(int(s.get("cutbacks", 0)) for s in summary["steps"])),
        newton_order=cm.newton_orders(summary),
        newton_order_text=cm.format_orders(summary),
        round_off=[st.get("residual_round_off") for st in summary["steps"]],
        uzawa_round_orders=cm.uzawa_round_orders(summary),
        residual_norms=[st["residual_norms"] for st in summary["steps"]],
        slave_nodes=len(d["x"]),
        dofs=summary.get("dofs"),
        ranks=summary.get("ranks"),
        profile=(x.tolist(), p.tolist()),
    )
    return m


def main(argv=None) -> dict:
    ap = cm.parser(
        __doc__.splitlines()[0],
        "results/demo_hertz2d",
        recovery=True,
        acceleration=True,
        quadrature=True,
    )
    ap.add_argument("--order", type=int, choices=(1, 2), default=1, help="element order [1]")
    ap.add_argument("--steps", type=int, default=4, help="load steps [4]")
    ap.add_argument("--tri", action="store_true", help="triangles instead of quadrilaterals")
    ap.add_argument("--load", type=float, default=P, help=f"total load P per length [{P:g}]")
    args = ap.parse_args(argv)
    if not args.load > 0.0:
        ap.error(f"--load must be > 0, got {args.load:g}")
    comm = MPI.COMM_WORLD
    sc = scene(
        args.refine,
        args.order,
        args.integration,
        args.steps,
        not args.tri,
        args.recovery,
        load=args.load,
    )
    cm.set_acceleration(sc, args.uzawa_acceleration)
    cm.set_quadrature(sc, args.quadrature_degree)
    summary, wall = cm.run_scene(sc, args.out, comm, round_off=True)
    m = cm.on_root(evaluate, summary, args.out, load=args.load, comm=comm)
    m["wall_time"] = wall
    h = H_CONTACT / 2**args.refine
    cm.report(
        f"hertz2d (half model): h_contact = {h:g}, {'P' if args.tri else 'Q'}{args.order}, "
        f"{args.integration}, "
        f"{args.recovery}, "
        f"{m['ranks']} rank(s), {m['dofs']} dofs, {m['slave_nodes']} slave nodes",
        [
            ("measured load P = 2 Fy", f"{m['P_measured']:.6f} (applied {args.load:g})"),
            ("Hertz a, p0", f"{m['a']:.5f}, {m['p0']:.5f}"),
            ("L2 pressure error", f"{100 * m['l2']:.3f} %"),
            ("p_max error", f"{100 * m['p_max_err']:+.3f} % (p_max = {m['p_max']:.5f})"),
            (
                "half-width error",
                f"{100 * m['a_err']:+.3f} % (a_h = {m['a_measured']:.5f}, "
                f"bracket [{m['a_lo']:.4f}, {m['a_hi']:.4f}])",
            ),
            ("force balance |Fy - P/2|/(P/2)", f"{m['force_balance']:.3e}"),
            ("Newton iterations per step", str(m["newton_iterations"])),
            ("Uzawa rounds per step", str(m["uzawa_rounds"])),
            ("step cutbacks", str(m["cutbacks"])),
            ("observed Newton order", m["newton_order_text"]),
            ("residual round-off level", ", ".join(f"{f:.1e}" for f in m["round_off"])),
            ("negative nodal pressures", str(m["negative"])),
            ("oscillation index", f"{m['oscillation']:.4f}"),
            ("wall time", f"{wall:.2f} s"),
        ],
        comm,
    )
    return m


if __name__ == "__main__":
    cm.script(main, "demo_hertz2d")
