"""Surface locking study (Temizer 2013): mesh ratio × dimensionless penalty × integration.

For the flat contact patch test (2D, ``demos/_patch.py``) and the 2D Hertz half model
(``demos/demo_hertz2d.py``), every combination of

- the mesh ratio h_master/h_slave ∈ ``--ratios`` [1/4 1/2 1 2 4],
- the dimensionless penalty κ = ε_N h_slave/E* ∈ ``--kappas`` [1 10 1e2 1e3 1e4]
  (a numeric ``penalty`` ε_N = κ E*/h_slave; E* the plane-strain effective modulus
  1/E* = 1/E'_slave + 1/E'_master, E' = E/(1 − ν²), as ``penalty = "auto"`` uses it:
  "auto" is κ = 100 with the per-node facet size),
- the integration ∈ ``--integrations`` [element segment node] ("node" is the
  node-to-segment baseline) and the recovery ∈ ``--recoveries`` [lumped]
  (a recovery that the library does not offer yet is skipped with a message),

is run as pure penalty (``uzawa_tol = 0``) and, for the mesh ratios in
``--uzawa-ratios`` [1/4 4] (the extreme ratios), also with Uzawa augmentation at the
default tolerance (``uzawa_tol = 1e-6``, ``uzawa_max = 20``). A run that does not
complete is a row with empty metrics and ``status``: ``failed`` (Newton or Uzawa did not
converge after the cutbacks), ``crashed`` (the library raised) or ``stalled`` (more than
``--max-steps`` [64] converged steps: the step size collapsed, see :data:`MAX_STEPS`).
Failures are results here, not errors.

Meshes:

With ``--fixed coarse`` (default) the COARSER of the two interface meshes is held
fixed and the finer one is refined, so that the ratio, not the resolution of the coarse
side, is what varies; ``--fixed slave`` holds the slave mesh and coarsens the master for
ratios > 1 instead (the coarse master then also resolves the contact zone worse).

- patch2d: the fixed side has ``--patch-n`` [15] elements along the interface, the other
  the count nearest to 15 r (or 15/r) that is coprime with 15, so that no interior node
  of the two interface meshes coincides (exact ratios would give nested meshes). The
  actual ratio is in the ``ratio`` column (0.246, 0.484, 0.9375, 2.07, 4.07 by default;
  slave/master counts 15/61, 15/31, 15/16, 31/15, 61/15). ``--patch-ny`` [6] elements
  through each block. Slave: the upper block (``upper_bottom``).
- hertz2d: a copy of the library's ``hertz2d`` geometry in which the cylinder (slave)
  and the block (master) have their own contact-zone sizes h_s and h_m, the fixed one
  ``--hertz-h`` [0.1 ≈ a/10] (gmsh ``Restrict`` fields; registered as the generator
  ``hertz2d_ratio`` for the duration of the sweep only). Defaults: h_s/h_m =
  0.1/0.025, 0.1/0.05, 0.1/0.1, 0.05/0.1, 0.025/0.1.

Metrics per run (nodal pressures p^I of the final step, sorted by x; p0 = 2 for the
patch test, the Hertz peak pressure with the measured load for hertz2d):

- patch2d: ``max_dev`` = max_I |p^I/p0 − 1| over all slave nodes, ``max_dev_interior``
  the same without the two end nodes, ``l2_err`` = the RMS of p^I/p0 − 1;
- hertz2d: ``l2_err`` and ``p_max_err`` as ``demos/_common.profile_metrics`` (L2 of the
  interpolated profile over ±1.25 a; peak error), ``max_dev`` = max_I |p^I − p(x_I)|/p0;
- both: ``osc`` = Σ|p_{i+1} − 2 p_i + p_{i−1}|/p0 over the active nodes
  (``demos/_common.oscillation_index``; hertz2d on the mirrored profile), ``osc_ref`` the
  same index of the exact profile sampled at the same nodes (0 for the patch test: the
  excess over it is what the discretisation adds), ``negative`` = number of p^I < 0
  (the lumped recovery p^I = ⟨λ − εγ⟩ makes it 0 by construction), ``newton`` = total
  Newton iterations (all steps, Uzawa rounds and cutbacks), ``uzawa_rounds``,
  ``cutbacks`` (those of a failed step included), ``wall`` (of the whole run: mesh
  generation, set-up, failed attempts included). ``newton`` and ``uzawa_rounds`` count
  the converged steps only (summary.json does not record failed attempts).

Writes ``OUT/locking.csv`` (one row per run, rewritten after every run) and
``OUT/locking.md`` (pivot tables: rows integration × ratio, columns κ). Run from the
repository root, serially (``OMP_NUM_THREADS=1``)::

    OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_locking.py --out bench/out/locking
    OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_locking.py --quick --out /tmp/locking

``--quick`` is a small subset (< 30 s serially once the numba kernels are compiled;
about 2 min in a fresh clone, which compiles them first): patch2d at ratios 1/4 and 4
with κ = 1 and 1e4 (Uzawa at ratio 4) and hertz2d at h_slave = 0.2, ratio 2, κ = 100.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import math
import re
import sys
from pathlib import Path
from time import perf_counter

ROOT = Path(__file__).resolve().parents[1]
for _p in (str(ROOT / "demos"), str(ROOT), str(ROOT / "bench")):
    if _p not in sys.path:
        sys.path.insert(0, _p)

import _common as cm  # noqa: E402 - demos/
import _patch  # noqa: E402
import _table  # noqa: E402 - bench/
import demo_hertz2d as hz  # noqa: E402
import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

from dolfinx_mortar.output import check_out_dir  # noqa: E402

RATIOS = (0.25, 0.5, 1.0, 2.0, 4.0)
KAPPAS = (1.0, 10.0, 100.0, 1e3, 1e4)
INTEGRATIONS = ("element", "segment", "node")
RECOVERIES = ("lumped",)
#: the method's recoveries, what ``--recoveries`` may name (a version of the package
#: without one of them skips it: :func:`available_recoveries`)
METHOD_RECOVERIES = ("lumped", "unconstrained", "constrained")
UZAWA_RATIOS = (0.25, 4.0)
UZAWA_TOL = 1e-6  # the scene default
BENCHMARKS = ("patch2d", "hertz2d")
#: A run with more converged steps than this is stopped ("stalled"): the load stepper
#: resets its cutback count after every converged step, so a persistent failure at some
#: t* makes it creep towards t* with ever smaller steps until the step underflows.
MAX_STEPS = 64

QUICK = {
    "patch2d": {"ratios": (0.25, 4.0), "kappas": (1.0, 1e4), "uzawa_ratios": (4.0,)},
    "hertz2d": {"ratios": (2.0,), "kappas": (100.0,), "uzawa_ratios": (), "hertz_h": 0.2},
}

COLUMNS = (
    "benchmark",
    "recovery",
    "integration",
    "mode",
    "ratio_target",
    "ratio",
    "meshes",
    "h_slave",
    "h_master",
    "slave_nodes",
    "kappa",
    "penalty",
    "status",
    "steps",
    "cutbacks",
    "newton",
    "uzawa_rounds",
    "max_dev",
    "max_dev_interior",
    "l2_err",
    "p_max_err",
    "osc",
    "osc_ref",
    "negative",
    "force_err",
    "wall",
    "error",
)

log = logging.getLogger("bench_locking")


def plane_modulus(E: float, nu: float) -> float:
    return E / (1.0 - nu**2)


def effective_modulus(E: float, nu: float) -> float:
    """E* of two bodies of the same material (as MortarContact computes it)."""
    return 0.5 * plane_modulus(E, nu)


# ---------------------------------------------------------------------------- meshes


def coprime_near(n0: int, target: float) -> int:
    """The element count (>= 2) nearest to ``target`` in log that is coprime with ``n0``."""
    best = None
    for n in range(max(2, math.floor(target) - 4), math.ceil(target) + 5):
        if math.gcd(n, n0) != 1:
            continue
        err = abs(math.log(n / target))
        if best is None or err < best[0] - 1e-12:
            best = (err, n)
    return best[1]


def patch_counts(n0: int, ratio: float, fixed: str = "coarse") -> tuple[int, int]:
    """(slave, master) element counts along the interface for h_master/h_slave ≈ ratio.

    ``fixed = "slave"``: the slave has n0; ``"coarse"``: the coarser side has n0 (the
    slave for ratio <= 1, the master for ratio > 1). The other count is the nearest one
    coprime with n0 (no interior node of the two interface meshes coincides)."""
    if fixed == "coarse" and ratio > 1.0:
        return coprime_near(n0, n0 * ratio), n0
    return n0, coprime_near(n0, n0 / ratio)


def hertz_sizes(h0: float, ratio: float, fixed: str = "coarse") -> tuple[float, float]:
    """(h_slave, h_master) in the contact zone for h_master/h_slave = ratio (see
    :func:`patch_counts` for ``fixed``)."""
    if fixed == "coarse" and ratio > 1.0:
        return h0 / ratio, h0
    return h0, h0 * ratio


def _build_hertz2d_ratio(h_master, **params):
    """The library's hertz2d geometry, the block meshed with h_master in the contact zone."""
    import gmsh

    from dolfinx_mortar import generators as g

    meta = g._build_hertz2d(**params)  # sets a Box background field with h_contact everywhere
    mf = gmsh.model.mesh.field
    restricted = []
    for body, h_in in (("cylinder", params["h_contact"]), ("block", h_master)):
        _, tag = meta["groups"][body]
        surfaces = [int(e) for e in gmsh.model.getEntitiesForPhysicalGroup(2, tag)]
        curves = sorted(
            {
                abs(int(c))
                for s in surfaces
                for _, c in gmsh.model.getBoundary([(2, s)], combined=False, oriented=False)
            }
        )
        box = mf.add("Box")
        c, gap0 = params["c_zone"], params["gap0"]
        values = {
            "VIn": h_in,
            "VOut": params["h_far"],
            "Thickness": max(params["h_far"] - h_in, 0.0) / params["grading"],
            "XMin": -c,
            "XMax": c,
            "YMin": -c,
            "YMax": c + gap0,
            "ZMin": -1.0,
            "ZMax": 1.0,
        }
        for key, value in values.items():
            mf.setNumber(box, key, value)
        r = mf.add("Restrict")
        mf.setNumber(r, "InField", box)
        mf.setNumbers(r, "SurfacesList", surfaces)
        mf.setNumbers(r, "CurvesList", curves)
        restricted.append(r)
    fmin = mf.add("Min")
    mf.setNumbers(fmin, "FieldsList", restricted)
    mf.setAsBackgroundMesh(fmin)
    return meta


