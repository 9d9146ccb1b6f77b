"""Shared helpers of the demo scripts (not part of the library).

- :func:`parser`, :func:`add_step_depth_limit`, :func:`run_scene`: command line and a collective run of a scene dict;
- :func:`final_csv`, :func:`step_csv`: the slave-node table of the last converged step,
  of step k (rank 0);
- :func:`mirror`: unfold a symmetric half model's profile onto -x;
- :func:`profile_metrics`: the peers' pressure metrics (``shared/peers/hertz_common.py``
  ``normal_metrics``): L2 error of the piecewise-linear interpolant of the nodal
  pressures against the exact profile on [-1.25 a, 1.25 a], the peak pressure error
  and the contact half-width, evaluated with the MEASURED load;
- :func:`newton_orders`, :func:`step_orders`, :func:`format_orders`: observed order of convergence of the last
  Newton iterations, read against each step's measured round-off level;
- :func:`oscillation_index`, :func:`report`;
- :func:`press_then_shift`, :func:`elastic`: scene pieces shared by the demos.

Every function that reads files runs on rank 0 only; the demos broadcast their
metrics so that ``main()`` returns the same dictionary on every rank.
"""

from __future__ import annotations

import argparse
import csv
import math
import re
from pathlib import Path

import numpy as np
from mpi4py import MPI

from dolfinx_mortar.output import contact_stem
from dolfinx_mortar.scene import TANGENTIAL_FRAMES

#: A slave node counts as "in contact" when p > ACTIVE_TOL * max(p) (as the peers).
ACTIVE_TOL = 0.01


def parser(
    description: str,
    out: str,
    integration: bool = True,
    recovery: bool = False,
    acceleration: bool | str = False,
    frame: bool = False,
    quadrature: bool = False,
) -> argparse.ArgumentParser:
    """The common options: ``--refine K``, ``--out DIR`` and (optionally) ``--integration``,
    ``--recovery``, ``--uzawa-acceleration`` (see :func:`set_acceleration`; a string
    ``acceleration`` is that option's default, ``True`` means "auto"), ``--frame``
    (:func:`set_frame`) and ``--quadrature-degree`` (:func:`set_quadrature`)."""
    ap = _OneLineParser(description=description)
    ap.add_argument(
        "--refine",
        type=int,
        default=0,
        help="mesh refinement level: the contact-zone element size is halved per level [0]",
    )
    ap.add_argument("--out", default=out, help=f"output directory [{out}]")
    if integration:
        ap.add_argument(
            "--integration",
            choices=("element", "segment", "node"),
            default="element",
            help="mortar integration: slave quadrature, exact segments, or the node-to-segment "
            "baseline [element]",
        )
    if recovery:
        ap.add_argument(
            "--recovery",
            choices=("lumped", "unconstrained", "constrained"),
            default="lumped",
            help="recovery of the nodal mixed gap and pressure (METHOD.md §3) [lumped]",
        )
    if acceleration:
        default = "auto" if acceleration is True else acceleration
        ap.add_argument(
            "--uzawa-acceleration",
            choices=("auto", "aitken", "anderson", "none", "newton"),
            default=default,
            help="update of the multipliers between Uzawa rounds (newton: the exact update, "
            "with friction pairs with the lumped tangential recovery only; auto: newton on "
            "pairs with the lumped recoveries, else aitken, which switches to newton in a "
            f"step whose rounds contract slowly where newton applies) [{default}]",
        )
    if frame:
        ap.add_argument(
            "--frame",
            choices=TANGENTIAL_FRAMES,
            default=TANGENTIAL_FRAMES[0],
            help="tangential_frame of the frictional pairs: the convected slave frame or the "
            "master's convected covariant basis (METHOD.md §1) [slave]",
        )
    if quadrature:
        ap.add_argument(
            "--quadrature-degree",
            type=int,
            default=None,
            metavar="N",
            help="quadrature_degree of every pair: the Gauss rule's degree on each slave facet "
            "(element) or segment (segment), 2..30 [the facet type's default: 7 on P1 lines "
            "and quadrilaterals, 4 on P1 triangles (12 with element integration and no "
            "friction), 11 on P2 lines and quadrilaterals, 6 on P2 triangles]",
        )
    return ap


