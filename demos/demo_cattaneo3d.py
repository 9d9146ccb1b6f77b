"""3D Cattaneo–Mindlin: a sphere pressed on a block, then loaded tangentially (Q < μP).

Generator ``twist3d`` (a full lower hemisphere R = 8 on a 20 × 20 × 20 block: a
tangential load needs no symmetry plane), tetrahedra, both bodies linear elastic
E = 200, ν = 0.3 (identical materials: no normal–tangential coupling), small
kinematics, Coulomb friction μ = 0.3 (slave ``sphere_surface``, master ``block_top``).
``block_bottom`` is clamped; ``sphere_top`` goes down by DEPTH over t ∈ [0, 1], then
sideways (+x) by SHIFT over [1, 2]. P is the normal reaction of ``sphere_top``, Q the
tangential contact force (its x component).

Against the closed forms (:mod:`dolfinx_mortar.analytic`; Johnson, Contact Mechanics
§7.1, with Mindlin's approximation): the Hertz radius a = (3 P R*/(4 E*))^(1/3),
E* = E/(2(1 − ν²)), peak p0 = 3P/(2π a²); the stick radius c = a (1 − Q/(μP))^(1/3);
the traction q(r) = μ p0 [√(1 − r²/a²) − (c/a) √(1 − r²/c²)] (r < c), μ p(r) in the
slip annulus, against the motion. Printed: c/a exact and fitted (the c that
misclassifies the fewest active nodes as stick outside / slip inside), its error in
contact-zone elements; the Coulomb cone |q| = μ p at slip nodes carrying traction; the
L2 errors of p and q over the disc r ≤ 1.25 a (the nodal values on the lower cap
interpolated linearly over the (x, y) plane), q's against the same norm of the nodal
interpolant of the exact q (the floor of the mesh).

With P1 tetrahedra the nodal pressure scatters (hertz3d: +27 % peak, BENCHMARKS §5), and
q's error follows p's (μ times it in the slip annulus): L2(q) is 2.5–3 times the
interpolation floor, 36 % at h = 0.2 (a/8), not the 2D demo's 5–9 % (BENCHMARKS §63).

``--cycle`` (Mindlin–Deresiewicz; Johnson §7.2): after the shift to +S at t = 2, back
to −S at t = 4 and forward to +S at t = 6 (N steps per S), a full tangential cycle at
constant P. Printed against the closed forms of :mod:`dolfinx_mortar.analytic`
(``mindlin_deresiewicz3d*``, ``tangential_compliance``, Λ = 2(2 − ν)/G): per step the
stick radius fitted as above against c'/a = (1 − |Q − Q_rev|/(2μP))^(1/3) (Q_rev the
last turning point), and the slip nodes whose traction keeps the sign of the force
before the step (a reversal's lag); the loop: the shift δ = δ_contact(Q) + C_b Q with the
bodies' own compliance C_b fitted on the loading steps only, the unloading and reloading
forces predicted from δ (δ_contact = K0 [1 − (1 − Q/μP)^(2/3)] on loading,
δ* − 2K0 [1 − (1 − (Q* − Q)/(2μP))^(2/3)] on unloading, K0 = 3μPΛ/(16a)), their largest
error / Q*; the frictional dissipation of the cycle (summary.json's per-step
``dissipation`` summed over 2 < t ≤ 6) against ΔW = (9μ²P²Λ/(10a)) [1 − (1 − X)^(5/3) −
(5X/6)(1 + (1 − X)^(2/3))], X = Q*/(μP). At h = 0.3, N = 2: loop within 0.3 % of Q*,
dissipation +4.1 %, c' −0.24 … −0.48 element, one old-sign node in one step (BENCHMARKS
§67).

Run, from the repository root (``scripts/env.sh`` sets ``$PY``)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_cattaneo3d.py [--refine K] [--h-contact H] [--shift S]
        [--shift-steps N] [--recovery lumped|constrained] [--cycle]

With ``--recovery constrained`` (the tangential recovery lumped) the run takes about 4 ×
the lumped one's time: the exact tangent couples the contact zone to every slave node
with paired area through M⁻¹ (BENCHMARKS §65).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import demo_twist3d  # noqa: E402
import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

from dolfinx_mortar import analytic  # noqa: E402

R, E, NU, MU = demo_twist3d.R, demo_twist3d.E, demo_twist3d.NU, demo_twist3d.MU
DEPTH = demo_twist3d.DEPTH
SHIFT = 0.072  # Q/(μP) ≈ 0.5 at h = 0.3
H_CONTACT = demo_twist3d.H_CONTACT
SLAVE, MASTER = demo_twist3d.SLAVE, demo_twist3d.MASTER
PAIR = f"{SLAVE}:{MASTER}"
#: ``--cycle``: the shift's turning points (times) and its sign there (times S): pressed
#: by t = 1, +S at t = 2 (loading), -S at 4 (unloading), +S at 6 (reloading)
CYCLE_TIMES = (1.0, 2.0, 4.0, 6.0)
CYCLE_SIGNS = (0.0, 1.0, -1.0, 1.0)


def scene(
    refine: int = 0,
    integration: str = "element",
    shift: float = SHIFT,
    n_press: int = 2,
    n_shift: int = 2,
    h_contact: float = H_CONTACT,
    recovery: str = "lumped",
    cycle: bool = False,
) -> dict:
    """The scene dict: the twist demo's mesh, materials and frictional pair
    (:func:`demo_twist3d.scene`, with the default Uzawa settings and the normal
    ``recovery``), ``sphere_top`` pressed by DEPTH in ``n_press`` steps, then shifted by
    ``shift`` in ``n_shift`` steps. ``cycle``: then a full tangential cycle, the shift
    back to ``-shift`` over t ∈ [2, 4] and forward to ``+shift`` over [4, 6], in
    ``2 n_shift`` steps each (:data:`CYCLE_TIMES`)."""
    sc = demo_twist3d.scene(refine, integration, h_contact=h_contact)
    sc["title"] = f"cattaneo3d, refine {refine}, {integration}"
    pair = {k: v for k, v in sc["contact"][0].items() if k not in ("uzawa_tol", "uzawa_max")}
    sc["contact"] = [{**pair, "recovery": recovery}]
    sc["dirichlet"].append(
        {
            "boundary": "sphere_top",
            "components": [0, 1, 2],
            "path": [[0, 0, 0, 0], [1, 0, 0, -DEPTH]]
            + [
                [t, s * shift, 0, -DEPTH]
                for t, s in zip(CYCLE_TIMES[1:], CYCLE_SIGNS[1:], strict=True)
            ]
            if cycle
            else [[0, 0, 0, 0], [1, 0, 0, -DEPTH], [2, shift, 0, -DEPTH]],
        }
    )
    t_end = CYCLE_TIMES[-1] if cycle else 2.0
    sc["steps"] = {
        "t_end": t_end,
        "n": int(t_end),
        "output_times": [k / n_press for k in range(1, n_press)]
        + [1.0 + k / n_shift for k in range(1, int(t_end - 1) * n_shift) if k % n_shift],
    }
    del sc["output"]
    return sc


def slave_frame(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The CSV's tangential frame (docs/scenes.md) at reference points ``x`` (n, 3) of the
    sphere (centre (0, 0, R)): t0 = the unit projection of the x axis onto the tangent
    plane, t1 = n × t0, n the outward normal. Returns (t0, t1), each (n, 3)."""
    n = x - np.array([0.0, 0.0, R])
    n /= np.linalg.norm(n, axis=1)[:, None]
    t0 = np.array([1.0, 0.0, 0.0]) - n[:, :1] * n
    t0 /= np.linalg.norm(t0, axis=1)[:, None]
    return t0, np.cross(n, t0)


