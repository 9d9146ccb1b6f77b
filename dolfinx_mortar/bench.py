"""``dolfinx-mortar bench NAME --levels K``: mesh-level sweeps of the benchmarks.

For each benchmark (``hertz2d``, ``hertz3d``, ``patch2d``, ``cattaneo2d``, ``ironing2d``
or ``all``), each level
k = 0 .. K-1 (the contact-zone element size of the demo's default mesh halved k
times), each integration ("element", "segment") and each recovery (``recoveries``:
"lumped" by default, any of "unconstrained", "constrained") the scene of the
corresponding demo is run in its own directory ``OUT/<name>_L<k>_<integration>``
(``_<recovery>`` appended for the non-lumped recoveries), evaluated with the demo's own
metrics (``demos/_common.py``: pressure profile errors, observed Newton order), and
written as one row of ``OUT/bench.csv``. A progress line per run goes to ``progress``
(the command line prints it on rank 0) or, without one, to this module's logger (INFO).
Then rank 0 draws ``work_precision.png`` (L2 pressure error against wall time,
log-log, one curve per benchmark, recovery and integration), ``error_vs_h.png``
(L2 error against h with the fitted rate in the legend), ``newton_history.png``
(residual norms of the last load step of every run, semilog) and ``cost.png`` (time per
Newton iteration against dofs and against slave facets, log-log, the fitted slopes in
the legends).

The scenes and metrics live in the repository's ``demos/`` directory (they are not
part of the installed library): :func:`run_bench` puts that directory on
``sys.path`` when it runs, so the bench needs the source checkout (the package is
installed editable).

Metrics per benchmark:

- ``hertz2d``: ``l2_rel_error`` = ‖p_h − p‖/‖p‖ of the mirrored profile
  (``profile_metrics``), ``max_rel_error`` = max over slave nodes |p_i − p(x_i)|/p0;
- ``hertz3d``: ``l2_rel_error`` = the demo's L2 error over r < 1.25 a,
  ``max_rel_error`` = |max p_i / p0 − 1| (the peak nodal pressure error);
- ``patch2d``: exact pressure p0 everywhere: ``l2_rel_error`` = ‖p − p0‖/‖p0‖ over
  the slave nodes, ``max_rel_error`` = max |p_i/p0 − 1|.
- ``cattaneo2d`` (friction; lumped or constrained recovery): ``l2_rel_error`` = the L2 error of the
  tangential traction q against Cattaneo–Mindlin over ±1.25 a, ``max_rel_error`` =
  max over slave nodes |q_i − q(x_i)|/(μ p0); level 0 has h = 0.1 (≈ a/6.7).
- ``ironing2d`` (finite deformation, friction μ = 0.3; no analytic solution): the
  die of ``demos/demo_ironing2d.py`` pressed 0.6 (not the demo's 1.4) in 5 steps, then
  slid 2.0 in 25·2^k steps, on a slab lengthened to the left (x from −4, L = 11,
  refined box margin 2.2) so that the contact zone never reaches its free end; level 0
  has h = h_die = 0.2. The continuum drag is steady in gross slip, so the "error"
  columns hold the oscillation of the drag F_x over the window u_x ≥ 1 (t ≥ 1.5):
  ``l2_rel_error`` = std of F_x after removing a linear trend, ``max_rel_error`` =
  (max − min)/mean of F_x, both relative to the mean; the note column gives the mean
  F_x/F_y there. A run that does not finish the path has NaN there (the note says
  where it stopped). (On the demo's deeper path, 1.4, segment integration stalls
  where the slab corner slips; on this one both integrations finish.)

Timings are those of the run's summary.json (``timings``: search, contact assembly,
bulk assembly, linear solve, total), max-reduced over ranks; ``wall_time`` is the
run's total; ``peak_memory_mb`` is ru_maxrss of the process (max over ranks), which
only grows, so it is the peak up to and including that run. Cost columns:
``slave_facets`` (summary.json ``modelled.contact_pairs.*.slave_facets``, summed over
the pairs), ``time_per_iteration`` = wall_time / newton_iterations (s) and
``contact_overhead`` = wall_time / (newton_iterations × (bulk assembly + linear solve
per iteration)) = wall_time / (bulk_assembly_time + solve_time): 1 would be a run that
costs only its bulk assemblies and linear solves; the rest is contact (search, pairing,
recovery, assembly), the line search's residuals, Uzawa updates and Python.
"""