@contextlib.contextmanager
def hertz2d_ratio_generator():
    """Register the generator ``hertz2d_ratio`` (hertz2d + ``h_master``) while inside."""
    from dolfinx_mortar import generators as g

    base = g.GENERATORS["hertz2d"]
    gen = g.Generator(
        name="hertz2d_ratio",
        description="hertz2d with a different contact-zone element size on the block (master)",
        params={
            **base.params,
            "h_master": (float, base.params["h_contact"][1], "block size in the contact zone"),
        },
        build=_build_hertz2d_ratio,
        gdim=2,
        checks=base.checks + (("h_master", lambda p: p["h_master"] > 0.0, "must be positive"),),
    )
    previous = g.GENERATORS.get(gen.name)
    g.GENERATORS[gen.name] = gen  # the scene accepts the registry's names
    try:
        yield gen.name
    finally:
        if previous is None:
            g.GENERATORS.pop(gen.name, None)
        else:
            g.GENERATORS[gen.name] = previous


# ---------------------------------------------------------------------------- scenes


def patch_case(ratio: float, n0: int, n_y: int, fixed: str = "coarse") -> dict:
    n_slave, n_master = patch_counts(n0, ratio, fixed)
    return {
        "ratio": n_slave / n_master,
        "h_slave": _patch.L / n_slave,
        "h_master": _patch.L / n_master,
        "meshes": f"{n_slave}/{n_master}",
        "params": {"n_upper": n_slave, "n_lower": n_master, "n_y": n_y},
        "E_star": effective_modulus(_patch.E, _patch.NU),
    }