class _OneLineParser(argparse.ArgumentParser):
    """argparse with its usage errors on one line, ``PROG: error: MESSAGE``, exit status 2
    (each rank prints it: every rank parses its own arguments)."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message}\n")


def set_acceleration(scene: dict, acceleration: str) -> dict:
    """``scene`` with ``uzawa_acceleration`` set on every contact pair (the option
    ``--uzawa-acceleration`` of :func:`parser`); returns the scene."""
    for pair in scene["contact"]:
        pair["uzawa_acceleration"] = acceleration
    return scene


def set_quadrature(scene: dict, degree: int | None) -> dict:
    """``scene`` with ``quadrature_degree`` set on every contact pair (the option
    ``--quadrature-degree`` of :func:`parser`; None leaves the pairs at their facet type's
    default); returns the scene."""
    if degree is not None:
        for pair in scene["contact"]:
            pair["quadrature_degree"] = degree
    return scene


def set_frame(scene: dict, frame: str) -> dict:
    """``scene`` with ``tangential_frame`` set on every frictional contact pair (the option
    ``--frame`` of :func:`parser`); returns the scene."""
    for pair in scene["contact"]:
        if pair.get("friction", 0.0) > 0.0:
            pair["tangential_frame"] = frame
    return scene


def add_step_depth_limit(ap: argparse.ArgumentParser, default: float) -> None:
    """The option ``--step-depth-limit`` (``[solver] step_depth_limit``: the deepest
    penetration, in slave facet sizes, that one Newton step may give a slave node out of
    contact, in every solve; 0 = in first-contact solves only, with the library's
    ``solver.FIRST_CONTACT_DEPTH_LIMIT``) with the demo's ``default``."""
    ap.add_argument(
        "--step-depth-limit",
        type=float,
        default=default,
        help="[solver] step_depth_limit: the deepest penetration (in slave facet sizes) one "
        "Newton step may give a slave node out of contact, in every solve; 0 = in "
        f"first-contact solves only, 0.5 [{default:g}]",
    )


def run_scene(scene: dict, out_dir, comm=MPI.COMM_WORLD, **hooks) -> tuple[dict, float]:
    """Parse and run a scene dict (collective). Returns (summary, wall time in s).

    ``hooks`` (``progress``, ``setup``) go to :func:`dolfinx_mortar.runner.run`.

    Raises RuntimeError on every rank when the run did not finish (status != "ok").
    """
    from time import perf_counter

    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    out_dir = Path(out_dir).resolve()
    parsed = parse_scene(scene, out_dir.parent, source=f"<{scene.get('title', 'demo')}>")
    comm.barrier()
    t0 = perf_counter()
    summary = run(parsed, comm, out_dir, **hooks)
    wall = comm.allreduce(perf_counter() - t0, op=MPI.MAX)
    if summary.get("status") != "ok":
        raise RuntimeError(f"run failed: {summary.get('error')}")
    return summary, wall


def final_csv(out_dir, slave: str) -> dict[str, np.ndarray]:
    """Columns of ``contact_<slave>_<k>.csv`` with the largest k (the final state), as arrays."""
    stem = contact_stem(slave)
    pattern = re.compile(rf"{re.escape(stem)}_(\d+)\.csv$")
    files = {}
    for f in Path(out_dir).iterdir():
        m = pattern.match(f.name)
        if m:
            files[int(m.group(1))] = f
    if not files:
        raise FileNotFoundError(f"no {stem}_<step>.csv in {out_dir}")
    return step_csv(out_dir, slave, max(files))