from __future__ import annotations

import csv
import logging
import math
import resource
import sys
from pathlib import Path

import numpy as np

from .errors import SceneError

log = logging.getLogger(__name__)

BENCHMARKS = ("hertz2d", "hertz3d", "patch2d", "cattaneo2d", "ironing2d")
#: ``bench NAME`` -> the script of a source checkout that NAME runs with its own options
#: (``cli._bench_script``): the hard-case sweep and the surface-locking study
BENCH_SCRIPTS = {"hard": "bench_hard_cases.py", "locking": "bench_locking.py"}
#: Benchmarks with friction: the unconstrained recovery is skipped (friction rejects it).
FRICTIONAL = ("cattaneo2d", "ironing2d")
#: ``bench all --levels K`` runs these benchmarks at min(K, cap) levels so that the whole
#: suite fits in 30 minutes on 2 cores (hertz3d level 2, 53k dofs, took ~11 min per
#: integration there when the caps were set; 55–67 s with element integration in
#: session 26, BENCHMARKS §12); ``bench NAME --levels K`` is not capped.
ALL_LEVEL_CAPS = {"hertz3d": 2, "ironing2d": 2}
#: The most levels ``--levels`` takes: each level halves the contact element size, so
#: level 5 has about 4⁵ ≈ 1000 times level 0's dofs in 2D (hertz2d: 3.3 million) and
#: 8⁵ ≈ 33 000 times in 3D. An unbounded K ran on until memory or time ran out, writing a
#: directory per level.
MAX_LEVELS = 6
#: The files a sweep writes into its output directory: the CSV (a row per run) and the
#: plots (:func:`plot`); the output directory's check refuses a directory at their names
CSV_FILE = "bench.csv"
PLOT_FILES = {
    "work_precision": "work_precision.png",
    "error_vs_h": "error_vs_h.png",
    "newton_history": "newton_history.png",
    "cost": "cost.png",
}
OUTPUT_FILES = (CSV_FILE, *PLOT_FILES.values())
INTEGRATIONS = ("element", "segment")
RECOVERIES = ("lumped", "unconstrained", "constrained")

#: Level-0 contact element sizes of ``--tiny`` (quick smoke runs; the patch test is
#: already coarse at its default level 0).
TINY_H0 = {"hertz2d": 0.4, "hertz3d": 0.5, "cattaneo2d": 0.14, "ironing2d": 0.4}
#: Level-0 contact element size of cattaneo2d (≈ a/6.7; the demo's default 0.05 is level 1).
CATTANEO_H0 = 0.1
#: ironing2d: level-0 slab and die element size, die travel, slide steps at level 0, and
#: the start of the force window (die position u_x).
IRONING_H0 = 0.2
IRONING_PRESS = 0.6
IRONING_SLIDE = 2.0
IRONING_SLIDE_STEPS = 25
IRONING_WINDOW = 1.0

COLUMNS = (
    "benchmark",
    "level",
    "recovery",
    "integration",
    "h",
    "dofs",
    "slave_nodes",
    "slave_facets",
    "ranks",
    "l2_rel_error",
    "max_rel_error",
    "newton_iterations",
    "uzawa_rounds",
    "newton_order",
    "wall_time",
    "search_time",
    "contact_assembly_time",
    "bulk_assembly_time",
    "solve_time",
    "time_per_iteration",
    "contact_overhead",
    "peak_memory_mb",
    "note",
)

_TIMING_COLUMNS = {
    "search_time": "search",
    "contact_assembly_time": "contact_assembly",
    "bulk_assembly_time": "bulk_assembly",
    "solve_time": "linear_solve",
    "wall_time": "total",
}


def demos_dir() -> Path:
    """The repository's ``demos`` directory (next to the package in the source checkout)."""
    d = Path(__file__).resolve().parents[1] / "demos"
    if not (d / "_common.py").is_file():
        raise SceneError("bench", f"needs the source checkout's demos directory ({d} not found)")
    return d


def _import_demos():
    d = str(demos_dir())
    if d not in sys.path:
        sys.path.insert(0, d)
    import _common as cm  # noqa: PLC0415 - from demos/, on sys.path only while benching
    import _patch  # noqa: PLC0415
    import demo_cattaneo2d  # noqa: PLC0415
    import demo_hertz2d  # noqa: PLC0415
    import demo_hertz3d  # noqa: PLC0415
    import demo_ironing2d  # noqa: PLC0415

    return cm, demo_hertz2d, demo_hertz3d, _patch, demo_cattaneo2d, demo_ironing2d


