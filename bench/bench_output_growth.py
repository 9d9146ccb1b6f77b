"""The output's cost per step over a long run (BENCHMARKS.md §58).

``summary``: summary.json's rewrite after each step, as a run of ``--steps`` steps makes
it: the step records of a finished run's summary.json (``--summary``) are cycled to
``--steps`` records (copies, each with ``t`` set to its step's), and after each record
joins ``steps`` the file is written into a temporary directory, as the run writes it
(:func:`dolfinx_mortar.output.replace_text`), by the encoder before session 50
(``json.dumps(summary, indent=1)``: Python's pure encoder, the whole file) and by
:class:`dolfinx_mortar.output.SummaryText` (the finished records' lines cached). Prints
the median write time of each block of ``--block`` steps, and checks that ``json.load``
of the two files is equal (at the end of each block).

``steps``: a finished run's per-step output time (``timings.output``, since session 50)
against its solve (``wall_time``): medians per block of ``--block`` steps, a linear fit
of each (ms at step 0 + ms per 100 steps, from step 21 on), and the run-level timings.

``series``: one XDMF series (:class:`dolfinx_mortar.output.XDMFSeries`, what a run
writes as fields.xdmf) of ``--steps`` steps on a ``--cells`` quadrilateral mesh of the
unit square, with the six fields of a frictional run (displacement and five scalars),
written as a run writes a step (open, every field, close and publish): the median time
of each block of ``--block`` steps, and a linear fit. Under mpirun too.

Serial, from the repository root::

    OMP_NUM_THREADS=1 /usr/bin/python3 -m dolfinx_mortar run bench/scenes/slide2d_long.toml --out /tmp/slide2d_long
    OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_output_growth.py steps --summary /tmp/slide2d_long/summary.json
    OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_output_growth.py summary --summary /tmp/slide2d_long/summary.json --steps 1200
    OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_output_growth.py series --steps 1200
"""

from __future__ import annotations

import argparse
import copy
import json
import statistics
import sys
import tempfile
from pathlib import Path
from time import perf_counter

from dolfinx_mortar.output import SummaryText, _json_default, replace_text


def _old_text(summary: dict) -> str:
    """summary.json's text as the package wrote it before session 50."""
    return json.dumps(summary, indent=1, default=_json_default)


def bench_summary(path: Path, steps: int, block: int) -> list[dict]:
    """The medians (ms) of the summary.json writes of each block of ``block`` steps, by the
    encoder before session 50 ("old") and by SummaryText ("new"), with the file's size
    (bytes) at the block's end; a list of rows (local)."""
    source = json.loads(Path(path).read_text())
    records = source["steps"]
    if not records:
        raise SystemExit(f"{path}: no step records")
    base = {k: v for k, v in source.items() if k not in ("steps", "timings")}
    base["status"], base["error"] = "running", None
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        out = {w: Path(tmp) / w / "summary.json" for w in ("old", "new")}
        for f in out.values():
            f.parent.mkdir()
        summaries = {w: dict(base, steps=[]) for w in out}
        cache = SummaryText()
        write = {
            "old": lambda s: replace_text(out["old"], _old_text(s)),
            "new": lambda s: replace_text(out["new"], cache.text(s)),
        }
        times = {w: [] for w in out}
        for k in range(1, steps + 1):
            record = copy.deepcopy(records[(k - 1) % len(records)])
            record["t"] = k / steps
            for w in ("old", "new"):
                summaries[w]["steps"].append(record)
                t0 = perf_counter()
                write[w](summaries[w])
                times[w].append(perf_counter() - t0)
            if k % block == 0 or k == steps:
                old, new = (json.loads(out[w].read_text()) for w in ("old", "new"))
                if old != new:
                    raise SystemExit(f"step {k}: the two files differ")
                n = len(times["old"])
                rows.append(
                    {
                        "steps": f"{k - n + 1}-{k}",
                        "old_ms": 1e3 * statistics.median(times["old"]),
                        "new_ms": 1e3 * statistics.median(times["new"]),
                        "old_bytes": out["old"].stat().st_size,
                        "new_bytes": out["new"].stat().st_size,
                    }
                )
                times = {w: [] for w in out}
    return rows


def step_costs(path: Path, block: int) -> tuple[list[dict], dict, dict]:
    """The medians (ms) of ``timings.output`` and ``wall_time`` per block of ``block``
    steps of the run whose summary.json is ``path``, the linear fits of both (steps > 20:
    {key: (ms at step 0, ms per 100 steps)}) and the run-level timings (local)."""
    import numpy as np

    summary = json.loads(Path(path).read_text())
    steps = summary["steps"]
    if not steps or "output" not in steps[0].get("timings", {}):
        raise SystemExit(f"{path}: no step with timings.output (a run before session 50?)")
    output = np.array([1e3 * r["timings"]["output"] for r in steps])
    solve = np.array([1e3 * r["wall_time"] for r in steps])
    rows = []
    for a in range(0, len(steps), block):
        rows.append(
            {
                "steps": f"{a + 1}-{min(a + block, len(steps))}",
                "output_ms": float(np.median(output[a : a + block])),
                "solve_ms": float(np.median(solve[a : a + block])),
            }
        )
    k = np.arange(1, len(steps) + 1)
    fits = {}
    if len(steps) > 22:
        for key, y in (("output", output), ("solve", solve)):
            slope, at0 = np.polyfit(k[20:], y[20:], 1)
            fits[key] = (float(at0), float(100 * slope))
    return rows, fits, summary.get("timings", {})


