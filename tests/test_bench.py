"""``dolfinx-mortar bench``: tiny sweeps of hertz2d and patch2d, the CSV, the plots, the CLI.

Serial, in-process (``MPI.COMM_SELF``): not marked mpi. The Hertz levels are coarse
(h_contact 0.4 and 0.2) so that the module runs in seconds; the numbers are checked
for shape (columns, finiteness, monotonicity), not for accuracy (test_demos does that).
"""

from __future__ import annotations

import csv
import json
import logging
import math

import pytest
from mpi4py import MPI

from dolfinx_mortar import cli
from dolfinx_mortar.bench import (
    BENCHMARKS,
    COLUMNS,
    RECOVERIES,
    cost_columns,
    fitted_rate,
    run_bench,
)
from dolfinx_mortar.errors import SceneError

REQUIRED = (
    "benchmark",
    "level",
    "recovery",
    "integration",
    "dofs",
    "slave_nodes",
    "ranks",
    "l2_rel_error",
    "max_rel_error",
    "newton_iterations",
    "uzawa_rounds",
    "wall_time",
    "search_time",
    "contact_assembly_time",
    "bulk_assembly_time",
    "solve_time",
    "peak_memory_mb",
)
#: issue 5's cost columns (time per Newton iteration, contact overhead) and the surface size
COST = ("slave_facets", "time_per_iteration", "contact_overhead")
NUMERIC = [c for c in REQUIRED if c not in ("benchmark", "recovery", "integration")]
NUMERIC += ["h", *COST]
PNGS = ("work_precision.png", "error_vs_h.png", "newton_history.png", "cost.png")