def _names(name: str) -> tuple[str, ...]:
    if name == "all":
        return BENCHMARKS
    if name not in BENCHMARKS:
        choices = ", ".join((*BENCHMARKS, "all", *BENCH_SCRIPTS))
        raise SceneError("bench", f"unknown benchmark {name!r} (choose from {choices})")
    return (name,)


def _h0(name: str, h0) -> float | None:
    if h0 is None:
        return None
    if isinstance(h0, dict):
        return h0.get(name)
    return float(h0)


def _scene(mods, name: str, level: int, integration: str, h0, recovery="lumped"):
    """(scene dict, h, evaluate(summary, out_dir) -> metrics on rank 0) of one run."""
    cm, hz2, hz3, patch, catt, iron = mods
    if name == "ironing2d":
        sc, h, evaluate = _ironing_scene(cm, iron, level, integration, h0)
        sc["contact"][0]["recovery"] = recovery
        return sc, h, evaluate
    if name == "cattaneo2d":
        sc = catt.scene(level, integration, recovery=recovery)
        h = (_h0(name, h0) or CATTANEO_H0) / 2**level
        sc["mesh"]["params"]["h_contact"] = h

        def evaluate(summary, out_dir):
            m = catt.evaluate(summary, out_dir, h)
            x, q = np.asarray(m["x"]), np.asarray(m["q"])
            a, c = m["a"], m["c"]
            p0 = 2.0 * m["P"] / (math.pi * a)
            full = catt.MU * p0 * np.sqrt(np.clip(1.0 - (x / a) ** 2, 0.0, None))
            inner = catt.MU * p0 * (c / a) * np.sqrt(np.clip(1.0 - (x / c) ** 2, 0.0, None))
            qe = np.where(np.abs(x) <= c, full - inner, full)
            return {
                "l2_rel_error": m["l2_q"],
                "max_rel_error": float(np.max(np.abs(q - qe)) / (catt.MU * p0)),
                "slave_nodes": len(x),
                "newton_iterations": int(sum(m["newton_iterations"])),
                "uzawa_rounds": int(sum(m["uzawa_rounds"])),
                "newton_order": cm.newton_orders(summary)[-1],
                "residual_norms": [st["residual_norms"] for st in summary["steps"]],
            }

        return sc, h, evaluate
    if name in ("hertz2d", "hertz3d"):
        demo = hz2 if name == "hertz2d" else hz3
        sc = demo.scene(level, integration=integration, recovery=recovery)
        h = (_h0(name, h0) or demo.H_CONTACT) / 2**level
        sc["mesh"]["params"]["h_contact"] = h

        def evaluate(summary, out_dir):
            m = demo.evaluate(summary, out_dir)
            if name == "hertz2d":
                x, p = (np.asarray(v) for v in m["profile"])
                pe = m["p0"] * np.sqrt(np.clip(1.0 - (x / m["a"]) ** 2, 0.0, None))
                mx = float(np.max(np.abs(p - pe)) / m["p0"])
            else:
                mx = abs(m["p_max_err"])
                m["residual_norms"] = [st["residual_norms"] for st in summary["steps"]]
            return {
                "l2_rel_error": m["l2"],
                "max_rel_error": mx,
                "slave_nodes": m["slave_nodes"],
                "newton_iterations": int(sum(m["newton_iterations"])),
                "uzawa_rounds": int(sum(m["uzawa_rounds"])),
                "newton_order": m["newton_order"][-1],
                "residual_norms": m["residual_norms"],
            }

        return sc, h, evaluate

    sc = patch.scene(
        2, level, integration, recovery=recovery
    )  # patch2d: 5/7 elements along x at level 0
    slave, master = sc["contact"][0]["slave"], sc["contact"][0]["master"]
    h = patch.L / sc["mesh"]["params"]["n_upper"]

    def evaluate(summary, out_dir):
        m = patch.evaluate(summary, out_dir, 2, slave, master)
        p = cm.final_csv(out_dir, slave)["p_N"]
        return {
            "l2_rel_error": float(np.linalg.norm(p - patch.P0) / (patch.P0 * math.sqrt(len(p)))),
            "max_rel_error": m["p_err"],
            "slave_nodes": m["slave_nodes"],
            "newton_iterations": int(sum(m["newton_iterations"])),
            "uzawa_rounds": int(sum(m["uzawa_rounds"])),
            "newton_order": cm.newton_orders(summary)[-1],
            "residual_norms": [st["residual_norms"] for st in summary["steps"]],
        }

    return sc, h, evaluate