def step_csv(out_dir, slave: str, k: int) -> dict[str, np.ndarray]:
    """Columns of ``contact_<slave>_<k>.csv`` (k: the step's number, 1 for the first
    step of summary.json's ``steps``), as arrays."""
    with open(Path(out_dir) / f"{contact_stem(slave)}_{k}.csv", newline="") as fh:
        rows = [r for r in csv.reader(fh) if r]
    head = [c.strip() for c in rows[0]]
    data = np.array([[float(c) for c in r] for r in rows[1:]], dtype=float).reshape(-1, len(head))
    return {h: data[:, i] for i, h in enumerate(head)}


def mirror(x: np.ndarray, p: np.ndarray, tol: float = 1e-10) -> tuple[np.ndarray, np.ndarray]:
    """Unfold the profile p(x) of a half model (x >= 0) onto x <= 0; sorted by x.

    A node on the symmetry plane (|x| < tol) appears once.
    """
    o = np.argsort(x)
    x, p = x[o], p[o]
    off = np.abs(x) > tol
    xs = np.concatenate([-x[off][::-1], x])
    ps = np.concatenate([p[off][::-1], p])
    return xs, ps


def _trapz(y, x) -> float:
    """Trapezoidal rule (numpy 1.24 has ``trapz``, numpy 2 ``trapezoid``: neither is used)."""
    y, x = np.asarray(y, dtype=float), np.asarray(x, dtype=float)
    return float(0.5 * np.sum((y[1:] + y[:-1]) * np.diff(x)))


def half_width(xn: np.ndarray, pn: np.ndarray) -> dict:
    """Measured contact half-width of a (full, x-sorted) pressure profile.

    ``a_edge`` (the reported one): the outermost active node on each side
    (p > ACTIVE_TOL max p) extrapolated with a square-root edge through it and its
    inner neighbour, clipped to the interval to the first inactive node, averaged
    over both sides (hertz_common ``normal_metrics``); ``a_lo``/``a_hi`` bracket it
    (last active / first inactive node). ``a_mom`` = 2 sqrt(∫ x² p / ∫ p), exact for
    an elliptic profile.
    """
    pmax = float(pn.max())
    idx = np.where(pn > ACTIVE_TOL * pmax)[0]
    if len(idx) == 0 or pmax <= 0:
        return {"a_edge": 0.0, "a_lo": 0.0, "a_hi": 0.0, "a_mom": float("nan"), "n_active": 0}
    il, ir = idx[0], idx[-1]
    a_lo = 0.5 * (xn[ir] - xn[il])
    xl = xn[il - 1] if il > 0 else xn[il]
    xr = xn[ir + 1] if ir + 1 < len(xn) else xn[ir]
    a_hi = 0.5 * (xr - xl)

    def edge(i_last, i_in, i_out):
        x2, p2 = xn[i_last], pn[i_last]
        xe = x2
        if 0 <= i_in < len(xn) and pn[i_in] > p2:
            x1, p1 = xn[i_in], pn[i_in]
            xe = x2 + (x2 - x1) * p2**2 / (p1**2 - p2**2)
        if 0 <= i_out < len(xn):
            lo, hi = sorted((x2, xn[i_out]))
            xe = min(max(xe, lo), hi)
        return xe

    a_edge = 0.5 * (edge(ir, ir - 1, ir + 1) - edge(il, il + 1, il - 1))
    pp = np.clip(pn, 0.0, None)
    m0 = _trapz(pp, xn)
    a_mom = 2.0 * math.sqrt(_trapz(xn**2 * pp, xn) / m0) if m0 > 0 else float("nan")
    return {"a_edge": a_edge, "a_lo": a_lo, "a_hi": a_hi, "a_mom": a_mom, "n_active": len(idx)}