def patch_scene(case, integration, recovery, penalty, uzawa_tol) -> dict:
    sc = _patch.scene(2, 0, integration)
    sc["mesh"]["params"].update(case["params"])
    sc["contact"][0].update(recovery=recovery, penalty=penalty, uzawa_tol=uzawa_tol)
    sc["output"]["fields"] = []  # the contact CSV is always written; no XDMF fields
    return sc


def hertz_case(ratio: float, h0: float, fixed: str = "coarse") -> dict:
    h_slave, h_master = hertz_sizes(h0, ratio, fixed)
    return {
        "ratio": h_master / h_slave,
        "h_slave": h_slave,
        "h_master": h_master,
        "meshes": f"{h_slave:g}/{h_master:g}",
        "E_star": effective_modulus(hz.E, hz.NU),
    }


def hertz_scene(case, integration, recovery, penalty, uzawa_tol) -> dict:
    sc = hz.scene(0, integration=integration, quads=False)  # triangles, as in BENCHMARKS §9
    sc["mesh"]["generator"] = "hertz2d_ratio"
    sc["mesh"]["params"].update(h_contact=case["h_slave"], h_master=case["h_master"])
    sc["contact"][0].update(recovery=recovery, penalty=penalty, uzawa_tol=uzawa_tol)
    sc["output"]["fields"] = []
    return sc