def _ironing_scene(cm, iron, level: int, integration: str, h0):
    """(scene, h, evaluate) of ironing2d at ``level`` (see the module docstring)."""
    h = (_h0("ironing2d", h0) or IRONING_H0) / 2**level
    n_slide = IRONING_SLIDE_STEPS * 2**level
    sc = iron.scene(
        0.3,
        0,
        integration,
        n_press=5,
        n_slide=n_slide,
        press=IRONING_PRESS,
        slide=IRONING_SLIDE,
        penalty_tangential=iron.PT_FACTOR * iron.E_STAR / h,
    )
    sc["mesh"]["params"].update(h_contact=h, h_die=h, x_left=-4.0, L=11.0, c_zone=2.2)
    sc["title"] = f"ironing2d bench, h {h:g}, {integration}"

    def evaluate(summary, out_dir):
        m = iron.evaluate(summary, 0.3, IRONING_PRESS, IRONING_SLIDE, h)
        u = np.asarray(m["u_x"])
        fx = np.asarray(m["F_x"])
        win = u >= IRONING_WINDOW - 1e-9
        done = m["status"] == "ok" and win.sum() >= 3
        stats = iron.window_stats(u[win], fx[win], h) if done else {}
        slave = sc["contact"][0]["slave"]
        return {
            "l2_rel_error": stats.get("std", float("nan")),
            "max_rel_error": stats.get("range", float("nan")),
            "slave_nodes": len(cm.final_csv(out_dir, slave)["p_N"]) if m["n_steps"] else 0,
            "newton_iterations": int(sum(m["newton_iterations"])),
            "uzawa_rounds": int(sum(m["uzawa_rounds"])),
            "newton_order": cm.newton_orders(summary)[-1] if m["n_steps"] else float("nan"),
            "residual_norms": [st["residual_norms"] for st in summary["steps"]],
            "note": (
                f"F_x/F_y {np.mean(fx[win] / np.asarray(m['F_y'])[win]):.4f}, "
                f"cutbacks {m['cutbacks']}"
                if done
                else f"stopped at t = {m['t_reached']:g}: {m['error']}"
            ),
        }

    return sc, h, evaluate


def run_one(
    mods, name: str, level: int, integration: str, out_dir: Path, comm, h0=None, recovery="lumped"
):
    """Run one benchmark level (collective). Returns (CSV row, last-step residual norms)."""
    from mpi4py import MPI

    cm = mods[0]
    sc, h, evaluate = _scene(mods, name, level, integration, h0, recovery)
    # ironing2d: a run that stops on the way is a result (NaN errors), not an error
    run_scene = mods[5].run_scene if name == "ironing2d" else cm.run_scene
    summary, wall = run_scene(sc, out_dir, comm)
    m = cm.on_root(evaluate, summary, out_dir, comm=comm)
    timings = summary.get("timings", {})
    row = {
        "benchmark": name,
        "level": level,
        "recovery": recovery,
        "integration": integration,
        "h": h,
        "dofs": int(summary["dofs"]),
        "slave_nodes": int(m["slave_nodes"]),
        "ranks": comm.size,
        "l2_rel_error": float(m["l2_rel_error"]),
        "max_rel_error": float(m["max_rel_error"]),
        "newton_iterations": m["newton_iterations"],
        "uzawa_rounds": m["uzawa_rounds"],
        "newton_order": float(m["newton_order"]),
        "note": m.get("note", ""),
    }
    for col, key in _TIMING_COLUMNS.items():
        row[col] = comm.allreduce(float(timings.get(key, 0.0)), op=MPI.MAX)
    pairs = summary.get("modelled", {}).get("contact_pairs", {}).values()
    row["slave_facets"] = int(sum(pr.get("slave_facets", 0) for pr in pairs))
    row.update(cost_columns(row))
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    row["peak_memory_mb"] = comm.allreduce(rss, op=MPI.MAX)
    last = m["residual_norms"][-1] if m["residual_norms"] else []
    history = [float(x) for rnd in last for x in rnd]
    return row, history