def _disc_l2(xy: np.ndarray, values: np.ndarray, exact, radius: float) -> float:
    """Relative L2 error over the disc |(x, y)| ≤ radius of the linear interpolant of the
    nodal ``values`` at ``xy`` (n, 2) against ``exact(r)``, on a 301 × 301 grid."""
    from scipy.interpolate import LinearNDInterpolator

    g = np.linspace(-radius, radius, 301)
    gx, gy = (v.ravel() for v in np.meshgrid(g, g))
    inside = np.hypot(gx, gy) <= radius
    gx, gy = gx[inside], gy[inside]
    vh = LinearNDInterpolator(xy, values, fill_value=0.0)(gx, gy)
    ve = exact(np.hypot(gx, gy))
    return float(np.sqrt(np.sum((vh - ve) ** 2) / np.sum(ve**2)))


def fitted_stick_radius(r: np.ndarray, state: np.ndarray, a: float) -> float:
    """The stick radius that misclassifies the fewest active nodes (state 1 stick beyond
    it, state 2 slip within it; r (n,) their distances from the contact centre), the
    mean of the minimisers on a grid of 401 radii in [0, a]."""
    cs = np.linspace(0.0, a, 401)
    wrong = np.array([np.sum((state == 1) & (r > c)) + np.sum((state == 2) & (r < c)) for c in cs])
    return float(cs[wrong == wrong.min()].mean())