# ---------------------------------------------------------------------------- metrics


def patch_metrics(summary, out_dir) -> dict:
    slave, master = "upper_bottom", "lower_top"
    m = _patch.evaluate(summary, out_dir, 2, slave, master)
    d = cm.final_csv(out_dir, slave)
    o = np.argsort(d["x"], kind="stable")
    p = d["p_N"][o]
    dev = p / _patch.P0 - 1.0
    return {
        "slave_nodes": len(p),
        "max_dev": float(np.max(np.abs(dev))),
        "max_dev_interior": float(np.max(np.abs(dev[1:-1]))) if len(p) > 2 else float("nan"),
        "l2_err": float(np.sqrt(np.mean(dev**2))),
        "p_max_err": float(p.max() / _patch.P0 - 1.0),
        "osc": cm.oscillation_index(p, _patch.P0),
        "osc_ref": 0.0,
        "negative": int(np.sum(p < 0.0)),
        "force_err": m["force_err"],
    }


def hertz_metrics(summary, out_dir) -> dict:
    m = hz.evaluate(summary, out_dir)
    x, p = (np.asarray(v) for v in m["profile"])
    pe = m["p0"] * np.sqrt(np.clip(1.0 - (x / m["a"]) ** 2, 0.0, None))
    return {
        "slave_nodes": m["slave_nodes"],
        "max_dev": float(np.max(np.abs(p - pe)) / m["p0"]),
        "max_dev_interior": float("nan"),
        "l2_err": m["l2"],
        "p_max_err": m["p_max_err"],
        "osc": m["oscillation"],
        "osc_ref": cm.oscillation_index(pe, m["p0"]),
        "negative": m["negative"],
        "force_err": m["force_balance"],
    }


class Stalled(RuntimeError):
    """Raised from the progress callback when a run takes more than ``max_steps`` steps."""


def _summary_on_disk(out_dir) -> dict:
    """summary.json as the crashed run left it (its steps are the converged ones)."""
    try:
        return json.loads((Path(out_dir) / "summary.json").read_text())
    except (OSError, ValueError):
        return {"steps": []}


def failed_cutbacks(summary) -> int:
    """Cutbacks of the step that failed (from the error message; 0 for a completed run)."""
    m = re.search(r"failed after (\d+) cutbacks", summary.get("error") or "")
    return int(m.group(1)) if m else 0