def run_bench(
    name: str,
    levels: int,
    out_dir,
    integrations=INTEGRATIONS,
    *,
    comm,
    h0=None,
    plots: bool = True,
    recoveries=("lumped",),
    progress=None,
) -> list[dict]:
    """Run benchmark ``name`` (or "all") at levels 0 .. ``levels``-1 (collective over
    ``comm``, the communicator every run's mesh lives on; required).

    ``h0``: level-0 contact element size of the Hertz benchmarks (a float, or a dict
    by benchmark name; None: the demos' defaults). Writes ``out_dir/bench.csv`` and,
    with ``plots``, the PNGs (rank 0). Returns the rows (on every rank).
    ``recoveries``: the recoveries to run (each a curve of the plots).
    ``progress(line)`` is called on every rank with each progress line (the same on every
    rank): a sweep skipped (friction and the unconstrained recovery), a benchmark's levels
    capped by ``bench all`` (ALL_LEVEL_CAPS), and one line per finished run (its dofs,
    errors, iterations, times, memory); None: each line is logged at INFO.
    Raises SceneError for an unknown name, integration, recovery or a level count < 1.
    """
    report = progress if progress is not None else log.info
    names = _names(name)
    caps = ALL_LEVEL_CAPS if name == "all" else {}
    integrations = tuple(integrations)
    bad = [i for i in integrations if i not in INTEGRATIONS]
    if bad or not integrations:
        raise SceneError("--integration", f"must be element, segment or both, got {bad}")
    recoveries = tuple(recoveries)
    bad = [r for r in recoveries if r not in RECOVERIES]
    if bad or not recoveries:
        raise SceneError("--recovery", f"must be one of {', '.join(RECOVERIES)} or all, got {bad}")
    if not 1 <= int(levels) <= MAX_LEVELS:
        raise SceneError("--levels", f"must be in 1 .. {MAX_LEVELS}, got {levels}")
    # what runs, decided before anything is written: a sweep with nothing to run is a
    # usage error that leaves no output directory behind
    sweeps = []
    for bname in names:
        for integration, recovery in ((i, r) for r in recoveries for i in integrations):
            if bname in FRICTIONAL and recovery == "unconstrained":
                if integration == integrations[0]:
                    report(f"[bench] {bname} {recovery}: skipped (friction needs p >= 0)")
                continue
            nlev = min(int(levels), caps.get(bname, int(levels)))
            if nlev < int(levels) and integration == integrations[0]:
                report(f"[bench] {bname}: {nlev} levels in `bench all` (ALL_LEVEL_CAPS)")
            sweeps.append((bname, integration, recovery, nlev))
    if not sweeps:
        raise SceneError("bench", f"nothing to run for {name!r} with these options (see above)")
    mods = _import_demos()
    out_dir = Path(out_dir).resolve()
    if comm.rank == 0:
        out_dir.mkdir(parents=True, exist_ok=True)
        # an earlier sweep's CSV and plots go: an interrupted sweep left them next to the
        # new rows (the run directories are each rewritten by their run)
        for name in OUTPUT_FILES:
            (out_dir / name).unlink(missing_ok=True)
    comm.barrier()
    rows, histories = [], []
    for bname, integration, recovery, nlev in sweeps:
        for level in range(nlev):
            tag = "" if recovery == "lumped" else f"_{recovery}"
            run_dir = out_dir / f"{bname}_L{level}_{integration}{tag}"
            row, hist = run_one(mods, bname, level, integration, run_dir, comm, h0, recovery)
            rows.append(row)
            histories.append(hist)
            report(
                f"[bench] {bname} L{level} {integration} {recovery}: dofs={row['dofs']}, "
                f"slave nodes={row['slave_nodes']}, L2={row['l2_rel_error']:.3e}, "
                f"max={row['max_rel_error']:.3e}, newton={row['newton_iterations']}, "
                f"uzawa={row['uzawa_rounds']}, t={row['wall_time']:.2f} s "
                f"({row['time_per_iteration']:.3g} s per iteration, overhead "
                f"{row['contact_overhead']:.2f}), "
                f"mem={row['peak_memory_mb']:.0f} MB" + (f", {row['note']}" if row["note"] else "")
            )
            if comm.rank == 0:  # rewritten after every run: a partial sweep keeps its rows
                write_csv(rows, out_dir / CSV_FILE)
    if comm.rank == 0 and plots:
        plot(rows, histories, out_dir)
    comm.barrier()
    return rows