def profile_metrics(xn: np.ndarray, pn: np.ndarray, a: float, p0: float) -> dict:
    """Errors of the nodal pressures pn at xn (full profile, sorted) against p0 sqrt(1 - x²/a²).

    ``l2``: ‖p_h − p‖/‖p‖ over [−L, L], L = max(1.25 a, a_hi), p_h the piecewise-linear
    interpolant of the nodal values (negative values kept); ``p_max_err``: max p_h / p0 − 1;
    ``a_err``: a_edge / a − 1 (see :func:`half_width`).
    """
    hw = half_width(xn, pn)
    L = max(1.25 * a, hw["a_hi"])
    xs = np.unique(
        np.concatenate([np.linspace(-L, L, 40 * len(xn) + 1), xn[np.abs(xn) <= L], [-a, a]])
    )
    ph = np.interp(xs, xn, pn, left=0.0, right=0.0)
    pe = p0 * np.sqrt(np.clip(1.0 - (xs / a) ** 2, 0.0, None))
    l2 = math.sqrt(_trapz((ph - pe) ** 2, xs) / _trapz(pe**2, xs))
    pmax = float(pn.max())
    return {
        "l2": l2,
        "p_max": pmax,
        "p_max_err": pmax / p0 - 1.0,
        "a_measured": hw["a_edge"],
        "a_err": hw["a_edge"] / a - 1.0,
        "a_mom": hw["a_mom"],
        "a_lo": hw["a_lo"],
        "a_hi": hw["a_hi"],
        "n_active": hw["n_active"],
        "negative": int(np.sum(pn < 0.0)),
        "p_min": float(pn.min()),
    }


def oscillation_index(pn: np.ndarray, p0: float) -> float:
    """Σ |p_{i+1} − 2 p_i + p_{i−1}| / p0 over the active nodes (p > ACTIVE_TOL max p)."""
    act = np.where(pn > ACTIVE_TOL * pn.max())[0]
    if len(act) < 3:
        return 0.0
    q = pn[act[0] : act[-1] + 1]
    return float(np.abs(np.diff(q, 2)).sum() / p0)


#: A residual norm at most FLOOR_FACTOR × the step's measured round-off level f
#: (summary.json steps' ``residual_round_off``, written by ``run(..., round_off=True)``)
#: lies on the round-off floor: the rounding of the assembly, not the iterate, sets it.
FLOOR_FACTOR = 3.0


def observed_order(norms, floor: float = 0.0) -> float:
    """Order of convergence q = log(r_k/r_{k-1}) / log(r_{k-1}/r_{k-2}) from the last three
    residual norms above ``floor`` (nan if fewer than three, or if they do not
    decrease)."""
    r = [float(x) for x in norms if x > max(floor, 0.0)]
    if len(r) < 3:
        return float("nan")
    e0, e1, e2 = r[-3:]
    if not (e2 < e1 < e0):
        return float("nan")
    return math.log(e2 / e1) / math.log(e1 / e0)


def step_floor(step: dict) -> float:
    """FLOOR_FACTOR × the step's measured round-off level f (0 when the run did not
    measure it: then no norm counts as round-off)."""
    return FLOOR_FACTOR * float(step.get("residual_round_off", 0.0))


def solve_order(norms, round_off: float = 0.0) -> tuple[float, bool]:
    """Observed order of one Newton solve's residual norms, and whether it is a bound.

    With f = ``round_off`` (the step's measured round-off level, 0 if unknown) and the
    floor FLOOR_FACTOR × f, two readings:

    - the order of the last three norms above the floor (:func:`observed_order`);
    - when only the last norm r_n is on the floor: the order of r_{n-2}, r_{n-1} and
      r_n + 2f. The rounding can hide a smaller residual in r_n but not a larger one
      than r_n + 2f, so this is a lower bound of the order of the last contraction.

    Returns the larger (``True`` with it when that is the bound). The first reading
    alone reads a pre-asymptotic triple whenever the solve has only two exact
    contractions above round-off (BENCHMARKS.md §2, §24)."""
    r = [float(x) for x in norms if x > 0]
    floor = FLOOR_FACTOR * round_off
    q = observed_order(r, floor)
    if round_off > 0 and len(r) >= 3 and r[-1] <= floor < min(r[-3:-1]):
        bound = observed_order([r[-3], r[-2], r[-1] + 2.0 * round_off])
        if bound > q or (math.isnan(q) and not math.isnan(bound)):
            return bound, True
    return q, False