def run_case(
    bench, case, integration, recovery, kappa, mode, out_dir, comm, max_steps=MAX_STEPS
) -> dict:
    """One run (collective): the CSV row, failed runs included."""
    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    penalty = kappa * case["E_star"] / case["h_slave"]
    uzawa_tol = 0.0 if mode == "penalty" else UZAWA_TOL
    make = patch_scene if bench == "patch2d" else hertz_scene
    sc = make(case, integration, recovery, penalty, uzawa_tol)
    out_dir = Path(out_dir).resolve()
    parsed = parse_scene(sc, out_dir.parent, source=f"<locking {out_dir.name}>")
    comm.barrier()
    t0 = perf_counter()

    def guard(step, record):
        if step > max_steps:
            raise Stalled(f"more than {max_steps} converged steps (t = {record['t']:.17g})")

    try:
        summary = run(parsed, comm, out_dir, progress=guard)
    except Exception as exc:  # noqa: BLE001 - a crash of the library is a result here
        summary = cm.on_root(_summary_on_disk, out_dir, comm=comm)
        status = "stalled" if isinstance(exc, Stalled) else "crashed"
        summary.update(status=status, error=f"{type(exc).__name__}: {exc}")
    wall = comm.allreduce(perf_counter() - t0, op=MPI.MAX)
    steps = summary["steps"]
    row = {
        "benchmark": bench,
        "recovery": recovery,
        "integration": integration,
        "mode": mode,
        "ratio_target": case.get("ratio_target"),
        "ratio": case["ratio"],
        "meshes": case["meshes"],
        "h_slave": case["h_slave"],
        "h_master": case["h_master"],
        "kappa": kappa,
        "penalty": penalty,
        "status": summary["status"],
        "steps": len(steps),
        "cutbacks": int(sum(int(s.get("cutbacks", 0)) for s in steps)) + failed_cutbacks(summary),
        "newton": int(sum(cm.newton_iterations(summary))),
        "uzawa_rounds": int(sum(int(s["uzawa_rounds"]) for s in steps)),
        "wall": wall,
        "error": (summary.get("error") or "")[:160],
    }
    if summary["status"] == "ok":
        metrics = patch_metrics if bench == "patch2d" else hertz_metrics
        row.update(cm.on_root(metrics, summary, out_dir, comm=comm))
    return row


# ---------------------------------------------------------------------------- output


_fmt = _table.fmt


def write_csv(rows, path) -> None:
    _table.write_csv(rows, path, COLUMNS)


def _cell(row, key, fmt) -> str:
    if row is None:
        return ""
    if row["status"] != "ok":
        return {"failed": "fail", "crashed": "crash", "stalled": "stall"}.get(row["status"], "?")
    v = row.get(key)
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    return fmt(v)


def _kappa(k: float) -> str:
    return f"{k:g}" if k < 1e3 else f"1e{round(math.log10(k))}"


def pivot(rows, bench, mode, key, fmt) -> list[str]:
    """Markdown pivot: one row per (recovery, integration, ratio), one column per κ."""
    sel = [r for r in rows if r["benchmark"] == bench and r["mode"] == mode]
    if not sel:
        return []
    kappas = sorted({r["kappa"] for r in sel})
    keys = []
    for r in sel:
        k = (r["recovery"], r["integration"], r["ratio"])
        if k not in keys:
            keys.append(k)
    index = {(r["recovery"], r["integration"], r["ratio"], r["kappa"]): r for r in sel}
    meshes = {(r["recovery"], r["integration"], r["ratio"]): r["meshes"] for r in sel}
    meshes_head = "slave/master elements" if bench == "patch2d" else "h_s/h_m"
    lines = [
        f"| recovery | integration | h_m/h_s | {meshes_head} | "
        + " | ".join(f"κ={_kappa(k)}" for k in kappas)
        + " |",
        "|---|---|---|---|" + "---|" * len(kappas),
    ]
    for rec, integ, ratio in keys:
        cells = [_cell(index.get((rec, integ, ratio, k)), key, fmt) for k in kappas]
        mesh = meshes[(rec, integ, ratio)]
        lines.append(f"| {rec} | {integ} | {ratio:.3g} | {mesh} | " + " | ".join(cells) + " |")
    return lines


