"""Direct against iterative linear solvers on 3D Hertz: time, memory, linear iterations.

Runs the hertz3d demo's scene (``demos/demo_hertz3d.py``'s ``scene(refine)``: the quarter
model on P1 tetrahedra, linear bulk, 2 load steps; 3.2k dofs at ``--refine 0``, 11k at 1,
53k at 2) once per linear solver and repeat, each run in a process of its own, as a user
runs it::

    OMP_NUM_THREADS=1 /usr/bin/python3 -m dolfinx_mortar run SCENE --out OUT/runs/CASE

(serially, one process at a time, the solvers interleaved within each repeat), and reads
its ``summary.json`` back. The solvers (``--solvers``, default all):

- ``mumps``: the default (``[solver] linear = "mumps"``; LDLᵀ here, the Jacobian being
  symmetric);
- ``gamg``: ``[solver.petsc] ksp_type = "gmres", pc_type = "gamg", ksp_rtol = RTOL``
  (PETSc's smoothed-aggregation AMG);
- ``hypre``: the same with ``pc_type = "hypre"`` (BoomerAMG).

``--ksp-rtol`` sets RTOL (default 1e-8). Per run: Newton iterations and Krylov
iterations (``linear_iterations``, summed over the steps), the linear solve's time and the
run's (summary.json ``timings``), the process's peak resident memory (``os.wait4``), and
against the first solver's run of the same repeat, the largest difference of the nodal
pressures over the largest pressure and of the contact force over its size. Printed as a
table of medians over the repeats (the memory: the largest); ``--csv`` writes every run.
From the repository root::

    OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_linear_solvers.py --refine 2 --repeat 3

BENCHMARKS.md §77 has the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from time import perf_counter

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "demos"))
sys.path.insert(0, str(ROOT / "bench"))

import demo_hertz3d  # noqa: E402
from _table import write_csv  # noqa: E402

from dolfinx_mortar.scene import dump_scene  # noqa: E402

SOLVERS = ("mumps", "gamg", "hypre")
COLUMNS = (
    "repeat",
    "solver",
    "status",
    "dofs",
    "newton",
    "linear_iterations",
    "linear_solve_s",
    "total_s",
    "wall_s",
    "peak_rss_mib",
    "dp_rel",
    "dforce_rel",
)


def solver_table(solver: str, ksp_rtol: float) -> dict:
    """The scene's ``[solver]`` table for ``solver`` (one of :data:`SOLVERS`)."""
    if solver == "mumps":
        return {}
    return {"petsc": {"ksp_type": "gmres", "pc_type": solver, "ksp_rtol": ksp_rtol}}