def _main_round(step: dict) -> list:
    """The step's main Newton solve: the Uzawa round with the most iterations (the first
    one normally: later rounds start near the solution and take one to three)."""
    rounds = step.get("residual_norms") or []
    return max(rounds, key=len) if rounds else []


def step_orders(summary: dict) -> list[tuple[float, bool]]:
    """Per step: :func:`solve_order` of the main Newton solve against the step's measured
    round-off level, (order, whether it is the lower bound); nan where fewer than three
    norms."""
    return [
        solve_order(_main_round(st), float(st.get("residual_round_off", 0.0)))
        for st in summary["steps"]
    ]


def newton_orders(summary: dict) -> list[float]:
    """Per step: the observed order of the main Newton solve (:func:`step_orders`)."""
    return [q for q, _ in step_orders(summary)]


def format_orders(summary: dict) -> str:
    """The per-step orders as the demos print them, a bound marked with "≥"."""
    return ", ".join(f"{'≥' if b else ''}{q:.2f}" for q, b in step_orders(summary))


def quadratic_constants(summary: dict) -> list[float]:
    """Per step, the largest C = r_{k+1} r_0 / r_k² over the last two iterations above the
    step's round-off floor (:func:`step_floor`) of every Uzawa round: bounded C is
    quadratic convergence (r_0 the first norm of the round)."""
    out = []
    for st in summary["steps"]:
        floor = step_floor(st)
        cs = [0.0]
        for r in st.get("residual_norms") or []:
            r = [x for x in r if x > 0]
            for k in range(max(1, len(r) - 2), len(r)):
                if r[k] > floor and r[k - 1] > floor:
                    cs.append(r[k] * r[0] / r[k - 1] ** 2)
        out.append(max(cs))
    return out


def uzawa_round_orders(summary: dict) -> list[list[float]]:
    """Per step, per Uzawa round: the observed order of the norms above the step's
    round-off floor (nan where fewer than three)."""
    return [
        [observed_order(r, step_floor(st)) for r in st.get("residual_norms") or []]
        for st in summary["steps"]
    ]


def newton_iterations(summary: dict) -> list[int]:
    """Total Newton iterations per step (summed over Uzawa rounds)."""
    out = []
    for st in summary["steps"]:
        its = st.get("newton_iterations", 0)
        out.append(int(sum(its)) if isinstance(its, list | tuple) else int(its))
    return out


def solver_stats(summary: dict) -> dict:
    """Newton iterations per step (summed over Uzawa rounds), the most in one Newton solve,
    Uzawa rounds per step, cutbacks in all, the solves continued with full Newton steps
    (solver.FULL_STEP_ITERATIONS) and those restarted with the bt line search after a
    non-finite residual in all, the Newton steps shortened by the penetration limit
    (``[solver] step_depth_limit``) in all, the failed attempts from the predictor in all, and the
    frictional dissipation per step."""
    steps = summary["steps"]
    return {
        "newton_iterations": newton_iterations(summary),
        "max_newton_per_solve": max((max(s["newton_iterations"]) for s in steps), default=0),
        "uzawa_rounds": [int(s["uzawa_rounds"]) for s in steps],
        "cutbacks": sum(int(s["cutbacks"]) for s in steps),
        "full_step_solves": sum(int(s.get("full_step_solves", 0)) for s in steps),
        "limited_steps": sum(int(s.get("limited_steps", 0)) for s in steps),
        "backtracked_solves": sum(int(s.get("backtracked_solves", 0)) for s in steps),
        "predictor_failures": sum(int(s.get("predictor_failures", 0)) for s in steps),
        "dissipation": [float(s.get("dissipation", 0.0)) for s in steps],
    }