FIELDS = ("contact_pressure", "gap", "contact_state", "tangential_traction_norm", "slip")


def bench_series(steps: int, block: int, cells: tuple[int, int], comm) -> tuple[list, tuple]:
    """The medians (ms) of a step's write of an XDMF series per block of ``block`` steps,
    and the linear fit (ms at step 0, ms per 100 steps; steps > 20), rank 0's times
    (collective)."""
    import numpy as np
    from dolfinx import fem, mesh

    from dolfinx_mortar import compat
    from dolfinx_mortar.output import XDMFSeries

    msh = mesh.create_rectangle(comm, [[0.0, 0.0], [1.0, 1.0]], cells, mesh.CellType.quadrilateral)
    Q = fem.FunctionSpace(msh, ("CG", 1))
    functions = [fem.Function(compat.vector_space(msh, 1), name="displacement")]
    functions += [fem.Function(Q, name=name) for name in FIELDS]
    tmp = tempfile.mkdtemp() if comm.rank == 0 else None
    out = Path(comm.bcast(tmp, root=0))
    series = XDMFSeries(comm, out / "fields.xdmf", msh)
    times = []
    for k in range(1, steps + 1):
        comm.barrier()
        t0 = perf_counter()
        file = series.open()
        for f in functions:
            f.x.array[:] = k
            file.write_function(f, k / steps)
        series.close()
        times.append(1e3 * (perf_counter() - t0))
    series.finish()
    rows = []
    for a in range(0, steps, block):
        rows.append(
            {
                "steps": f"{a + 1}-{min(a + block, steps)}",
                "ms": statistics.median(times[a : a + block]),
            }
        )
    k = np.arange(1, steps + 1)
    slope, at0 = np.polyfit(k[20:], times[20:], 1) if steps > 22 else (float("nan"),) * 2
    comm.barrier()
    if comm.rank == 0:
        import shutil

        shutil.rmtree(out)
    return rows, (float(at0), float(100 * slope))


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    s = sub.add_parser("summary", help="summary.json's rewrite, old encoder against new")
    s.add_argument("--summary", type=Path, required=True, help="a finished run's summary.json")
    s.add_argument("--steps", type=int, default=1200, help="step records [1200]")
    s.add_argument("--block", type=int, default=100, help="steps per printed median [100]")
    r = sub.add_parser("steps", help="a finished run's per-step output time against its solve")
    r.add_argument("--summary", type=Path, required=True, help="a finished run's summary.json")
    r.add_argument("--block", type=int, default=100, help="steps per printed median [100]")
    x = sub.add_parser("series", help="an XDMF series' write per step")
    x.add_argument("--steps", type=int, default=1200, help="steps [1200]")
    x.add_argument("--block", type=int, default=100, help="steps per printed median [100]")
    x.add_argument("--cells", type=int, nargs=2, default=(6, 5), help="cells in x and y [6 5]")
    args = ap.parse_args(argv)
    if args.what == "series":
        from mpi4py import MPI

        if args.steps < 1 or args.block < 1:
            ap.error("--steps and --block must be >= 1")
        rows, (at0, per100) = bench_series(
            args.steps, args.block, tuple(args.cells), MPI.COMM_WORLD
        )
        if MPI.COMM_WORLD.rank == 0:
            print(f"{'steps':>11} {'ms':>8}")
            for row in rows:
                print(f"{row['steps']:>11} {row['ms']:8.2f}")
            print(f"fit: {at0:.2f} ms at step 0 + {per100:.2f} ms per 100 steps")
        return rows
    if args.what == "steps":
        if args.block < 1:
            ap.error("--block must be >= 1")
        rows, fits, timings = step_costs(args.summary, args.block)
        print(f"{'steps':>11} {'output ms':>10} {'solve ms':>10}")
        for row in rows:
            print(f"{row['steps']:>11} {row['output_ms']:10.2f} {row['solve_ms']:10.2f}")
        for key, (at0, per100) in fits.items():
            print(f"fit {key}: {at0:.2f} ms at step 0 + {per100:.2f} ms per 100 steps")
        print("run-level timings (s):", {k: round(v, 2) for k, v in timings.items()})
        return rows
    if args.steps < 1 or args.block < 1:
        ap.error("--steps and --block must be >= 1")
    rows = bench_summary(args.summary, args.steps, args.block)
    print(f"{'steps':>11} {'old ms':>8} {'new ms':>8} {'old kB':>8} {'new kB':>8}")
    for r in rows:
        print(
            f"{r['steps']:>11} {r['old_ms']:8.2f} {r['new_ms']:8.2f} "
            f"{r['old_bytes'] / 1e3:8.0f} {r['new_bytes'] / 1e3:8.0f}"
        )
    sys.stdout.flush()
    return rows


if __name__ == "__main__":
    main()