def evaluate(csv: dict, P: float, Q: float, h: float) -> dict:
    """Metrics of the final contact CSV (columns of :func:`_common.final_csv`) at the
    normal load P and tangential load Q (Q > 0 along +x), contact-zone element size h."""
    x = np.column_stack([csv["x"], csv["y"], csv["z"]])
    p, state = csv["p_N"], csv["state"].astype(int)
    t0, t1 = slave_frame(x)
    qv = csv["p_T0"][:, None] * t0 + csv["p_T1"][:, None] * t1  # master on slave
    e_star = analytic.effective_modulus(E, NU)
    hz = analytic.hertz3d(P, R, e_star)
    a, p0 = hz["a"], hz["p0"]
    c = a * analytic.cattaneo_mindlin3d(P, Q, MU)
    centre = (p @ x[:, :2]) / p.sum()
    cap = x[:, 2] < 0.25 * R  # the lower cap: a graph over the (x, y) plane
    xy = x[cap, :2] - centre
    r = np.hypot(*(x[:, :2] - centre).T)
    active = state > 0
    c_fit = fitted_stick_radius(r[active], state[active], a)
    q_resist = -csv["p_T0"]  # against the motion: t0 is the x axis in the tangent plane
    qmag = np.linalg.norm(qv, axis=1)
    ratio = qmag / np.maximum(MU * p, np.finfo(float).tiny)
    carrying = (state == 2) & (qmag > 0.0)  # slip nodes that entered before this step

    def q_exact(rr):
        return analytic.cattaneo_mindlin3d_traction(rr, P, Q, MU, R, e_star)

    def p_exact(rr):
        return analytic.hertz3d_pressure(rr, P, R, e_star)

    wrong = ((state == 1) & (r > c)) | ((state == 2) & (r < c))
    return {
        "P": P,
        "Q": Q,
        "Q_over_muP": Q / (MU * P),
        "a": a,
        "p0": p0,
        "p_max_err": float(p.max() / p0 - 1.0),
        "c_over_a": c / a,
        "c_fit_over_a": c_fit / a,
        "c_err_elements": (c_fit - c) / h,
        "misclassified": int(wrong.sum()),
        "misclassified_depth_elements": float(np.abs(r[wrong] - c).max() / h)
        if wrong.any()
        else 0.0,
        "slip_ratio": (float(ratio[carrying].min()), float(ratio[carrying].max()))
        if carrying.any()
        else (np.nan, np.nan),
        "stick_ratio_max": float(ratio[state == 1].max()) if (state == 1).any() else np.nan,
        "l2_p": _disc_l2(xy, p[cap], p_exact, 1.25 * a),
        "l2_q": _disc_l2(xy, q_resist[cap], q_exact, 1.25 * a),
        "l2_q_floor": _disc_l2(xy, q_exact(r[cap]), q_exact, 1.25 * a),
        "stick_nodes": int(np.sum(state == 1)),
        "slip_nodes": int(np.sum(state == 2)),
    }