def run_one(scene: Path, out: Path, timeout: float) -> tuple[int, float, float]:
    """Run ``scene`` through the command line in a process of its own (serial). Returns
    the exit status, the wall time (s) and the process's peak resident memory (MiB)."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    cmd = [sys.executable, "-m", "dolfinx_mortar", "run", str(scene), "--out", str(out)]
    t0 = perf_counter()
    with open(out.parent / f"{out.name}.log", "w") as log:
        proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT)
        timer = threading.Timer(timeout, proc.kill)
        timer.start()
        try:
            _, status, usage = os.wait4(proc.pid, 0)  # the child's own rusage
        finally:
            timer.cancel()
    proc.returncode = rc = os.waitstatus_to_exitcode(status)
    wall = perf_counter() - t0
    rss = usage.ru_maxrss / 1024  # KiB on Linux
    return rc, wall, rss


def read_run(out: Path) -> dict:
    """summary.json's figures of a run, and its last nodal pressures (p_N by node)."""
    s = json.loads((out / "summary.json").read_text())
    steps = s["steps"]
    row = {
        "status": s["status"],
        "dofs": s["dofs"],
        "newton": sum(sum(st["newton_iterations"]) for st in steps),
        "linear_iterations": sum(st["linear_iterations"] for st in steps),
        "linear_solve_s": s["timings"]["linear_solve"],
        "total_s": s["timings"]["total"],
        "force": np.array(next(iter(steps[-1]["contact_force"].values()))) if steps else None,
        "solver_used": s["modelled"]["linear_solver"],
    }
    csv = out / f"contact_sphere_surface_{len(steps)}.csv"
    row["p"] = np.loadtxt(csv, delimiter=",", skiprows=1)[:, 6] if csv.exists() else None
    return row


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--refine", type=int, default=0, help="demo_hertz3d's refinement [0]")
    ap.add_argument("--solvers", nargs="+", choices=SOLVERS, default=list(SOLVERS))
    ap.add_argument("--repeat", type=int, default=1, help="runs of each solver [1]")
    ap.add_argument("--ksp-rtol", type=float, default=1e-8, help="Krylov tolerance [1e-8]")
    ap.add_argument("--timeout", type=float, default=3600.0, help="per run, seconds [3600]")
    ap.add_argument("--out", type=Path, help="keep the runs here [a temporary directory]")
    ap.add_argument("--csv", type=Path, help="write every run's row here")
    args = ap.parse_args(argv)
    if args.repeat < 1 or args.refine < 0:
        ap.error("--repeat must be >= 1 and --refine >= 0")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        base = args.out or Path(tmp)
        (base / "runs").mkdir(parents=True, exist_ok=True)
        scenes = {}
        for solver in args.solvers:
            data = demo_hertz3d.scene(args.refine)
            data["solver"] = solver_table(solver, args.ksp_rtol)
            data["output"] = {"fields": []}
            scenes[solver] = base / f"hertz3d_r{args.refine}_{solver}.toml"
            scenes[solver].write_text(dump_scene(data))
        for k in range(args.repeat):
            first = None
            for solver in args.solvers:
                out = base / "runs" / f"{solver}_{k}"
                rc, wall, rss = run_one(scenes[solver], out, args.timeout)
                row = {"repeat": k, "solver": solver, "wall_s": wall, "peak_rss_mib": rss}
                if (out / "summary.json").exists():
                    row.update(read_run(out))
                else:
                    row["status"] = f"exit {rc}, no summary"
                first = first or row
                if row.get("p") is not None and first.get("p") is not None:
                    scale = np.abs(first["p"]).max()
                    row["dp_rel"] = float(np.abs(row["p"] - first["p"]).max() / scale)
                    f0 = first["force"]
                    row["dforce_rel"] = float(np.abs(row["force"] - f0).max() / np.linalg.norm(f0))
                rows.append(row)
                print(
                    f"repeat {k} {solver:6s} {row['status']}: {row.get('solver_used')}, "
                    f"wall {wall:.1f} s, peak {rss:.0f} MiB",
                    flush=True,
                )
    print(
        f"\nhertz3d --refine {args.refine}, ksp_rtol {args.ksp_rtol:g}: medians over {args.repeat}"
    )
    print(
        "| solver | dofs | Newton | Krylov | linear solve (s) | run (s) | peak memory (MiB) | Δp / p_max | ΔF / ‖F‖ |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for solver in args.solvers:
        mine = [r for r in rows if r["solver"] == solver and r.get("status") == "ok"]
        if not mine:
            print(f"| {solver} | failed: {rows[-1].get('status')} | | | | | | | |")
            continue

        def med(key, mine=mine):
            return statistics.median(r[key] for r in mine)

        dp = max((r.get("dp_rel", 0.0) for r in mine), default=0.0)
        df = max((r.get("dforce_rel", 0.0) for r in mine), default=0.0)
        print(
            f"| {solver} | {mine[0]['dofs']} | {med('newton'):g} | {med('linear_iterations'):g} "
            f"| {med('linear_solve_s'):.2f} | {med('total_s'):.2f} "
            f"| {max(r['peak_rss_mib'] for r in mine):.0f} | {dp:.1e} | {df:.1e} |"
        )
    if args.csv:
        write_csv(rows, args.csv, COLUMNS)
    return rows


if __name__ == "__main__":
    main()