def _e(v) -> str:
    return f"{v:.1e}"


def write_markdown(rows, path, command: str) -> None:
    out = ["# Surface locking study", "", f"    {command}", ""]
    tables = {
        "patch2d": [
            ("max |p/p0 − 1| (all slave nodes)", "max_dev", _e),
            ("max |p/p0 − 1| without the two end nodes", "max_dev_interior", _e),
            ("oscillation index Σ|Δ²p|/p0 (exact: 0)", "osc", _e),
            ("Newton iterations (total)", "newton", str),
        ],
        "hertz2d": [
            ("L2 pressure error (%)", "l2_err", lambda v: f"{100 * v:.2f}"),
            ("max |p − p_ex|/p0 over the nodes (%)", "max_dev", lambda v: f"{100 * v:.1f}"),
            (
                "oscillation index Σ|Δ²p|/p0 (see osc_ref for the exact profile's)",
                "osc",
                lambda v: f"{v:.3f}",
            ),
            ("Newton iterations (total)", "newton", str),
        ],
    }
    for bench, specs in tables.items():
        for mode in ("penalty", "uzawa"):
            for title, key, fmt in specs:
                lines = pivot(rows, bench, mode, key, fmt)
                if not lines:
                    continue
                what = "pure penalty" if mode == "penalty" else f"Uzawa, tol {UZAWA_TOL:g}"
                out += [f"## {bench}, {what}: {title}", "", *lines, ""]
            if bench == "hertz2d":
                refs: dict = {}
                for r in rows:
                    if r["benchmark"] == bench and r["mode"] == mode and r["status"] == "ok":
                        refs.setdefault(r["ratio"], []).append(r["osc_ref"])
                if refs:
                    txt = ", ".join(
                        f"{min(v):.3f}–{max(v):.3f} (ratio {q:.3g})"
                        for q, v in sorted(refs.items())
                    )
                    out += [f"osc_ref, the exact profile's index at the same nodes: {txt}", ""]
    failed = [r for r in rows if r["status"] != "ok"]
    if failed:
        out += ["## Runs that did not complete", ""]
        for r in failed:
            out.append(
                f"- {r['benchmark']} {r['recovery']} {r['integration']} {r['mode']} "
                f"ratio {r['ratio']:.3g} κ {_kappa(r['kappa'])}: {r['error']}"
            )
        out.append("")
    Path(path).write_text("\n".join(out))


# ---------------------------------------------------------------------------- driver


def available_recoveries(requested) -> list[str]:
    from dolfinx_mortar import contact

    have = getattr(contact, "RECOVERIES", ("lumped",))
    out = []
    for r in requested:
        if r in have:
            out.append(r)
        else:
            print(
                f"[locking] recovery {r!r} is not available in this version of dolfinx_mortar "
                f"(have: {', '.join(have)}): skipped",
                flush=True,
            )
    return out


def _positive(kind):
    """An argparse type: ``kind`` (float or int) of a finite value > 0 (a ratio of 0 ran
    into a ZeroDivisionError traceback, a negative one a TypeError, mid-sweep)."""

    def parse(text: str):
        value = kind(text)
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
        return value

    parse.__name__ = kind.__name__  # argparse names the type in its messages
    return parse


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="bench/out/locking", help="output directory")
    ap.add_argument(
        "--quick",
        action="store_true",
        help="a small subset (< 30 s serially with compiled kernels; ~2 min in a fresh clone)",
    )
    ap.add_argument("--benchmarks", nargs="+", choices=BENCHMARKS, default=list(BENCHMARKS))
    positive_float, positive_int = _positive(float), _positive(int)
    ap.add_argument(
        "--ratios", type=positive_float, nargs="+", default=None, help="h_master/h_slave"
    )
    ap.add_argument("--kappas", type=positive_float, nargs="+", default=None, help="ε_N h_slave/E*")
    ap.add_argument("--integrations", nargs="+", choices=INTEGRATIONS, default=list(INTEGRATIONS))
    ap.add_argument("--recoveries", nargs="+", choices=METHOD_RECOVERIES, default=list(RECOVERIES))
    ap.add_argument(
        "--uzawa-ratios",
        type=positive_float,
        nargs="*",
        default=None,
        help="mesh ratios also run with Uzawa on (none: pure penalty only) [0.25 4]",
    )
    ap.add_argument(
        "--max-steps",
        type=positive_int,
        default=MAX_STEPS,
        help="stop a run after this many steps [64]",
    )
    ap.add_argument(
        "--fixed",
        choices=("coarse", "slave"),
        default="coarse",
        help="the mesh held at --patch-n / --hertz-h while the ratio varies: the coarser "
        "side, or the slave [coarse]",
    )
    ap.add_argument(
        "--patch-n", type=positive_int, default=15, help="elements of the fixed side (patch2d) [15]"
    )
    ap.add_argument("--patch-ny", type=positive_int, default=6, help="elements through a block [6]")
    ap.add_argument(
        "--hertz-h",
        type=positive_float,
        default=None,
        help="h_contact of the fixed side (hertz2d) [0.1]",
    )
    return ap.parse_args(argv)