# ---------------------------------------------------------------------------
# --cycle: Mindlin–Deresiewicz (unloading, reloading)
# ---------------------------------------------------------------------------


def cycle_branch(t: float) -> str:
    """The branch of the cycle's load path at time t: "press" (t ≤ 1), "load" (1, 2],
    "unload" (2, 4], "reload" (4, 6]."""
    eps = 1e-9
    for name, end in zip(("press", "load", "unload"), CYCLE_TIMES[:3], strict=True):
        if t <= end + eps:
            return name
    return "reload"


def cycle_shift(t, shift: float = SHIFT):
    """The prescribed shift of ``sphere_top`` (along x) at time t of the cycle."""
    return np.interp(t, (0.0, *CYCLE_TIMES), (0.0, *(s * shift for s in CYCLE_SIGNS)))


def _history(branch: str, Q: float, Q_star: float, Q_min: float | None, P: float):
    """The closed forms' arguments for the force Q on ``branch`` after loading to Q_star > 0
    and (reloading) unloading to Q_min < 0, with Masing's memory rule where the force
    leaves the loop (a reversal beyond ±Q_star starts a larger loop; a force past the
    last reversal point's magnitude is on the virgin curve; below Q_min the reloading
    branch continues the unloading one), so that each branch's δ(Q) is continuous and
    increasing over |Q| < μP: None for the virgin curve, else (Q_star, Q_min) for
    :mod:`dolfinx_mortar.analytic`'s mindlin_deresiewicz3d*."""
    if branch == "load":
        return None
    if branch == "unload" or Q < Q_min:
        return None if abs(Q) > Q_star else (Q_star, None)
    if Q_min <= -Q_star:  # the unloading went past -Q*: reloading = unloading from Q_min
        return None if Q > -Q_min else (Q_min, None)
    return None if Q > Q_star else (Q_star, Q_min)


def loop_contact_shift(
    branch: str, P: float, Q: float, Q_star: float, Q_min: float | None, compliance: float
) -> float:
    """The contact's tangential shift at force Q on ``branch`` (closed forms of
    :mod:`dolfinx_mortar.analytic`: the virgin curve, unloading from Q_star, reloading
    from Q_min; see :func:`_history`), identical materials."""
    e_star = analytic.effective_modulus(E, NU)
    hist = _history(branch, Q, Q_star, Q_min, P)
    if hist is None:
        return analytic.cattaneo_mindlin3d_shift(P, Q, MU, R, e_star, compliance)
    return analytic.mindlin_deresiewicz3d_shift(P, hist[0], Q, MU, R, e_star, compliance, hist[1])


def loop_stick_ratio(branch: str, P: float, Q: float, Q_star: float, Q_min: float | None):
    """The closed-form stick ratio c/a at force Q on ``branch`` (as
    :func:`loop_contact_shift`): Cattaneo–Mindlin's on the virgin curve, c'/a of
    :func:`dolfinx_mortar.analytic.mindlin_deresiewicz3d_stick` on the loop."""
    hist = _history(branch, Q, Q_star, Q_min, P)
    if hist is None:
        return analytic.cattaneo_mindlin3d(P, Q, MU)
    return analytic.mindlin_deresiewicz3d_stick(P, hist[0], Q, MU, hist[1])