def cost_columns(row: dict) -> dict:
    """``time_per_iteration`` = wall_time / newton_iterations (s) and ``contact_overhead``
    = wall_time / (newton_iterations × (bulk assembly + linear solve per iteration)) =
    wall_time / (bulk_assembly_time + solve_time), the row's times being totals over the
    run (nan without iterations, or without bulk and solve time; local)."""
    its = row["newton_iterations"]
    base = row["bulk_assembly_time"] + row["solve_time"]
    return {
        "time_per_iteration": row["wall_time"] / its if its > 0 else float("nan"),
        "contact_overhead": row["wall_time"] / base if base > 0 else float("nan"),
    }


def write_csv(rows: list[dict], path) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]) for k in COLUMNS})


def _curves(rows: list[dict]) -> dict[tuple, list[int]]:
    """Row indices per (benchmark, recovery, integration), in level order."""
    out: dict[tuple, list[int]] = {}
    for i, r in enumerate(rows):
        out.setdefault((r["benchmark"], r["recovery"], r["integration"]), []).append(i)
    return out


def fitted_rate(h, err) -> float:
    """Slope of log(err) against log(h) (least squares; nan with < 2 usable points): the
    error's rate in h, or any log-log slope (time per iteration against dofs)."""
    h, err = np.asarray(h, dtype=float), np.asarray(err, dtype=float)
    ok = (h > 0) & (err > 0) & np.isfinite(err)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(h[ok]), np.log(err[ok]), 1)[0])


_ERROR_LABEL = "L2 relative error (p; q: cattaneo2d; F_x oscillation: ironing2d)"


def plot(rows: list[dict], histories: list[list[float]], out_dir) -> None:
    """Write work_precision.png, error_vs_h.png, newton_history.png and cost.png (rank 0)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    floor = 1e-16  # round-off errors (patch test, segment integration) on a log axis
    curves = _curves(rows)

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for (b, rec, integ), idx in curves.items():
        t = [rows[i]["wall_time"] for i in idx]
        e = [max(rows[i]["l2_rel_error"], floor) for i in idx]
        ax.loglog(t, e, "o-", label=f"{b} {rec} {integ}")
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel(_ERROR_LABEL)
    ax.set_title("work-precision")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / PLOT_FILES["work_precision"], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for (b, rec, integ), idx in curves.items():
        h = [rows[i]["h"] for i in idx]
        e = [rows[i]["l2_rel_error"] for i in idx]
        q = fitted_rate(h, e)
        rate = f"rate {q:.2f}" if math.isfinite(q) else "rate n/a"
        ax.loglog(h, [max(x, floor) for x in e], "o-", label=f"{b} {rec} {integ} ({rate})")
    ax.set_xlabel("contact element size h")
    ax.set_ylabel(_ERROR_LABEL)
    ax.set_title("error against h (fitted rate in the legend)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / PLOT_FILES["error_vs_h"], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for r, hist in zip(rows, histories, strict=True):
        hist = [x for x in hist if x > 0]
        if hist:
            ax.semilogy(
                range(len(hist)),
                hist,
                ".-",
                label=f"{r['benchmark']} L{r['level']} {r['integration']} {r['recovery']}",
            )
    ax.set_xlabel("Newton iteration of the last load step (all Uzawa rounds)")
    ax.set_ylabel("residual norm")
    ax.set_title("Newton residual histories")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(out_dir / PLOT_FILES["newton_history"], dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(1, 2, figsize=(10, 4.5), sharey=True)
    for ax, key, xlabel in (
        (axes[0], "dofs", "dofs"),
        (axes[1], "slave_facets", "slave facets"),
    ):
        for (b, rec, integ), idx in curves.items():
            x = [rows[i][key] for i in idx]
            y = [rows[i]["time_per_iteration"] for i in idx]
            q = fitted_rate(x, y)
            slope = f"slope {q:.2f}" if math.isfinite(q) else "slope n/a"
            ax.loglog(x, y, "o-", label=f"{b} {rec} {integ} ({slope})")
        ax.set_xlabel(xlabel)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("wall time per Newton iteration (s)")
    fig.suptitle("cost per Newton iteration (fitted log-log slopes in the legends)")
    fig.tight_layout()
    fig.savefig(out_dir / PLOT_FILES["cost"], dpi=120)
    plt.close(fig)