def settings(args, bench: str) -> dict:
    s = {
        "ratios": RATIOS,
        "kappas": KAPPAS,
        "uzawa_ratios": UZAWA_RATIOS,
        "hertz_h": hz.H_CONTACT,
    }
    if args.quick:
        s.update(QUICK[bench])
    for key in ("ratios", "kappas", "uzawa_ratios"):
        v = getattr(args, key)
        if v is not None:
            s[key] = tuple(v)
    if args.hertz_h is not None:
        s["hertz_h"] = args.hertz_h
    return s


def jobs(args, recoveries):
    """(benchmark, case, integration, recovery, kappa, mode) of every run, in run order."""
    for bench in args.benchmarks:
        s = settings(args, bench)
        for ratio in s["ratios"]:
            if bench == "patch2d":
                case = patch_case(ratio, args.patch_n, args.patch_ny, args.fixed)
            else:
                case = hertz_case(ratio, s["hertz_h"], args.fixed)
            case["ratio_target"] = ratio
            modes = ["penalty"] + (["uzawa"] if ratio in s["uzawa_ratios"] else [])
            for mode in modes:
                for recovery in recoveries:
                    for integration in args.integrations:
                        for kappa in s["kappas"]:
                            yield bench, case, integration, recovery, kappa, mode


def main(argv=None, comm=None) -> list[dict]:
    args = parse_args(argv)
    comm = comm or MPI.COMM_WORLD
    logging.getLogger("dolfinx_mortar").setLevel(logging.ERROR)  # cutback warnings: in the CSV
    # the name as given: Path("") resolves to the working directory
    check_out_dir(args.out, "--out", comm)  # SceneError: one line from the CLI
    out = Path(args.out).resolve()
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
    comm.barrier()
    recoveries = available_recoveries(args.recoveries)
    command = "OMP_NUM_THREADS=1 /usr/bin/python3 bench/bench_locking.py " + " ".join(
        argv if argv is not None else sys.argv[1:]
    )
    rows = []
    with hertz2d_ratio_generator():
        for bench, case, integration, recovery, kappa, mode in jobs(args, recoveries):
            name = f"{bench}_{recovery}_{integration}_{mode}_r{case['ratio_target']:g}_k{kappa:g}"
            row = run_case(
                bench, case, integration, recovery, kappa, mode, out / "runs" / name, comm,
                args.max_steps,
            )  # fmt: skip
            rows.append(row)
            if comm.rank == 0:
                print(
                    f"[locking] {name}: {row['status']}, max_dev={_fmt(row.get('max_dev'))}, "
                    f"l2={_fmt(row.get('l2_err'))}, osc={_fmt(row.get('osc'))}, "
                    f"newton={row['newton']}, cutbacks={row['cutbacks']}, t={row['wall']:.2f} s",
                    flush=True,
                )
                write_csv(rows, out / "locking.csv")
    if comm.rank == 0:
        write_csv(rows, out / "locking.csv")
        write_markdown(rows, out / "locking.md", command)
    comm.barrier()
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