def loop_metrics(t, delta, P, Q) -> dict:
    """The FE loop Q(δ) against the closed forms. ``t``, ``delta`` (prescribed shift),
    ``P``, ``Q`` (n,): the steps. The FE shift adds the bodies' own elastic compliance to
    the contact's: ``δ = δ_contact(Q) + C_b Q``; C_b is fitted (least squares) on the
    loading steps (1 < t ≤ 2) only, then the unloading and reloading branches are
    predicted: Q_pred solves ``δ_contact(Q) + C_b Q = δ`` at each step's δ (Q* = Q at
    t = 2, Q_min = Q at t = 4). Returns C_b, Q*, Q_min, Q_pred (n; nan at the press), the
    branches, and the largest |Q - Q_pred|/Q* over the loading, unloading and reloading
    steps."""
    from scipy.optimize import brentq

    t, delta, P, Q = (np.asarray(v, dtype=float) for v in (t, delta, P, Q))
    lam = analytic.tangential_compliance(E, NU)
    branch = [cycle_branch(tk) for tk in t]
    i2 = int(np.argmin(np.abs(t - CYCLE_TIMES[1])))
    i4 = int(np.argmin(np.abs(t - CYCLE_TIMES[2])))
    Q_star = float(Q[i2])
    Q_min = float(Q[i4]) if abs(t[i4] - CYCLE_TIMES[2]) < 1e-9 else None
    load = np.array([b == "load" for b in branch])
    dc = np.array(
        [
            loop_contact_shift("load", P[i], Q[i], Q_star, Q_min, lam) if load[i] else np.nan
            for i in range(len(t))
        ]
    )
    C_b = float(np.sum((delta[load] - dc[load]) * Q[load]) / np.sum(Q[load] ** 2))
    Q_pred = np.full(len(t), np.nan)
    for i, b in enumerate(branch):
        if b == "press" or (b == "reload" and Q_min is None):
            continue
        lim = MU * P[i] * (1.0 - 1e-9)

        def f(q, i=i, b=b):
            return loop_contact_shift(b, P[i], q, Q_star, Q_min, lam) + C_b * q - delta[i]

        Q_pred[i] = brentq(f, -lim, lim, xtol=1e-12 * lim)
    cyc = ~np.isnan(Q_pred)
    return {
        "C_b": C_b,
        "Q_star": Q_star,
        "Q_min": Q_min,
        "Q_pred": Q_pred,
        "branch": branch,
        "loop_err": float(np.max(np.abs(Q[cyc] - Q_pred[cyc])) / abs(Q_star)),
    }


def cycle_dissipation(t, dissipation, P_star: float, Q_star: float) -> dict:
    """The frictional dissipation of one cycle (the steps' ``dissipation`` of summary.json
    summed over 2 < t ≤ 6) against the closed form
    :func:`dolfinx_mortar.analytic.mindlin_deresiewicz3d_energy` at (P*, Q*), the forces
    at t = 2."""
    t, d = np.asarray(t, dtype=float), np.asarray(dissipation, dtype=float)
    fe = float(d[(t > CYCLE_TIMES[1] + 1e-9) & (t <= CYCLE_TIMES[3] + 1e-9)].sum())
    e_star = analytic.effective_modulus(E, NU)
    lam = analytic.tangential_compliance(E, NU)
    exact = analytic.mindlin_deresiewicz3d_energy(P_star, Q_star, MU, R, e_star, lam)
    return {"dW_fe": fe, "dW": exact, "dW_ratio": fe / exact}


def stick_fit(csv: dict, a: float) -> tuple[float, np.ndarray, np.ndarray]:
    """The fitted stick radius (:func:`fitted_stick_radius`) of a contact CSV, centred on
    the pressure centroid; returns (c, r, state) with r the nodes' distances from the
    centre."""
    x = np.column_stack([csv["x"], csv["y"]])
    p, state = csv["p_N"], csv["state"].astype(int)
    r = np.hypot(*(x - (p @ x) / p.sum()).T)
    active = state > 0
    return fitted_stick_radius(r[active], state[active], a), r, state


def old_sign_slip_nodes(csv: dict, csv_prev: dict, direction: float) -> int:
    """The slip nodes (state 2, active the step before: they carry traction) whose
    traction along x, against the motion (``-p_T0``: t0 is the x axis in the tangent
    plane), has not the sign ``direction`` of this step's force change (the sign of the
    step before a reversal)."""
    carrying = (csv["state"] == 2) & (csv_prev["state"] > 0)
    return int(np.sum(carrying & (np.sign(-csv["p_T0"]) != np.sign(direction))))


