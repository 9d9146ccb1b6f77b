"""Hard-case stability sweep: each scene of ``bench/scenes`` through the command line.

Every case is one scene file run as a user runs it, in its own process::

    OMP_NUM_THREADS=1 /usr/bin/python3 -m dolfinx_mortar run SCENE --out OUT/runs/CASE

(serially, one process at a time), and its ``summary.json`` is read back. Cases
(``--cases``, default all; ``--quick``: the hertz2d gap and penetration, the four patch
cases and ``hertz2d_kappa1e2_penalty``, which take seconds each):

- ``hertz2d_auto``: the scene of ``demos/demo_hertz2d.py --tri`` (P1 triangles, penalty
  "auto", Uzawa 1e-6): the reference row;
- ``hertz2d_gap``: initial gap 0.01 under force control (the cylinder is held by
  contact only);
- ``hertz2d_penetration``: initial penetration 0.02 under force control;
- ``hertz2d_penalty_low`` / ``_high``: penalty 1e-2 × and 1e3 × the auto-equivalent
  (ε h/E* = 1 and 1e5), Uzawa at the default tolerance;
- ``patch2d_ratio4_*`` / ``patch2d_ratio1_4_*``: the contact patch test with
  h_master/h_slave = 4 (5 master, 20 slave elements) and 1/4 (20 master, 5 slave), element and
  segment integration;
- ``slide_cattaneo2d``: large frictionless sliding (press 0.05, slide 1.0 in 20 steps,
  over 20 master facets);
- ``friction3d_press_slide`` (session 41): a hexahedral block (patch3d, 4 × 4 × 2 on 3
  × 3 × 2, margin 0.2) pressed by 0.02 in 2 steps, then slid by (0.1, 0.05) in 2
  (finite strain, segment integration, μ = 0.3): its first slide step cut back until the
  slip-reversal rule stopped comparing the predictor's state (BENCHMARKS §40);
- ``friction3d_reversal`` (session 41): a hexahedral block (patch3d, 4 × 4 × 2 on 3 × 3
  × 2, margin 0.3) pressed by 0.02 onto a larger one, then slid by +0.1, −0.05, +0.05 in
  x (12 steps; finite strain, segment integration, μ = 2: stick in the press, gross slip
  and two reversals after). With Aitken every press step took 19 Uzawa rounds and the
  second reversal cut back once (BENCHMARKS §42);
- ``block3d_over_corner`` (session 42): a hexahedral block (patch3d, 3 × 3 × 2 on 8 × 8 ×
  2, margin 1.5) pressed by 0.02, then dragged by (2.0, 2.1) in one step over the
  master's corner (finite strain, segment integration, frictionless). Until session 55
  the Uzawa rounds stalled beyond t ≈ 1.86 and the case was an expected clean stop (it
  crept towards it in ever shorter steps before they were bounded by the load step,
  BENCHMARKS §43): the slave nodes beyond the master's edges were paired over slivers of
  their weight whose multipliers never converged. With segment integration's sliver
  nodes (``uzawa.SEGMENT_SLIVER_FRACTION``) it completes: 8 steps, 6 cutbacks;
- ``block3d_slide`` / ``block3d_slide_si`` (session 42): a hexahedral block (patch3d,
  5 × 5 × 2 on 16 × 16 × 2, margin 1.5) pressed by 0.02, then dragged by (1.3, 0.9) in
  one step (finite strain, segment integration, frictionless), in the demos' units and
  in SI units (lengths × 1e-3 in metres, E = 1e11 Pa): the same Newton iterations since
  the rows of constrained dofs are forces (BENCHMARKS §44; 11 against 31 and a full-step
  rescue before).

Generated cases (scene dicts built from the demos, written to ``OUT/scenes/CASE.toml``
with :func:`dolfinx_mortar.scene.dump_scene`, then run the same way):

- ``patch2d_ratio2_*`` / ``patch2d_ratio1_2_*``: the patch cases with 15 slave / 7 master
  and 7 slave / 15 master elements (h_master/h_slave ≈ 2.1 and 0.47), element and segment;
- ``hertz2d_kappa1eK_uzawa`` / ``_penalty`` (K = 0, 2, 4, 6): the penalty
  ε = κ E*/h with κ = ε h/E* = 10^K (E* = 109.89, h = 0.1; "auto" is κ = 100), with
  Uzawa to 1e-6 or as pure penalty (``uzawa_tol = 0``);
- ``hertz2d_nu049_p1`` / ``_p2``: nearly incompressible bulk (ν = 0.49 in both bodies;
  the Hertz reference with that E*), P1 and P2;
- ``cattaneo2d_reversal``: stick–slip reversal, the Cattaneo–Mindlin platen shifted to +S,
  back to 0, then to −S (4 steps each). Reference (Mindlin–Deresiewicz): the hysteresis
  loop is symmetric, so the final tangential force is −Q(+S); recorded as
  |Q(−S) + Q(+S)|/|Q(+S)|, and the force left at zero shift, Q(0)/Q(+S).

Recorded per case: completed (exit status 0 and ``status = "ok"``), converged steps,
cutbacks (those of a step that finally failed included, from the error message), total
Newton iterations and the largest per step (all Uzawa rounds of the step; failed attempts
are not in summary.json, so not counted), Uzawa rounds, the process's wall time (start-up,
mesh and JIT included) and the load stepping's own time (summary ``timings.total``), and
the final error where there is an analytic reference: hertz2d (force control, so the
initial gap or penetration does not change the final state): the L2 pressure error and the
peak error against Hertz with the measured load and the pressure oscillation index
(``demos/demo_hertz2d.evaluate``); patch2d: max |p/p0 − 1| over the slave nodes; the
largest penetration of the last step (summary ``max_penetration``). ``--recovery`` sets the recovery of every contact pair (the scenes are rewritten under
``OUT/scenes``); friction refuses ``unconstrained``, which then shows as a clean failure.
``--uzawa-acceleration`` sets the multiplier update of every pair (``newton``, the exact
update, only of the pairs where it applies: with friction the lumped tangential recovery,
``scene.exact_update_applies``).
Writes ``OUT/hard_cases.csv`` and ``OUT/hard_cases.md``::

    OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_hard_cases.py --out bench/out/hard_cases
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from pathlib import Path
from time import perf_counter

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "bench" / "scenes"
for _p in (str(ROOT / "demos"), str(ROOT), str(ROOT / "bench")):
    if _p not in sys.path:
        sys.path.insert(0, _p)

import _table  # noqa: E402 - bench/

#: case -> (scene file stem, reference: "hertz2d" | "patch2d" | None, what it tests)
CASES = {
    "hertz2d_auto": ("hertz2d_auto", "hertz2d", "reference: demo scene, penalty auto, Uzawa"),
    "hertz2d_gap": ("hertz2d_gap", "hertz2d", "initial gap 0.01, force control"),
    "hertz2d_penetration": ("hertz2d_penetration", "hertz2d", "initial penetration 0.02"),
    "hertz2d_penalty_low": ("hertz2d_penalty_low", "hertz2d", "penalty 1e-2 × auto, Uzawa"),
    "hertz2d_penalty_high": ("hertz2d_penalty_high", "hertz2d", "penalty 1e3 × auto, Uzawa"),
    "patch2d_ratio4_element": ("patch2d_ratio4_element", "patch2d", "h_m/h_s = 4, element"),
    "patch2d_ratio4_segment": ("patch2d_ratio4_segment", "patch2d", "h_m/h_s = 4, segment"),
    "patch2d_ratio1_4_element": ("patch2d_ratio1_4_element", "patch2d", "h_m/h_s = 1/4, element"),
    "patch2d_ratio1_4_segment": ("patch2d_ratio1_4_segment", "patch2d", "h_m/h_s = 1/4, segment"),
    "slide_cattaneo2d": ("slide_cattaneo2d", None, "frictionless sliding 1.0 in 20 steps"),
    "friction3d_press_slide": (
        "friction3d_press_slide",
        None,
        "3D block, μ = 0.3: press 0.02, then slide (0.1, 0.05)",
    ),
    "friction3d_reversal": (
        "friction3d_reversal",
        None,
        "3D block, μ = 2: press, slide +0.1, −0.05, +0.05",
    ),
    "block3d_over_corner": (
        "block3d_over_corner",
        None,
        "3D block dragged over the master's corner (segment)",
    ),
    "block3d_slide": ("block3d_slide", None, "3D block dragged by (1.3, 0.9) in one step"),
    "block3d_slide_si": (
        "block3d_slide_si",
        None,
        "the same in SI units (metres, E = 1e11 Pa)",
    ),
}
#: ε h/E* of hertz2d's "auto" penalty is 100: ε = κ · E*/h with E*/h = 109.89/0.1
HERTZ2D_E_STAR_OVER_H = 200.0 / (2.0 * (1.0 - 0.3**2)) / 0.1
KAPPA_EXPONENTS = (0, 2, 4, 6)


def _hertz2d(nu: float = 0.3, order: int = 1, **contact) -> dict:
    import demo_hertz2d as hz

    sc = hz.scene(0, order, quads=False)  # the P1-triangle mesh of BENCHMARKS §10
    sc["contact"][0].update(contact)
    for mat in sc["material"]:
        mat["nu"] = nu
    return sc


def _reversal() -> dict:
    """Cattaneo–Mindlin, then the shift reversed: +S at t = 2, 0 at t = 3, −S at t = 4."""
    import demo_cattaneo2d as catt

    sc = catt.scene()
    d, s = catt.DEPTH, catt.SHIFT
    (moved,) = [b for b in sc["dirichlet"] if b["boundary"] == "upper_top"]
    moved["path"] = [[0.0, 0.0, 0.0], [1.0, 0.0, -d], [2.0, s, -d], [3.0, 0.0, -d], [4.0, -s, -d]]
    quarter = [0.25, 0.5, 0.75]
    sc["steps"] = {
        "t_end": 4.0,
        "n": 4,
        "output_times": [0.5] + [k + f for k in (1, 2, 3) for f in quarter],
    }
    return sc


def _patch_ratio(n_lower: int, n_upper: int, integration: str) -> dict:
    """The patch scene of ``bench/scenes/patch2d_ratio4_*`` with other element counts
    (h_master/h_slave = n_upper/n_lower; slave upper_bottom)."""
    import tomllib

    data = tomllib.loads((SCENES / "patch2d_ratio4_element.toml").read_text())
    data["mesh"]["params"].update(n_lower=n_lower, n_upper=n_upper)
    data["contact"][0]["integration"] = integration
    data["title"] = f"patch2d, {n_upper} slave / {n_lower} master elements, {integration}"
    data.get("output", {}).pop("dir", None)
    return data


#: case -> (scene builder, reference, what)
GENERATED = {
    **{
        f"patch2d_ratio{name}_{integ}": (
            lambda nl=nl, nu=nu, integ=integ: _patch_ratio(nl, nu, integ),
            "patch2d",
            f"h_m/h_s = {nu}/{nl}, {integ}",
        )
        for name, nl, nu in (("2", 7, 15), ("1_2", 15, 7))
        for integ in ("element", "segment")
    },
    **{
        f"hertz2d_kappa1e{k}_{mode}": (
            lambda k=k, mode=mode: _hertz2d(
                penalty=10.0**k * HERTZ2D_E_STAR_OVER_H, uzawa_tol=1e-6 if mode == "uzawa" else 0.0
            ),
            "hertz2d",
            f"ε h/E* = 1e{k}, " + ("Uzawa 1e-6" if mode == "uzawa" else "pure penalty"),
        )
        for k in KAPPA_EXPONENTS
        for mode in ("uzawa", "penalty")
    },
    "hertz2d_nu049_p1": (lambda: _hertz2d(nu=0.49), "hertz2d_nu049", "ν = 0.49, P1"),
    "hertz2d_nu049_p2": (lambda: _hertz2d(nu=0.49, order=2), "hertz2d_nu049", "ν = 0.49, P2"),
    "cattaneo2d_reversal": (_reversal, "reversal", "stick–slip reversal: +S, 0, −S"),
}
ALL_CASES = list(CASES) + list(GENERATED)
QUICK = (
    "hertz2d_gap",
    "hertz2d_penetration",
    "patch2d_ratio4_element",
    "patch2d_ratio4_segment",
    "patch2d_ratio1_4_element",
    "patch2d_ratio1_4_segment",
    "hertz2d_kappa1e2_penalty",
)

COLUMNS = (
    "case",
    "scene",
    "what",
    "completed",
    "exit_code",
    "steps",
    "cutbacks",
    "newton_total",
    "newton_max_step",
    "uzawa_rounds",
    "wall",
    "solve_time",
    "l2_err",
    "p_max_err",
    "max_dev",
    "max_penetration",
    "oscillation",
    "reversal_err",
    "q_residual",
    "error",
)


def run_cli(scene: Path, out_dir: Path, timeout: float) -> tuple[int, float, str]:
    """Run the scene through ``python3 -m dolfinx_mortar run`` (one process, serial)."""
    env = dict(os.environ)
    env["OMP_NUM_THREADS"] = "1"
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    cmd = [sys.executable, "-m", "dolfinx_mortar", "run", str(scene), "--out", str(out_dir)]
    t0 = perf_counter()
    try:
        proc = subprocess.run(
            cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout, check=False
        )
        rc, stdout, stderr = proc.returncode, proc.stdout or "", proc.stderr or ""
    except subprocess.TimeoutExpired as exc:
        rc, stdout = 124, exc.stdout or ""
        stderr = f"{exc.stderr or ''}\ntimed out after {timeout:g} s"
        stdout = stdout.decode() if isinstance(stdout, bytes) else stdout
        stderr = stderr.decode() if isinstance(stderr, bytes) else stderr
    wall = perf_counter() - t0
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "cli.log").write_text(" ".join(cmd) + "\n" + stdout + stderr)
    tail = stderr.strip().splitlines()[-1:]
    return rc, wall, tail[0] if tail else ""


def failed_cutbacks(error: str) -> int:
    m = re.search(r"failed after (\d+) cutbacks", error or "")
    return int(m.group(1)) if m else 0


def evaluate(reference: str | None, summary: dict, out_dir: Path) -> dict:
    """Final error against the analytic reference (completed runs only)."""
    import numpy as np

    if reference in ("hertz2d", "hertz2d_nu049"):
        import demo_hertz2d as hz

        m = hz.evaluate(summary, out_dir, nu=0.49 if reference == "hertz2d_nu049" else 0.3)
        return {"l2_err": m["l2"], "p_max_err": m["p_max_err"], "oscillation": m["oscillation"]}
    if reference == "reversal":
        q = {
            round(float(s["t"]), 9): float(s["reactions"]["upper_top"][0]) for s in summary["steps"]
        }
        return {
            "reversal_err": abs(q[4.0] + q[2.0]) / abs(q[2.0]),
            "q_residual": q[3.0] / q[2.0],
        }
    if reference == "patch2d":
        import _common as cm

        p = cm.final_csv(out_dir, "upper_bottom")["p_N"]
        return {"max_dev": float(np.max(np.abs(p / 2.0 - 1.0)))}
    return {}


def run_case(
    case: str,
    out: Path,
    timeout: float,
    recovery: str | None = None,
    acceleration: str | None = None,
) -> dict:
    """Run one case (``recovery``: set on every contact pair; ``acceleration``: the
    ``uzawa_acceleration`` of every pair, "newton" only of those where it applies;
    either rewrites the scene under OUT)."""
    import tomllib

    from dolfinx_mortar.scene import dump_scene, exact_update_applies

    if case in GENERATED:
        build, reference, what = GENERATED[case]
        data, shown = build(), f"(generated) scenes/{case}.toml"
    else:
        stem, reference, what = CASES[case]
        data, shown = None, f"bench/scenes/{stem}.toml"
        scene = SCENES / f"{stem}.toml"
        if recovery is not None or acceleration is not None:
            data = tomllib.loads(scene.read_text())
            data.get("output", {}).pop("dir", None)  # relative to bench/scenes
            shown = f"{shown} (rewritten)"
    for pair in data.get("contact", []) if data is not None else []:
        if recovery is not None:
            pair["recovery"] = recovery
        exact_ok = exact_update_applies(
            pair.get("friction", 0.0),
            pair.get("recovery", "lumped"),
            pair.get("tangential_recovery", "lumped"),
        )
        if acceleration is not None and (acceleration != "newton" or exact_ok):
            pair["uzawa_acceleration"] = acceleration
    if data is not None:
        scene = out / "scenes" / f"{case}.toml"
        scene.parent.mkdir(parents=True, exist_ok=True)
        scene.write_text(dump_scene(data))
    out_dir = out / "runs" / case
    rc, wall, tail = run_cli(scene, out_dir, timeout)
    row = {"case": case, "scene": shown, "what": what, "exit_code": rc}
    row["wall"] = wall
    summary = {}
    try:
        summary = json.loads((out_dir / "summary.json").read_text())
    except (OSError, ValueError):
        pass
    steps = summary.get("steps", [])
    per_step = [
        int(sum(s["newton_iterations"]))
        if isinstance(s["newton_iterations"], list)
        else int(s["newton_iterations"])
        for s in steps
    ]
    error = summary.get("error") or ("" if rc == 0 else tail)
    row.update(
        completed=rc == 0 and summary.get("status") == "ok",
        steps=len(steps),
        cutbacks=int(sum(int(s.get("cutbacks", 0)) for s in steps)) + failed_cutbacks(error),
        newton_total=sum(per_step),
        newton_max_step=max(per_step, default=0),
        uzawa_rounds=int(sum(int(s.get("uzawa_rounds", 0)) for s in steps)),
        solve_time=float(summary.get("timings", {}).get("total", float("nan"))),
        max_penetration=float(steps[-1]["max_penetration"]) if steps else float("nan"),
        error=(error or "")[:200],
    )
    if row["completed"]:
        row.update(evaluate(reference, summary, out_dir))
    return row


_fmt = _table.fmt


def write_csv(rows, path) -> None:
    _table.write_csv(rows, path, COLUMNS)


def _err(r, md: bool = True) -> str:
    if not r["completed"]:
        return "–"
    if r.get("l2_err") is not None:
        return (
            f"L2 {100 * r['l2_err']:.2f} %, p_max {100 * r['p_max_err']:+.2f} %, "
            f"osc. {r['oscillation']:.2f}"
        )
    if r.get("reversal_err") is not None:
        return f"Q(−S)+Q(+S) {100 * r['reversal_err']:.2f} %, Q(0)/Q(+S) {r['q_residual']:+.3f}"
    if r.get("max_dev") is not None:
        bar = "\\|" if md else "|"
        return f"max {bar}p/p0 − 1{bar} {r['max_dev']:.1e}"
    return "no analytic reference"


def write_markdown(rows, path, command: str) -> None:
    lines = [
        "# Hard-case stability sweep",
        "",
        f"    {command}",
        "",
        "| case | what | completed | steps | cutbacks | Newton total | max Newton/step "
        "| Uzawa rounds | max penetration | wall (s) | solve (s) | final error |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['what']} | {'yes' if r['completed'] else 'no'} | {r['steps']} "
            f"| {r['cutbacks']} | {r['newton_total']} | {r['newton_max_step']} "
            f"| {r['uzawa_rounds']} | {r['max_penetration']:.2e} | {r['wall']:.1f} "
            f"| {_fmt(round(r['solve_time'], 2))} "
            f"| {_err(r)} |"
        )
    failed = [r for r in rows if not r["completed"]]
    if failed:
        lines += ["", "Cases that did not complete:", ""]
        lines += [f"- {r['case']} (exit {r['exit_code']}): {r['error']}" for r in failed]
    Path(path).write_text("\n".join(lines) + "\n")


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="bench/out/hard_cases", help="output directory")
    ap.add_argument("--cases", nargs="+", choices=ALL_CASES, default=None)
    ap.add_argument("--quick", action="store_true", help=f"only {', '.join(QUICK)}")
    ap.add_argument("--timeout", type=float, default=1800.0, help="per case, seconds [1800]")
    ap.add_argument(
        "--recovery",
        choices=("lumped", "unconstrained", "constrained"),
        default=None,
        help="set this recovery on every contact pair [the scenes' own: lumped]",
    )
    ap.add_argument(
        "--uzawa-acceleration",
        choices=("auto", "aitken", "anderson", "none", "newton"),
        default=None,
        help="set uzawa_acceleration on every contact pair (newton: on those where it "
        "applies) [the scenes' own: auto, i.e. newton with lumped recoveries, else aitken]",
    )
    args = ap.parse_args(argv)
    if not args.timeout > 0.0:
        ap.error(f"--timeout must be > 0 seconds, got {args.timeout:g}")
    cases = args.cases or (list(QUICK) if args.quick else ALL_CASES)
    out = Path(args.out).resolve()
    from mpi4py import MPI

    from dolfinx_mortar.output import check_out_dir

    # the name as given: Path("") resolves to the working directory
    check_out_dir(args.out, "--out", MPI.COMM_SELF)  # SceneError: one line from the CLI
    out.mkdir(parents=True, exist_ok=True)
    command = "OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_hard_cases.py " + " ".join(
        argv if argv is not None else sys.argv[1:]
    )
    rows = []
    for case in cases:
        row = run_case(case, out, args.timeout, args.recovery, args.uzawa_acceleration)
        rows.append(row)
        print(
            f"[hard] {case}: completed={row['completed']}, steps={row['steps']}, "
            f"cutbacks={row['cutbacks']}, newton={row['newton_total']} "
            f"(max {row['newton_max_step']}/step), uzawa={row['uzawa_rounds']}, "
            f"wall={row['wall']:.1f} s, error={_err(row, md=False)}",
            flush=True,
        )
        write_csv(rows, out / "hard_cases.csv")
    write_markdown(rows, out / "hard_cases.md", command)
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
