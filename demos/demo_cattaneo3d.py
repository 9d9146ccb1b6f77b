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

Run, from the repository root (``scripts/env.sh`` sets ``$PY``)::

    . scripts/env.sh
    mpirun -n 2 $PY demos/demo_cattaneo3d.py [--refine K] [--shift S] [--shift-steps N]
        [--recovery lumped|constrained]

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


def scene(
    refine: int = 0,
    integration: str = "element",
    shift: float = SHIFT,
    n_press: int = 2,
    n_shift: int = 2,
    h_contact: float = H_CONTACT,
    recovery: str = "lumped",
) -> dict:
    """The scene dict: the twist demo's mesh, materials and frictional pair
    (:func:`demo_twist3d.scene`, with the default Uzawa settings and the normal
    ``recovery``), ``sphere_top`` pressed by DEPTH in ``n_press`` steps, then shifted by
    ``shift`` in ``n_shift`` steps."""
    sc = demo_twist3d.scene(refine, integration, h_contact=h_contact)
    sc["title"] = f"cattaneo3d, refine {refine}, {integration}"
    pair = {k: v for k, v in sc["contact"][0].items() if k not in ("uzawa_tol", "uzawa_max")}
    sc["contact"] = [{**pair, "recovery": recovery}]
    sc["dirichlet"].append(
        {
            "boundary": "sphere_top",
            "components": [0, 1, 2],
            "path": [[0, 0, 0, 0], [1, 0, 0, -DEPTH], [2, shift, 0, -DEPTH]],
        }
    )
    sc["steps"] = {
        "t_end": 2.0,
        "n": 2,
        "output_times": [k / n_press for k in range(1, n_press)]
        + [1.0 + k / n_shift for k in range(1, n_shift)],
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


def main(argv=None) -> dict:
    ap = cm.parser(
        "3D Cattaneo–Mindlin (sphere on a block)", "results/demo_cattaneo3d", recovery=True
    )
    ap.add_argument("--shift", type=float, default=SHIFT, help=f"sideways motion [{SHIFT}]")
    ap.add_argument("--press-steps", type=int, default=2, help="steps of the press [2]")
    ap.add_argument("--shift-steps", type=int, default=2, help="steps of the shift [2]")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    h = H_CONTACT / 2**args.refine
    sc = scene(
        args.refine,
        args.integration,
        args.shift,
        args.press_steps,
        args.shift_steps,
        recovery=args.recovery,
    )
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
        ],
        comm,
    )
    return m


if __name__ == "__main__":
    cm.script(main, "demo_cattaneo3d")
