"""Ironing in 2D: a stiff half-ring die pressed into a soft slab, then slid along it.

Generator ``ironing2d`` (BENCHMARKS.md row ironing2d), default mesh: the die is the
lower half of the ring 2.8 <= r <= 3.0 (E = 1000, ν = 0.3), its lowest point touching
the slab 9 × 3 (E = 1, ν = 0.3) at the origin; both neo-Hookean, plane strain, finite
kinematics; Coulomb friction μ = 0.3 (``--mu``) between ``die_surface`` and
``slab_top``. ``slab_bottom`` is clamped. ``die_top`` (the two flat ends of the die,
where it is driven) is prescribed: u_y goes to −PRESS (1.4) over t ∈ [0, 1] in
``--press-steps`` (10) equal steps, then u_x goes to +SLIDE (4) over t ∈ [1, 2] in
``--slide-steps`` (100) equal steps with u_y held.

Demo-level settings (measured, see the report of the run): by default the SLAB is the
slave (``--slave slab``: slave ``slab_top``, master ``die_surface``) and the tangential
penalty is ε_T = PT_FACTOR E*/h = 1 E*/h (``--pt-factor``; ``--penalty-tangential``
sets a number or "auto" = 10 E*/h); ε_N = "auto" (100 E*/h), uzawa_tol 1e-4; Newton steps
are penetration-limited (``--step-depth-limit``, ``[solver] step_depth_limit`` = 0.25: no
slab node out of contact goes deeper than 0.25 h in one Newton step). With the
die as slave (``--slave die``) the run does not complete: it stops where the die goes
from stick to slip (t ≈ 1.21 with ε_T = E*/h, after 69 cutbacks from the press on and 13
minutes; t ≈ 1.32 with ε_T "auto", 12 cutbacks; session 66): Newton and the Uzawa
rounds stall whatever the step size, because a slave Gauss point on the die switches
master facet between iterations (closest-point projection onto the kinked, concave
deformed slab surface) while most contact nodes sit on the Coulomb cone and flip
stick/slip. Segment integration, uzawa_tol 1e-3, 200 slide steps or the basic line
search did not help either. With the slab as slave and ε_T "auto" the run stopped at
the onset of gross slip (t ≈ 1.35) in earlier sessions; at session 66 it completes with
the default's plateau (F_x/F_y 0.3197, at most 23 Newton iterations per solve), and
the default stays E*/h.

The plateau forces are those of the default die mesh, not converged in its size: with
2 elements through its 0.2 thickness the ring is stiff in bending, and h_die = 0.05 (4
elements) gives F_y 1.62 instead of 2.07 and F_x 0.51 instead of 0.66, while F_x/F_y
moves by 1.4 % (BENCHMARKS §8, "Session 19").

The contact zone (half-width ≈ 2.5 at full depth) reaches the slab's free left end
(x = −2): the dragged top-left corner carries a pressure peak and slips off at once
at u_x ≈ 1.41 (a step of −5 % in F_x), before the plateau window.

Forces (per converged step): R = the reaction on ``die_top`` (summary.json
``reactions["die_top"]``, the force the support exerts on the die). The die is in
equilibrium between R and the contact force, so R is also the force that the die
exerts on the slab. Reported with the sign that makes both positive while ironing:

    F_x = R_x   (tangential force: the drag on the slab along the sliding direction +x)
    F_y = −R_y  (normal force: the die pushing the slab down)

Metrics: the plateau ratio F_x/F_y averaged over the second half of the slide
(t ∈ [1.5, 2]) with its min and max; the oscillation of F_x and F_y over the same
window: (max − min)/mean, the standard deviation after removing a linear trend
(relative to the mean), the dominant wavelength of the detrended signal in die travel
and its amplitude at the element-crossing wavelength h; whether the whole path
finished (status ok) and the total cutbacks; Newton iterations (max per solve, max
summed per step); wall time. ``--plot`` writes F_x and F_y against the die position
u_x to ``ironing2d_forces.png`` in the output directory. A failed run reports the
history up to the failure, then exits with an error.

Run, from the repository root (``scripts/env.sh`` sets ``$PY`` to Debian's python3, and
lets Open MPI run as root and on fewer cores than ranks)::

    . scripts/env.sh
    $PY demos/demo_ironing2d.py [--mu 0.3] [--press-steps 10] [--slide-steps 100]
        [--slave die] [--integration segment] [--plot]
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as cm  # noqa: E402
import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

from dolfinx_mortar.scene import TANGENTIAL_WEIGHTS  # noqa: E402

E_DIE, E_SLAB, NU = 1000.0, 1.0, 0.3
PRESS, SLIDE = 1.4, 4.0
H_CONTACT, H_DIE = 0.1, 0.1  # the generator's defaults
DIE_SURFACE, SLAB_TOP = "die_surface", "slab_top"
#: plane-strain effective modulus, 1/E* = 1/E'_die + 1/E'_slab (E' = E/(1 − ν²))
E_STAR = 1.0 / ((1.0 - NU**2) / E_DIE + (1.0 - NU**2) / E_SLAB)
#: default tangential penalty ε_T = PT_FACTOR E*/h (the library's "auto" is 10 E*/h)
PT_FACTOR = 1.0
#: penetration-limited Newton steps ([solver] step_depth_limit, in units of the slave
#: facet size): without it the full path needs a step halving at t = 1.355, 27 solves
#: continued with full steps and 10 retries from the converged state (BENCHMARKS §8)
STEP_DEPTH_LIMIT = 0.25


def scene(
    mu: float = 0.3,
    refine: int = 0,
    integration: str = "element",
    n_press: int = 10,
    n_slide: int = 100,
    press: float = PRESS,
    slide: float = SLIDE,
    uzawa_tol: float = 1e-4,
    penalty_tangential=None,
    max_cutbacks: int = 6,
    solver: dict | None = None,
    slave: str = "slab",
    tangential_weights: str = "standard",
) -> dict:
    """The scene dict (SCENES.md); the mesh is the generator default at ``refine = 0``.

    ``penalty_tangential``: a number, "auto", or None for PT_FACTOR E*/h."""
    if penalty_tangential is None:
        penalty_tangential = PT_FACTOR * E_STAR / (H_CONTACT / 2**refine)
    contact = {
        "slave": DIE_SURFACE if slave == "die" else SLAB_TOP,
        "master": SLAB_TOP if slave == "die" else DIE_SURFACE,
        "friction": mu,
        "integration": integration,
        "penalty": "auto",
        "uzawa_tol": uzawa_tol,
        "uzawa_max": 40,
        "penalty_tangential": penalty_tangential,
        "tangential_weights": tangential_weights,
    }
    dirichlet, steps = cm.press_then_shift("slab_bottom", "die_top", press, slide, n_press, n_slide)
    sc = {
        "title": f"ironing2d, mu {mu}, refine {refine}, {integration}, slave {slave}",
        "kinematics": "finite",
        "mesh": {
            "generator": "ironing2d",
            "params": {"h_contact": H_CONTACT / 2**refine, "h_die": H_DIE / 2**refine},
        },
        "material": [
            {"region": "die", "model": "neo-hookean", "E": E_DIE, "nu": NU},
            {"region": "slab", "model": "neo-hookean", "E": E_SLAB, "nu": NU},
        ],
        "contact": [contact],
        "dirichlet": dirichlet,
        "steps": dict(steps, max_cutbacks=max_cutbacks),
        "output": {"fields": ["contact_pressure", "tangential_traction", "contact_state"]},
    }
    if solver:
        sc["solver"] = dict(solver)
    return sc


def run_scene(scene: dict, out_dir, comm=MPI.COMM_WORLD) -> tuple[dict, float]:
    """As ``_common.run_scene``, but a failed run returns its summary (the steps it
    finished, status "failed") so that the force history up to the failure is reported."""
    from time import perf_counter

    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    out_dir = Path(out_dir).resolve()
    parsed = parse_scene(scene, out_dir.parent, source=f"<{scene['title']}>")
    comm.barrier()
    t0 = perf_counter()
    summary = run(parsed, comm, out_dir)
    return summary, comm.allreduce(perf_counter() - t0, op=MPI.MAX)


def window_stats(s: np.ndarray, y: np.ndarray, h: float) -> dict:
    """Oscillation of the signal y(s) (s = die position): relative range, detrended std,
    dominant wavelength of the detrended signal and its amplitude at wavelength h."""
    mean = float(np.mean(y))
    if len(y) < 3:
        return {"mean": mean, "range": float("nan"), "std": float("nan"), "wavelength": None}
    trend = np.polyval(np.polyfit(s, y, 1), s)
    r = y - trend
    # least-squares amplitudes of sinusoids over a grid of wavelengths (samples need not
    # be uniform after cutbacks); the grid spans two sample spacings to the window length
    ds = float(np.median(np.diff(s)))
    span = float(s[-1] - s[0])

    def amplitude(lam: float) -> float:
        A = np.column_stack([np.sin(2 * np.pi * s / lam), np.cos(2 * np.pi * s / lam)])
        c, *_ = np.linalg.lstsq(A, r, rcond=None)
        return float(np.hypot(*c))

    lams = np.geomspace(2.2 * ds, max(span, 2.2 * ds), 400)
    amps = np.array([amplitude(lam) for lam in lams])
    k = int(np.argmax(amps))
    scale = abs(mean) if mean else 1.0
    return {
        "mean": mean,
        "range": float((y.max() - y.min()) / scale),
        "std": float(np.std(r) / scale),
        "wavelength": float(lams[k]),
        "amp_dominant": float(amps[k] / scale),
        # at wavelength <= 2.2 sample spacings the sinusoids are (nearly) aliased: no value
        "amp_element": float(amplitude(h) / scale) if h >= 2.2 * ds else float("nan"),
    }


def _percent(a: float, b: float, why: str) -> str:
    """ "a %, b %" (3 decimals), or "n/a (``why``)" where the values are not defined
    (NaN: :func:`window_stats` cannot resolve that wavelength)."""
    if math.isnan(a) or math.isnan(b):
        return f"n/a ({why})"
    return f"{100 * a:.3f} %, {100 * b:.3f} %"


def evaluate(summary: dict, mu: float, press: float, slide: float, h: float) -> dict:
    """Force history and metrics (rank 0; summary.json only)."""
    steps = summary["steps"]
    t = np.array([float(st["t"]) for st in steps])
    R = np.array([st["reactions"]["die_top"] for st in steps], float)
    fx, fy = R[:, 0], -R[:, 1]
    ux = np.where(t > 1.0, slide * (t - 1.0), 0.0)
    uy = -press * np.minimum(t, 1.0)
    # cross-check: the contact force of the slab on the die is −R (summary.json: the force
    # of the master on the slave, summed over the slave nodes)
    (pair,) = steps[0]["contact_force"] if steps else ("",)
    sign = 1.0 if pair.startswith(DIE_SURFACE) else -1.0
    C = np.array([st["contact_force"][pair] for st in steps], float).reshape(-1, 2)
    balance = float(
        np.max(np.abs(sign * C + R), initial=0.0) / max(np.abs(R).max(initial=0.0), 1e-300)
    )
    sl = t > 1.0 + 1e-12
    window = t >= 1.5 - 1e-12
    ratio = np.divide(fx, fy, out=np.full_like(fx, np.nan), where=fy > 0)
    stats = cm.solver_stats(summary)
    m = {
        "mu": mu,
        "t": t.tolist(),
        "u_x": ux.tolist(),
        "u_y": uy.tolist(),
        "F_x": fx.tolist(),
        "F_y": fy.tolist(),
        "ratio": ratio.tolist(),
        "stick_nodes": [int(st["stick_nodes"]) for st in steps],
        "slip_nodes": [int(st["slip_nodes"]) for st in steps],
        "force_balance": balance,
        "n_steps": len(steps),
        "t_reached": float(t[-1]) if len(t) else 0.0,
        "F_y_press_end": float(fy[np.argmin(np.abs(t - 1.0))]) if len(t) else float("nan"),
        "ratio_slide_min": float(np.min(ratio[sl])) if sl.any() else float("nan"),
        "ratio_slide_max": float(np.max(ratio[sl])) if sl.any() else float("nan"),
        **stats,
        "max_newton_per_step": max(stats["newton_iterations"], default=0),
        "max_penetration": max((float(st["max_penetration"]) for st in steps), default=0.0),
        "status": summary.get("status"),
        "error": summary.get("error"),
        "dofs": summary.get("dofs"),
        "ranks": summary.get("ranks"),
    }
    if window.sum() >= 3 and t[-1] >= 2.0 - 1e-9:
        rw = ratio[window]
        m["plateau_ratio"] = float(np.mean(rw))
        m["plateau_ratio_min"] = float(np.min(rw))
        m["plateau_ratio_max"] = float(np.max(rw))
        m["osc_F_x"] = window_stats(ux[window], fx[window], h)
        m["osc_F_y"] = window_stats(ux[window], fy[window], h)
    return m


def main(argv=None) -> dict:
    ap = cm.parser(
        "Ironing 2D (half-ring die slid along a soft slab)", "results/demo_ironing2d", frame=True
    )
    ap.add_argument("--mu", type=float, default=0.3, help="friction coefficient [0.3]")
    ap.add_argument("--press-steps", type=int, default=10, help="steps of the press [10]")
    ap.add_argument("--slide-steps", type=int, default=100, help="steps of the slide [100]")
    ap.add_argument("--press", type=float, default=PRESS, help=f"die indentation [{PRESS}]")
    ap.add_argument("--slide", type=float, default=SLIDE, help=f"die travel [{SLIDE}]")
    ap.add_argument("--uzawa-tol", type=float, default=1e-4, help="Uzawa tolerance [1e-4]")
    ap.add_argument(
        "--pt-factor",
        type=float,
        default=PT_FACTOR,
        help=f"tangential penalty ε_T = PT_FACTOR E*/h [{PT_FACTOR}]",
    )
    ap.add_argument(
        "--penalty-tangential",
        default=None,
        help='ε_T: a number or "auto" (10 E*/h); overrides --pt-factor',
    )
    ap.add_argument("--max-cutbacks", type=int, default=6, help="cutbacks per step [6]")
    ap.add_argument(
        "--atol", type=float, default=None, help="Newton absolute tolerance (a force) [auto]"
    )
    ap.add_argument("--max-it", type=int, default=None, help="Newton iterations per solve [25]")
    ap.add_argument("--line-search", choices=("l2", "basic", "bt", "cp"), default=None, help="[l2]")
    ap.add_argument(
        "--slave",
        choices=("die", "slab"),
        default="slab",
        help="slave surface: slab_top (master die_surface) or die_surface (master slab_top) [slab]",
    )
    cm.add_step_depth_limit(ap, STEP_DEPTH_LIMIT)
    ap.add_argument("--plot", action="store_true", help="write F_x, F_y against u_x")
    ap.add_argument(
        "--tangential-weights",
        choices=TANGENTIAL_WEIGHTS,
        default="standard",
        help="weight functions of the tangential mixed field [standard]",
    )
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    h = H_CONTACT / 2**args.refine
    pt = args.penalty_tangential
    if pt is None:
        pt = args.pt_factor * E_STAR / h
    elif pt != "auto":
        pt = float(pt)
    solver = {"step_depth_limit": args.step_depth_limit}
    if args.atol is not None:
        solver["atol"] = args.atol
    if args.max_it is not None:
        solver["max_it"] = args.max_it
    if args.line_search is not None:
        solver["line_search"] = args.line_search
    sc = scene(
        args.mu,
        args.refine,
        args.integration,
        args.press_steps,
        args.slide_steps,
        args.press,
        args.slide,
        args.uzawa_tol,
        pt,
        args.max_cutbacks,
        solver,
        args.slave,
        args.tangential_weights,
    )
    summary, wall = run_scene(cm.set_frame(sc, args.frame), args.out, comm)
    m = cm.on_root(evaluate, summary, args.mu, args.press, args.slide, h, comm=comm)
    m["wall_time"] = wall
    if args.plot and comm.rank == 0:
        m["png"] = plot(m, Path(args.out) / "ironing2d_forces.png")
    rows = [
        ("status, cutbacks", f"{m['status']}, {m['cutbacks']} (t reached {m['t_reached']:g})"),
        ("solves finished by full steps", str(m["full_step_solves"])),
        ("Newton steps shortened (depth limit)", str(m["limited_steps"])),
        ("solves restarted after a NaN", str(m["backtracked_solves"])),
        ("failed attempts from the predictor", str(m["predictor_failures"])),
        ("F_y at the end of the press", f"{m['F_y_press_end']:.5f}"),
        ("F_x/F_y while sliding", f"{m['ratio_slide_min']:.4f} … {m['ratio_slide_max']:.4f}"),
    ]
    if "plateau_ratio" in m:
        ox, oy = m["osc_F_x"], m["osc_F_y"]
        rows += [
            (
                "plateau F_x/F_y (t ≥ 1.5)",
                f"{m['plateau_ratio']:.4f} [{m['plateau_ratio_min']:.4f}, "
                f"{m['plateau_ratio_max']:.4f}] (μ = {args.mu})",
            ),
            ("plateau F_x, F_y", f"{ox['mean']:.5f}, {oy['mean']:.5f}"),
            (
                "F_x (max−min)/mean, detr. std",
                f"{100 * ox['range']:.2f} %, {100 * ox['std']:.2f} %",
            ),
            (
                "F_y (max−min)/mean, detr. std",
                f"{100 * oy['range']:.2f} %, {100 * oy['std']:.2f} %",
            ),
            (
                "dominant wavelength F_x, F_y",
                f"{ox['wavelength']:.3f}, {oy['wavelength']:.3f} (h = {h:g})",
            ),
            (
                "amplitude at λ = h: F_x, F_y",
                _percent(
                    ox["amp_element"], oy["amp_element"], "slide step > h / 2.2: λ = h aliased"
                ),
            ),
        ]
    rows += [
        ("force balance |C + R|/|R|", f"{m['force_balance']:.2e}"),
        ("max penetration", f"{m['max_penetration']:.3e}"),
        (
            "Newton: max per solve, per step",
            f"{m['max_newton_per_solve']}, {m['max_newton_per_step']}",
        ),
        ("max Uzawa rounds", str(max(m["uzawa_rounds"], default=0))),
        ("wall time", f"{wall:.1f} s"),
    ]
    title = (
        f"ironing2d: μ = {args.mu}, {args.integration}, slave {args.slave}, h = {h:g}, "
        f"ε_T = {pt if isinstance(pt, str) else f'{pt:.4g}'}, {m['ranks']} rank(s), {m['dofs']} dofs, "
        f"{args.press_steps}+{args.slide_steps} steps"
    )
    return report_run(title, rows, m, comm)


def report_run(title: str, rows: list, m: dict, comm) -> dict:
    """Print the report (rank 0), led by the error of a run that stopped on the way, and
    raise RuntimeError on every rank after it; else return ``m``. Also ``demo_ironing3d``."""
    if m["status"] != "ok":
        rows.insert(0, ("FAILED", str(m["error"])))
    cm.report(title, rows, comm)
    if m["status"] != "ok":
        raise RuntimeError(f"run failed at t = {m['t_reached']:g}: {m['error']}")
    return m


def plot(m: dict, path: Path, normal: str = "F_y", name: str = "ironing2d") -> str:
    """F_x and the normal force ``m[normal]`` against the die position u_x (matplotlib,
    Agg); also used by ``demo_ironing3d`` (normal "F_z")."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.asarray(m["t"])
    sl = t >= 1.0 - 1e-12
    ux = np.asarray(m["u_x"])[sl]
    fig, ax = plt.subplots(figsize=(7, 4))
    fn = np.asarray(m[normal])[sl]
    ax.plot(ux, fn, "-", label=f"{normal} (normal)")
    ax.plot(ux, np.asarray(m["F_x"])[sl], "-", label="F_x (tangential)")
    ax.plot(ux, m["mu"] * fn, "k:", lw=0.8, label=f"μ {normal}")
    ax.set_xlabel("die position u_x")
    ax.set_ylabel("force on the slab" + (" (per unit thickness)" if normal == "F_y" else ""))
    ax.set_title(f"{name}, μ = {m['mu']}")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return str(path)


if __name__ == "__main__":
    cm.script(main, "demo_ironing2d")
