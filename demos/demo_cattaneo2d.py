"""Cattaneo–Mindlin in 2D: two cylinders pressed together, then sheared below gross slip.

Full model (generator ``cattaneo2d``): the half-cylinders ``upper`` and ``lower``
(R = 8 each, R* = 4), linear elastic E = 200, ν = 0.3 both, plane strain, small
kinematics, Coulomb friction μ = 0.2 (slave ``upper_surface``, master
``lower_surface``). ``lower_bottom`` is clamped; ``upper_top`` is a bonded rigid
platen: u_y goes to −DEPTH over t ∈ [0, 1] (normal load P ≈ 9.6), then u_x goes to
SHIFT over t ∈ [1, 2] while u_y is held (tangential load Q ≈ 0.5 μP). As in the
peers' harness (BENCHMARKS.md), the references use the run's MEASURED platen
reactions P and Q: Hertz's a = 2√(P R*/(π E*)), p0 = 2P/(π a); the stick zone
|x| ≤ c with c/a = √(1 − Q/(μP)); the tangential traction
q(x) = μ p0 [√(1 − x²/a²) − (c/a) √(1 − x²/c²)] for |x| ≤ c, μ p(x) for c ≤ |x| ≤ a.

Metrics (over the reference slave coordinate, centred on the pressure centroid): the
stick-zone half-width (the mean of the bracket [half the extent of the stick nodes, the
same with their outer neighbours], as the peers' harness), its error against c in
slave-element sizes, the L2 error of the nodal tangential traction against q(x), the L2
error of the pressure, Newton iterations.

``--unload`` (Mindlin–Deresiewicz): the shift goes to SHIFT in one step (Q* ≈ 0.47 μP),
then back through SHIFT/4 (t = 2.5, Q ≈ 0.11 μP) to −SHIFT/2 (t = 3, Q ≈ −0.24 μP); each
unloaded state against ``analytic.mindlin_deresiewicz2d`` with the measured P, Q*, Q: the
new stick zone |x| ≤ c', (c'/a)² = 1 − (Q* − Q)/(2μP), reverse slip q = −μp outside it.
Its metrics add the L2 error of the nodal interpolant of the exact q (what the mesh can
represent: the unloaded q has square-root cusps at c* and c') and the L2 distance to the
Cattaneo–Mindlin q of the same Q without the history (what a friction law without memory
would give).

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_cattaneo2d.py [--refine K] [--integration segment] [--unload]
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

from dolfinx_mortar import analytic  # noqa: E402
from dolfinx_mortar.scene import TANGENTIAL_WEIGHTS  # noqa: E402

R, E, NU, MU = 8.0, 200.0, 0.3, 0.2
R_STAR = R / 2.0
E_STAR = E / (2.0 * (1.0 - NU**2))
DEPTH = 0.1774  # platen approach giving P ≈ 9.6 (measured: 9.59 at h_contact = 0.05, 0.025)
SHIFT = 0.029  # tangential platen displacement giving Q/(μP) ≈ 0.5
H_CONTACT = 0.05
SLAVE, MASTER = "upper_surface", "lower_surface"
UNLOAD_BACK = 0.5  # --unload: the shift ends at -UNLOAD_BACK * SHIFT


def scene(
    refine: int = 0,
    integration: str = "element",
    n_press: int = 2,
    n_shear: int = 4,
    recovery: str = "lumped",
    tangential_weights: str = "dual",
    tangential_recovery: str = "lumped",
):
    """The scene dict (SCENES.md) at refinement level ``refine``."""
    dirichlet, steps = cm.press_then_shift(
        "lower_bottom", "upper_top", DEPTH, SHIFT, n_press, n_shear
    )
    return {
        "title": f"cattaneo2d, refine {refine}, {integration}",
        "kinematics": "small",
        "mesh": {
            "generator": "cattaneo2d",
            "params": {"R": R, "h_contact": H_CONTACT / 2**refine, "c_zone": 1.5},
        },
        "material": cm.elastic(("upper", "lower"), E, NU),
        "contact": [
            {
                "slave": SLAVE,
                "master": MASTER,
                "friction": MU,
                "recovery": recovery,
                "integration": integration,
                "penalty": "auto",
                "tangential_weights": tangential_weights,
                "tangential_recovery": tangential_recovery,
                "uzawa_tol": 1e-6,
                "uzawa_max": 40,
            }
        ],
        "dirichlet": dirichlet,
        "steps": steps,
        "output": {"fields": ["contact_pressure", "tangential_traction", "contact_state"]},
    }


def unloading_scene(refine: int = 0, back: float = UNLOAD_BACK, **kwargs) -> dict:
    """The scene of ``--unload``: :func:`scene` (``kwargs``: its options) with the shift
    to SHIFT in one step (t = 2), then back to −``back`` SHIFT over t ∈ [2, 3] in two steps."""
    sc = scene(refine, n_shear=1, **kwargs)
    for b in sc["dirichlet"]:
        b["path"] = (
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, -DEPTH],
                [2.0, SHIFT, -DEPTH],
                [3.0, -back * SHIFT, -DEPTH],
            ]
            if b["boundary"] == "upper_top"
            else [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]]
        )
    sc["steps"] = {"t_end": 3.0, "n": 3, "output_times": [0.5, 2.5]}
    sc["title"] += ", unloaded"
    return sc


def _l2(x: np.ndarray, q: np.ndarray, q_exact, a: float) -> float:
    """‖q_h − q‖/‖q‖ over [−1.25a, 1.25a]: q_h the piecewise-linear interpolant of the nodal
    values q at the sorted x (0 outside), ``q_exact`` a function of x."""
    L = 1.25 * a
    xs = np.unique(np.concatenate([np.linspace(-L, L, 40 * len(x) + 1), x[np.abs(x) <= L]]))
    qh = np.interp(xs, x, q, left=0.0, right=0.0)
    qe = q_exact(xs)
    return math.sqrt(cm._trapz((qh - qe) ** 2, xs) / cm._trapz(qe**2, xs))


def _profile(out_dir, step: int):
    """(x, p, q, state) of ``contact_<SLAVE>_<step>.csv``, sorted by the reference x and
    centred on the pressure centroid; q = −p_T0 (the platen's +x shift gives q > 0)."""
    d = np.genfromtxt(
        Path(out_dir) / f"{cm.contact_stem(SLAVE)}_{step}.csv", delimiter=",", names=True
    )
    o = np.argsort(d["x"])
    x, p, q, state = d["x"][o], d["p_N"][o], -d["p_T0"][o], d["state"][o]
    return x - float(np.sum(x * p) / np.sum(p)), p, q, state


def evaluate_unloading(summary: dict, out_dir, h: float) -> dict:
    """Metrics of the ``--unload`` run (rank 0: reads the CSVs): ``loading`` (the state at
    t = 2: Q*, its L2(q) against Cattaneo–Mindlin) and ``unloaded``, one dict per later
    step: t, P, Q, Q/(μP), c' (analytic) and the measured stick half-width (as
    :func:`stick_bracket`) and its error in slave elements, L2(q) against
    Mindlin–Deresiewicz, ``l2_interp`` (the nodal interpolant of the exact q against it),
    ``l2_virgin`` (q against the Cattaneo–Mindlin q of the same Q, no history), ``q_force``
    (∫ q_h dx / Q − 1), the stick and slip node counts, and q/(μ p_N) and x of the slip
    nodes."""
    steps = summary["steps"]
    k_star = 1 + next(i for i, s in enumerate(steps) if abs(s["t"] - 2.0) < 1e-12)

    def forces(k):
        reac = np.asarray(steps[k - 1]["reactions"]["upper_top"], float)
        return -reac[1], reac[0]

    P_star, Q_star = forces(k_star)
    x, p, q, _ = _profile(out_dir, k_star)
    a = analytic.hertz2d(P_star, R_STAR, E_STAR)["a"]
    loading = {
        "P": P_star,
        "Q": Q_star,
        "Q_ratio": Q_star / (MU * P_star),
        "l2_q": _l2(
            x, q, lambda s: analytic.cattaneo_mindlin2d(s, P_star, Q_star, MU, R_STAR, E_STAR), a
        ),
    }
    states = []
    for k in range(k_star + 1, len(steps) + 1):
        P, Q = forces(k)
        x, p, q, state = _profile(out_dir, k)
        a = analytic.hertz2d(P, R_STAR, E_STAR)["a"]
        c = a * math.sqrt(1.0 - (Q_star - Q) / (2.0 * MU * P))

        def exact(s, P=P, Q=Q):
            return analytic.mindlin_deresiewicz2d(s, P, Q_star, Q, MU, R_STAR, E_STAR)

        c_lo, c_hi = stick_bracket(x, state)
        c_h = 0.5 * (c_lo + c_hi)
        states.append(
            {
                "t": float(steps[k - 1]["t"]),
                "P": P,
                "Q": Q,
                "Q_ratio": Q / (MU * P),
                "c": c,
                "c_measured": c_h,
                "c_err_elements": (c_h - c) / h,
                "l2_q": _l2(x, q, exact, a),
                "l2_interp": _l2(x, exact(x), exact, a),
                "l2_virgin": _l2(
                    x,
                    q,
                    lambda s, P=P, Q=Q: analytic.cattaneo_mindlin2d(s, P, Q, MU, R_STAR, E_STAR),
                    a,
                ),
                "q_force": cm._trapz(q, x) / Q - 1.0,
                "slip_q_ratio": (q[state == 2] / (MU * p[state == 2])).tolist(),
                "slip_x": x[state == 2].tolist(),
                "stick_nodes": int(np.sum(state == 1)),
                "slip_nodes": int(np.sum(state == 2)),
            }
        )
    return {"loading": loading, "unloaded": states, **cm.solver_stats(summary)}


def stick_bracket(x: np.ndarray, state: np.ndarray) -> tuple[float, float]:
    """Half-widths (lo, hi) that bracket the stick zone of a sorted profile x (n,):
    lo = half the extent of the stick nodes, hi = half the extent of the stick nodes
    and their two outer neighbours (as the peers' harness, ``hertz_common._bracket``).
    The measured half-width is their mean."""
    idx = np.flatnonzero(state == 1)
    if not idx.size:
        return 0.0, 0.0
    il, ir = idx[0], idx[-1]
    lo = 0.5 * float(x[ir] - x[il])
    hi = 0.5 * float(x[min(ir + 1, len(x) - 1)] - x[max(il - 1, 0)])
    return lo, hi


def evaluate(summary: dict, out_dir, h: float) -> dict:
    """Metrics of the final step (rank 0: reads the final CSV)."""
    reac = np.asarray(summary["steps"][-1]["reactions"]["upper_top"], float)
    P, Q = -reac[1], reac[0]
    a = 2.0 * math.sqrt(P * R_STAR / (math.pi * E_STAR))
    p0 = 2.0 * P / (math.pi * a)
    c = a * math.sqrt(max(1.0 - Q / (MU * P), 0.0))
    d = cm.final_csv(out_dir, SLAVE)
    # small-strain theory: profiles over the REFERENCE slave coordinate (CSV column x;
    # X is the current one, which the Poisson expansion of the surface stretches by ~1 %)
    o = np.argsort(d["x"])
    x, p, q, state = d["x"][o], d["p_N"][o], -d["p_T0"][o], d["state"][o]
    xc = float(np.sum(x * p) / np.sum(p))  # pressure centroid
    x = x - xc
    c_lo, c_hi = stick_bracket(x, state)
    c_h = 0.5 * (c_lo + c_hi)
    pm = cm.profile_metrics(x, p, a, p0)

    def q_exact(s):
        s = np.asarray(s)
        full = MU * p0 * np.sqrt(np.clip(1.0 - (s / a) ** 2, 0.0, None))
        inner = MU * p0 * (c / a) * np.sqrt(np.clip(1.0 - (s / c) ** 2, 0.0, None))
        return np.where(np.abs(s) <= c, full - inner, full)

    L = 1.25 * a
    xs = np.unique(np.concatenate([np.linspace(-L, L, 40 * len(x) + 1), x[np.abs(x) <= L]]))
    qh = np.interp(xs, x, q, left=0.0, right=0.0)
    qe = q_exact(xs)
    l2q = math.sqrt(cm._trapz((qh - qe) ** 2, xs) / cm._trapz(qe**2, xs))
    return {
        "P": P,
        "Q": Q,
        "Q_ratio": Q / (MU * P),
        "a": a,
        "c": c,
        "c_measured": c_h,
        "c_bracket": [c_lo, c_hi],
        "c_err_elements": (c_h - c) / h,
        "c_err": c_h / c - 1.0 if c > 0 else float("nan"),
        "l2_q": l2q,
        "l2_p": pm["l2"],
        "p_max_err": pm["p_max_err"],
        "stick_nodes": int(np.sum(state == 1)),
        "slip_nodes": int(np.sum(state == 2)),
        "negative": pm["negative"],
        **cm.solver_stats(summary),
        "dofs": summary.get("dofs"),
        "ranks": summary.get("ranks"),
        "x": x.tolist(),
        "q": q.tolist(),
    }


def main(argv=None) -> dict:
    ap = cm.parser(
        "Cattaneo–Mindlin 2D (two cylinders, partial slip)",
        "results/demo_cattaneo2d",
        recovery=True,
        acceleration=True,
        frame=True,
    )
    ap.add_argument("--plot", action="store_true", help="write q(x) against the analytic curve")
    ap.add_argument(
        "--tangential-weights",
        choices=TANGENTIAL_WEIGHTS,
        default="dual",
        help="weight functions of the tangential mixed field [dual]",
    )
    ap.add_argument(
        "--tangential-recovery",
        choices=("lumped", "unconstrained", "constrained"),
        default="lumped",
        help="recovery of the tangential traction [lumped]",
    )
    ap.add_argument(
        "--unload",
        action="store_true",
        help="shift to SHIFT, then back to -SHIFT/2: Mindlin-Deresiewicz unloading",
    )
    cm.add_step_depth_limit(ap, 0.0)
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    h = H_CONTACT / 2**args.refine
    sc = (unloading_scene if args.unload else scene)(
        args.refine,
        integration=args.integration,
        recovery=args.recovery,
        tangential_weights=args.tangential_weights,
        tangential_recovery=args.tangential_recovery,
    )
    if args.step_depth_limit > 0.0:
        sc.setdefault("solver", {})["step_depth_limit"] = args.step_depth_limit
    cm.set_acceleration(sc, args.uzawa_acceleration)
    summary, wall = cm.run_scene(cm.set_frame(sc, args.frame), args.out, comm)
    if args.unload:
        return _report_unloading(summary, args, h, wall, comm)
    m = cm.on_root(evaluate, summary, args.out, h, comm=comm)
    m["wall_time"] = wall
    if args.plot and comm.rank == 0:
        m["png"] = plot(m, Path(args.out) / "cattaneo2d_q.png")
    cm.report(
        f"cattaneo2d: {args.integration}, {args.recovery}, {args.tangential_weights} weights, "
        f"{args.tangential_recovery} tangential recovery, "
        f"h = {h:g}, {m['ranks']} rank(s), {m['dofs']} dofs",
        [
            ("measured P, Q/(μP)", f"{m['P']:.4f}, {m['Q_ratio']:.4f}"),
            ("a, c (analytic)", f"{m['a']:.4f}, {m['c']:.4f}"),
            (
                "stick half-width",
                f"{m['c_measured']:.4f} ({m['c_err_elements']:+.2f} elements; "
                f"bracket {m['c_bracket'][0]:.4f} .. {m['c_bracket'][1]:.4f})",
            ),
            ("L2 error of q", f"{100 * m['l2_q']:.2f} %"),
            ("L2 error of p", f"{100 * m['l2_p']:.2f} %"),
            ("stick / slip nodes", f"{m['stick_nodes']} / {m['slip_nodes']}"),
            *cm.solver_rows(m, wall),
        ],
        comm,
    )
    return m


def _report_unloading(summary: dict, args, h: float, wall: float, comm) -> dict:
    """Evaluate and print the ``--unload`` run (collective); returns the metrics."""
    m = cm.on_root(evaluate_unloading, summary, args.out, h, comm=comm)
    m["wall_time"], m["ranks"], m["dofs"] = wall, summary.get("ranks"), summary.get("dofs")
    ld = m["loading"]
    rows = [("loaded (t = 2): Q*/(μP), L2(q)", f"{ld['Q_ratio']:.4f}, {100 * ld['l2_q']:.2f} %")]
    for st in m["unloaded"]:
        rows += [
            (
                f"t = {st['t']:g}: Q/(μP), c', stick half-width",
                f"{st['Q_ratio']:+.4f}, {st['c']:.4f}, {st['c_measured']:.4f} "
                f"({st['c_err_elements']:+.2f} elements)",
            ),
            (
                f"t = {st['t']:g}: L2(q) (interpolant; no history)",
                f"{100 * st['l2_q']:.2f} % ({100 * st['l2_interp']:.2f} %; "
                f"{100 * st['l2_virgin']:.1f} %)",
            ),
        ]
    cm.report(
        f"cattaneo2d unloaded (Mindlin–Deresiewicz): {args.integration}, {args.recovery}, "
        f"{args.tangential_weights} weights, {args.tangential_recovery} tangential recovery, "
        f"h = {h:g}, {m['ranks']} rank(s), {m['dofs']} dofs",
        rows + cm.solver_rows(m, wall),
        comm,
    )
    return m


def plot(m: dict, path: Path) -> str:
    """q(x) of the run against the Cattaneo–Mindlin curve (matplotlib, Agg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    a, c = m["a"], m["c"]
    p0 = 2.0 * m["P"] / (math.pi * a)
    s = np.linspace(-1.2 * a, 1.2 * a, 801)
    full = MU * p0 * np.sqrt(np.clip(1 - (s / a) ** 2, 0, None))
    inner = MU * p0 * (c / a) * np.sqrt(np.clip(1 - (s / c) ** 2, 0, None))
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(s, np.where(np.abs(s) <= c, full - inner, full), "k-", label="Cattaneo–Mindlin")
    ax.plot(s, full, "k:", lw=0.8, label="μ p(x)")
    ax.plot(m["x"], m["q"], "o", ms=3, label="dolfinx_mortar (nodal)")
    ax.set_xlabel("x")
    ax.set_ylabel("tangential traction q")
    ax.set_xlim(-1.3 * a, 1.3 * a)
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return str(path)


if __name__ == "__main__":
    cm.script(main, "demo_cattaneo2d")