def solver_rows(m: dict, wall: float) -> list[tuple[str, str]]:
    """The report rows of :func:`solver_stats` metrics and the wall time."""
    return [
        ("Newton iterations per step", str(m["newton_iterations"])),
        ("max Newton per solve", str(m["max_newton_per_solve"])),
        ("Uzawa rounds", str(m["uzawa_rounds"])),
        ("wall time", f"{wall:.2f} s"),
    ]


def press_then_shift(
    fixed: str, moved: str, depth: float, shift: float, n_press: int, n_shift: int
) -> tuple[list[dict], dict]:
    """The 2D "press, then shift" loading (scene ``dirichlet`` list, ``steps`` table):
    ``fixed`` clamped; ``moved`` goes down by ``depth`` over t ∈ [0, 1], then sideways by
    ``shift`` over [1, 2]; ``n_press`` and ``n_shift`` steps in each phase."""
    dirichlet = [
        {"boundary": fixed, "components": [0, 1], "path": [[0, 0, 0], [2, 0, 0]]},
        {
            "boundary": moved,
            "components": [0, 1],
            "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -depth], [2.0, shift, -depth]],
        },
    ]
    steps = {
        "t_end": 2.0,
        "n": 2,
        "output_times": [k / n_press for k in range(1, n_press)]
        + [1.0 + k / n_shift for k in range(1, n_shift)],
    }
    return dirichlet, steps


def elastic(regions, E: float, nu: float, model: str = "linear-elastic") -> list[dict]:
    """``[[material]]`` entries: the same law for every region."""
    return [{"region": r, "model": model, "E": E, "nu": nu} for r in regions]


def contact_force(summary: dict, pair: str, step: int = -1) -> np.ndarray:
    """Contact force vector of ``pair`` ("SLAVE:MASTER") at a step (default: the last)."""
    return np.asarray(summary["steps"][step]["contact_force"][pair], dtype=float)


def on_root(fn, *args, comm=MPI.COMM_WORLD, **kwargs):
    """Evaluate ``fn(*args, **kwargs)`` on rank 0 and broadcast the result (collective).

    An exception on rank 0 is re-raised on every rank (as RuntimeError elsewhere), so
    that no rank is left waiting in a collective.
    """
    result, error = None, None
    if comm.rank == 0:
        try:
            result = fn(*args, **kwargs)
        except Exception as exc:  # noqa: BLE001 - re-raised below on every rank
            error = exc
    ok = comm.bcast(error is None, root=0)
    if not ok:
        if comm.rank == 0:
            raise error
        raise RuntimeError("evaluation failed on rank 0")
    return comm.bcast(result, root=0)


def script(main, name: str) -> None:
    """Run ``main()`` as a script: exit 0 on success; on a SceneError (raised on every
    rank) print its one line on rank 0 and exit 2; on any other exception print one line
    per rank and exit 1 (aborting the whole MPI job when it runs on several ranks, so that
    no rank hangs). Library warnings are shown on rank 0 only."""
    import logging
    import sys

    comm = MPI.COMM_WORLD
    if comm.rank > 0:  # the library's warnings (step cutbacks) once, not once per rank
        logging.getLogger("dolfinx_mortar").setLevel(logging.ERROR)
    try:
        main()
    except SystemExit:
        raise
    except Exception as exc:  # noqa: BLE001 - the script's one-line error report
        from dolfinx_mortar.errors import SceneError

        if isinstance(exc, SceneError):  # raised on every rank: a clean exit, status 2
            if comm.rank == 0:
                print(f"{name}: {exc}", file=sys.stderr)
            sys.exit(2)
        print(f"{name} failed on rank {comm.rank}: {type(exc).__name__}: {exc}", file=sys.stderr)
        sys.stderr.flush()
        if comm.size > 1:
            comm.Abort(1)
        sys.exit(1)


def report(title: str, rows: list[tuple[str, str]], comm=MPI.COMM_WORLD) -> None:
    """Print ``title`` and one ``name: value`` line per metric (rank 0)."""
    if comm.rank != 0:
        return
    width = max(len(k) for k, _ in rows)
    print(title)
    for k, v in rows:
        print(f"  {k:<{width}} : {v}")