def evaluate_cycle(summary: dict, out_dir, h: float, shift: float = SHIFT) -> dict:
    """Metrics of a ``--cycle`` run (rank 0): per step after the press t, δ, P, Q, the
    branch, Q_pred, the closed-form and fitted stick ratios (c/a on loading, c'/a on
    unloading and reloading) and the error in elements h, the old-sign slip nodes; the
    loop (:func:`loop_metrics`) and the dissipation per cycle (:func:`cycle_dissipation`)."""
    steps = summary["steps"]
    t = np.array([float(s["t"]) for s in steps])
    P = np.array([-float(s["reactions"]["sphere_top"][2]) for s in steps])
    Q = np.array([-float(s["contact_force"][PAIR][0]) for s in steps])
    delta = cycle_shift(t, shift)
    loop = loop_metrics(t, delta, P, Q)
    i2 = int(np.argmin(np.abs(t - CYCLE_TIMES[1])))
    diss = cycle_dissipation(t, [float(s.get("dissipation", 0.0)) for s in steps], P[i2], Q[i2])
    e_star = analytic.effective_modulus(E, NU)
    rows = []
    prev = cm.step_csv(out_dir, SLAVE, 1) if len(steps) else None
    for k in range(2, len(steps) + 1):
        cur = cm.step_csv(out_dir, SLAVE, k)
        i = k - 1
        b = loop["branch"][i]
        if b != "press":
            a = analytic.hertz3d(P[i], R, e_star)["a"]
            ca = loop_stick_ratio(b, P[i], Q[i], loop["Q_star"], loop["Q_min"])
            c_fit = stick_fit(cur, a)[0]
            rows.append(
                {
                    "t": t[i],
                    "branch": b,
                    "delta": float(delta[i]),
                    "P": P[i],
                    "Q": Q[i],
                    "Q_over_muP": Q[i] / (MU * P[i]),
                    "Q_pred": float(loop["Q_pred"][i]),
                    "c_over_a": ca,
                    "c_fit_over_a": c_fit / a,
                    "c_err_elements": (c_fit - ca * a) / h,
                    "old_sign": old_sign_slip_nodes(cur, prev, Q[i] - Q[i - 1]),
                }
            )
        prev = cur
    loop = {k: v for k, v in loop.items() if k not in ("Q_pred", "branch")}
    return {**loop, **diss, "Q_star_over_muP": loop["Q_star"] / (MU * P[i2]), "steps": rows}