def _read(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def hertz2d(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_hertz2d")
    run_bench("hertz2d", 2, out, comm=MPI.COMM_SELF, h0={"hertz2d": 0.4})
    return out


@pytest.fixture(scope="module")
def patch2d(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_patch2d")
    run_bench("patch2d", 2, out, comm=MPI.COMM_SELF)
    return out


@pytest.mark.parametrize("name", ["hertz2d", "patch2d"])
def test_csv_and_plots(request, name):
    out = request.getfixturevalue(name)
    rows = _read(out / "bench.csv")
    assert tuple(rows[0].keys()) == COLUMNS
    assert set(REQUIRED) <= set(COLUMNS)
    assert len(rows) == 4  # 2 levels x 2 integrations
    assert {r["integration"] for r in rows} == {"element", "segment"}
    for r in rows:
        assert r["benchmark"] == name and r["recovery"] == "lumped"
        for c in NUMERIC:
            assert math.isfinite(float(r[c])), (c, r[c])
        assert int(r["ranks"]) == 1 and int(r["newton_iterations"]) >= 1
        assert float(r["peak_memory_mb"]) > 0 and float(r["wall_time"]) > 0
        # the cost columns: their definitions, from the row's own times (CSV: 6 digits)
        its, wall = int(r["newton_iterations"]), float(r["wall_time"])
        base = float(r["bulk_assembly_time"]) + float(r["solve_time"])
        assert float(r["time_per_iteration"]) == pytest.approx(wall / its, rel=1e-5)
        assert float(r["contact_overhead"]) == pytest.approx(wall / base, rel=1e-5)
        assert float(r["contact_overhead"]) > 1.0  # the contact and the rest cost something
        # one open slave curve of P1/Q1 facets in 2D: a facet between each pair of nodes
        assert int(r["slave_facets"]) == int(r["slave_nodes"]) - 1
        assert (out / f"{name}_L{r['level']}_{r['integration']}" / "summary.json").is_file()
    for integ in ("element", "segment"):
        by_level = sorted((int(r["level"]), r) for r in rows if r["integration"] == integ)
        facets = [int(r["slave_facets"]) for _, r in by_level]
        assert facets[1] > facets[0]
        dofs = [int(r["dofs"]) for _, r in by_level]
        h = [float(r["h"]) for _, r in by_level]
        assert dofs[1] > dofs[0] and h[1] == pytest.approx(h[0] / 2, rel=1e-4)
        if name == "hertz2d":
            l2 = [float(r["l2_rel_error"]) for _, r in by_level]
            assert l2[1] < l2[0]
    if name == "patch2d":  # exact pressure with segment integration
        assert all(float(r["max_rel_error"]) < 1e-8 for r in rows if r["integration"] == "segment")
    for png in PNGS:
        assert (out / png).stat().st_size > 1000


def test_fitted_rate():
    assert fitted_rate([0.4, 0.2, 0.1], [0.16, 0.04, 0.01]) == pytest.approx(2.0)
    assert math.isnan(fitted_rate([0.4], [0.1]))
    # the cost plot's slopes: time per iteration growing like dofs^1.5
    assert fitted_rate([1e3, 4e3, 1.6e4], [0.01, 0.08, 0.64]) == pytest.approx(1.5)


def test_cost_columns():
    row = {"newton_iterations": 4, "wall_time": 2.0, "bulk_assembly_time": 0.1, "solve_time": 0.15}
    cost = cost_columns(row)
    assert cost["time_per_iteration"] == pytest.approx(0.5)
    # total / (iterations × (bulk + solve) per iteration), the row's times being totals
    assert cost["contact_overhead"] == pytest.approx(2.0 / (4 * (0.25 / 4)))
    assert math.isnan(cost_columns({**row, "newton_iterations": 0})["time_per_iteration"])
    no_base = {**row, "bulk_assembly_time": 0.0, "solve_time": 0.0}
    assert math.isnan(cost_columns(no_base)["contact_overhead"])


def test_cli_bench_ok(tmp_path, capsys):
    out = tmp_path / "b"
    args = ["bench", "patch2d", "--levels", "1", "--integration", "segment", "--out", str(out)]
    assert cli.main(args) == 0
    assert "[bench] patch2d L0 segment lumped: dofs=" in capsys.readouterr().out
    assert len(_read(out / "bench.csv")) == 1
    args += ["--recovery", "all"]
    assert cli.main(args) == 0
    assert [r["recovery"] for r in _read(out / "bench.csv")] == list(RECOVERIES)


def test_cli_bench_unknown_name(tmp_path, capsys):
    assert cli.main(["bench", "NOPE", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("dolfinx-mortar: error: bench: unknown benchmark 'NOPE'")
    # every name the command takes, the sweep and the locking study too
    assert err[0].endswith(
        "(choose from " + ", ".join((*BENCHMARKS, "all", "hard", "locking")) + ")"
    )
    assert not (tmp_path / "x").exists()


def test_bench_recoveries(tmp_path):
    """``recoveries``: one row (and plot curve) per recovery; the patch test is exact with
    segment integration for each of them."""
    rows = run_bench(
        "patch2d",
        1,
        tmp_path,
        integrations=("segment",),
        comm=MPI.COMM_SELF,
        recoveries=("lumped", "unconstrained", "constrained"),
        plots=False,
    )
    assert [r["recovery"] for r in rows] == ["lumped", "unconstrained", "constrained"]
    assert all(r["max_rel_error"] < 1e-8 for r in rows)
    assert (tmp_path / "patch2d_L0_segment_constrained" / "summary.json").is_file()
    with pytest.raises(SceneError, match="exact"):
        run_bench("patch2d", 1, tmp_path, comm=MPI.COMM_SELF, recoveries=("exact",))


def test_bench_cattaneo2d_tiny(tmp_path, caplog):
    """The frictional benchmark: the L2 error of the tangential traction per level; the
    unconstrained recovery is skipped with a message (friction rejects it)."""
    from dolfinx_mortar.bench import TINY_H0

    caplog.set_level(logging.INFO, logger="dolfinx_mortar.bench")
    rows = run_bench(
        "cattaneo2d",
        1,
        tmp_path,
        integrations=("element",),
        comm=MPI.COMM_SELF,
        h0=TINY_H0,
        recoveries=("lumped", "unconstrained", "constrained"),
        plots=False,
    )
    assert "[bench] cattaneo2d unconstrained: skipped (friction needs p >= 0)" in caplog.messages
    assert [r["recovery"] for r in rows] == ["lumped", "constrained"]
    # each row ran the recovery it is labelled with (the constrained rows once ran lumped)
    for tag, recovery in (("", "lumped"), ("_constrained", "constrained")):
        summary = json.loads(
            (tmp_path / f"cattaneo2d_L0_element{tag}" / "summary.json").read_text()
        )
        (pair,) = summary["modelled"]["contact_pairs"].values()
        assert pair["recovery"] == recovery and pair["tangential_recovery"] == "lumped"
    assert rows[0]["l2_rel_error"] != rows[1]["l2_rel_error"]
    for r in rows:
        for c in NUMERIC:
            assert math.isfinite(float(r[c])), (c, r[c])
        assert 0.0 < r["l2_rel_error"] < 0.6 and r["slave_nodes"] > 5
        assert r["h"] == pytest.approx(TINY_H0["cattaneo2d"])


def test_bench_ironing2d_tiny(tmp_path):
    """Ironing (finite deformation, friction): both tiny levels finish the path, the drag
    oscillation (the "error" columns) falls with the level, and the mean F_x/F_y in gross
    slip is within 3 % of μ = 0.3 (the shallow press ploughs little)."""
    from dolfinx_mortar.bench import ALL_LEVEL_CAPS, TINY_H0

    rows = run_bench(
        "ironing2d",
        2,
        tmp_path,
        integrations=("element",),
        comm=MPI.COMM_SELF,
        h0=TINY_H0,
        plots=False,
    )
    assert [r["level"] for r in rows] == [0, 1]
    for r in rows:
        for c in NUMERIC:
            assert math.isfinite(float(r[c])), (c, r[c])
        ratio = float(r["note"].split("F_x/F_y ")[1].split(",")[0])
        assert ratio == pytest.approx(0.3, rel=0.03), r["note"]
    assert rows[1]["l2_rel_error"] < rows[0]["l2_rel_error"]
    assert rows[1]["max_rel_error"] < rows[0]["max_rel_error"]
    assert rows[0]["l2_rel_error"] < 0.05
    assert ALL_LEVEL_CAPS["ironing2d"] == 2


def test_bench_nothing_to_run(tmp_path):
    """Options that leave no run (friction refuses the unconstrained recovery): one clear
    error, the skip said once, and no output directory (it was created, empty)."""
    out = tmp_path / "none"
    lines = []
    with pytest.raises(SceneError, match="nothing to run for 'cattaneo2d'"):
        run_bench(
            "cattaneo2d",
            1,
            out,
            comm=MPI.COMM_SELF,
            recoveries=("unconstrained",),
            progress=lines.append,
        )
    assert lines == ["[bench] cattaneo2d unconstrained: skipped (friction needs p >= 0)"]
    assert not out.exists()


def test_the_sweep_logs_its_progress_and_prints_nothing(tmp_path, capfd, caplog):
    """run_bench (library code) prints nothing: its progress lines go to the logger
    dolfinx_mortar.bench (INFO), or to ``progress`` where one is given, each run's line
    with the numbers of its row; the command line prints the same lines on stdout. The
    communicator is the caller's: there is no COMM_WORLD default."""
    caplog.set_level(logging.INFO, logger="dolfinx_mortar.bench")
    kw = {"integrations": ("segment",), "plots": False}
    (row,) = run_bench("patch2d", 1, tmp_path / "a", comm=MPI.COMM_SELF, **kw)
    out, _ = capfd.readouterr()
    assert out == ""
    (line,) = [m for m in caplog.messages if m.startswith("[bench] ")]
    assert line.startswith(
        f"[bench] patch2d L0 segment lumped: dofs={row['dofs']}, "
        f"slave nodes={row['slave_nodes']}, L2={row['l2_rel_error']:.3e}, "
        f"max={row['max_rel_error']:.3e}, newton={row['newton_iterations']}, "
    )
    assert row["dofs"] == 112 and row["slave_nodes"] == 8 and row["max_rel_error"] < 1e-8
    caplog.clear()
    lines = []
    run_bench("patch2d", 1, tmp_path / "b", comm=MPI.COMM_SELF, progress=lines.append, **kw)
    assert capfd.readouterr().out == "" and caplog.messages == []
    assert len(lines) == 1 and lines[0].startswith("[bench] patch2d L0 segment lumped: dofs=112,")
    with pytest.raises(TypeError, match="comm"):
        run_bench("patch2d", 1, tmp_path / "c", **kw)


def test_bench_all_says_which_levels_it_caps(tmp_path, monkeypatch):
    """``bench all`` says, once per capped benchmark, how many levels it runs
    (ALL_LEVEL_CAPS: hertz3d and ironing2d 2 of 3), before any run."""
    from dolfinx_mortar import bench

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(bench, "run_one", interrupted)
    monkeypatch.setattr(bench, "_import_demos", lambda: None)
    lines = []
    with pytest.raises(KeyboardInterrupt):
        run_bench("all", 3, tmp_path, comm=MPI.COMM_SELF, progress=lines.append)
    assert lines == [
        "[bench] hertz3d: 2 levels in `bench all` (ALL_LEVEL_CAPS)",
        "[bench] ironing2d: 2 levels in `bench all` (ALL_LEVEL_CAPS)",
    ]


def test_a_new_sweep_removes_the_earlier_csv_and_plots(tmp_path, monkeypatch):
    """A sweep into a directory that holds an earlier sweep's bench.csv and plots removes
    them first: interrupted, it left them next to its own rows (the last probe)."""
    from dolfinx_mortar import bench

    for name in bench.OUTPUT_FILES:
        (tmp_path / name).write_text("an earlier sweep's\n")
    (tmp_path / "notes.txt").write_text("mine\n")

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(bench, "run_one", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_bench("patch2d", 1, tmp_path, comm=MPI.COMM_SELF)
    assert sorted(f.name for f in tmp_path.iterdir()) == ["notes.txt"]