def main(argv=None) -> dict:
    ap = cm.parser(
        "3D Cattaneo–Mindlin (sphere on a block)",
        "results/demo_cattaneo3d",
        recovery=True,
        quadrature=True,
    )
    ap.add_argument("--shift", type=float, default=SHIFT, help=f"sideways motion [{SHIFT}]")
    ap.add_argument("--press-steps", type=int, default=2, help="steps of the press [2]")
    ap.add_argument("--shift-steps", type=int, default=2, help="steps of the shift [2]")
    ap.add_argument(
        "--h-contact",
        type=float,
        default=H_CONTACT,
        help=f"contact-zone element size at refine 0 [{H_CONTACT}]",
    )
    ap.add_argument(
        "--cycle",
        action="store_true",
        help="a full tangential cycle after the shift (back to -shift by t = 4, forward to "
        "+shift by t = 6, shift-steps per shift): Mindlin–Deresiewicz's loop, stick radius "
        "and dissipation",
    )
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    h = args.h_contact / 2**args.refine
    sc = scene(
        args.refine,
        args.integration,
        args.shift,
        args.press_steps,
        args.shift_steps,
        h_contact=args.h_contact,
        recovery=args.recovery,
        cycle=args.cycle,
    )
    cm.set_quadrature(sc, args.quadrature_degree)
    summary, wall = cm.run_scene(sc, args.out, comm)

    def measure():
        last = summary["steps"][-1]
        P = -float(last["reactions"]["sphere_top"][2])
        Q = -float(last["contact_force"][PAIR][0])  # the force on the slave resists +x
        m = evaluate(cm.final_csv(args.out, SLAVE), P, Q, h)
        m.update(cm.solver_stats(summary), dofs=summary.get("dofs"))
        return m

    m = cm.on_root(measure, comm=comm)
    m["wall_time"] = wall
    if args.cycle:
        m["cycle"] = cm.on_root(evaluate_cycle, summary, args.out, h, args.shift, comm=comm)
    lo, hi = m["slip_ratio"]
    cm.report(
        f"cattaneo3d: {args.integration}, {args.recovery}, h = {h:g} (a/h = {m['a'] / h:.1f}), "
        f"{comm.size} rank(s), {m['dofs']} dofs",
        [
            ("P, Q, Q/(μP)", f"{m['P']:.4f}, {m['Q']:.4f}, {m['Q_over_muP']:.3f}"),
            (
                "Hertz a, p0",
                f"{m['a']:.4f}, {m['p0']:.4f} (nodal peak {100 * m['p_max_err']:+.1f} %)",
            ),
            (
                "stick radius c/a",
                f"{m['c_fit_over_a']:.3f} (exact {m['c_over_a']:.3f}, "
                f"{m['c_err_elements']:+.2f} elements)",
            ),
            (
                "misclassified nodes",
                f"{m['misclassified']} (at most {m['misclassified_depth_elements']:.2f} elements "
                "from c)",
            ),
            ("slip |q|/(μp)", f"{lo:.6f} … {hi:.6f} (stick at most {m['stick_ratio_max']:.4f})"),
            ("L2(p)", f"{100 * m['l2_p']:.2f} %"),
            (
                "L2(q)",
                f"{100 * m['l2_q']:.2f} % (interpolation floor {100 * m['l2_q_floor']:.2f} %)",
            ),
            ("stick / slip nodes", f"{m['stick_nodes']} / {m['slip_nodes']}"),
            *cm.solver_rows(m, wall),
            *(cycle_rows(m["cycle"]) if args.cycle else []),
        ],
        comm,
    )
    return m


def cycle_rows(c: dict) -> list[tuple[str, str]]:
    """The report rows of :func:`evaluate_cycle`'s metrics."""
    rows = [
        (
            "cycle: Q*, Q*/(μP), Q(t=4)",
            f"{c['Q_star']:.4f}, {c['Q_star_over_muP']:.4f}, {c['Q_min']:.4f}",
        )
    ]
    for s in c["steps"]:
        rows.append(
            (
                f"  t = {s['t']:.3f} {s['branch']:<6}",
                f"δ {s['delta']:+.4f}, Q/(μP) {s['Q_over_muP']:+.4f}, Q−Q_pred "
                f"{(s['Q'] - s['Q_pred']) / c['Q_star']:+.4f} Q*, c/a {s['c_fit_over_a']:.3f} "
                f"(exact {s['c_over_a']:.3f}, {s['c_err_elements']:+.2f} elements), "
                f"old-sign slip nodes {s['old_sign']}",
            )
        )
    old = [s["old_sign"] for s in c["steps"]]
    return rows + [
        ("body compliance C_b (loading fit)", f"{c['C_b']:.4e}"),
        ("loop: max |Q − Q_pred|/Q*", f"{100 * c['loop_err']:.2f} %"),
        (
            "dissipation per cycle",
            f"{c['dW_fe']:.5f} (closed form {c['dW']:.5f}, {100 * (c['dW_ratio'] - 1):+.1f} %)",
        ),
        (
            "old-sign slip nodes",
            f"{sum(old)} in all, at most {max(old, default=0)} in one step, "
            f"in {sum(1 for o in old if o)} step(s)",
        ),
    ]


if __name__ == "__main__":
    cm.script(main, "demo_cattaneo3d")
