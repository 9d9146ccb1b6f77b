"""The MPI runs' guard (tests/_mpi_guard.py): a test that fails on one rank only ends the
run with the failure printed, instead of hanging in the other ranks' next collective.
Runs ``mpirun -n 2`` itself on a throw-away test file, so those tests are not marked
``mpi``; the default marker selection under mpirun is checked on 1–3 ranks."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import mpi_marks
from mpi4py import MPI
from test_cli import _env

SKEWED = """
from mpi4py import MPI


def test_fails_on_rank_1_only():
    comm = MPI.COMM_WORLD
    if comm.rank == 1:
        assert comm.rank == 0, "a rank-local value"
    comm.allreduce(1)


def test_collective():
    assert MPI.COMM_WORLD.allreduce(1) == MPI.COMM_WORLD.size
"""


def _pytest_under_mpirun(tmp_path: Path, source: str) -> tuple[subprocess.CompletedProcess, float]:
    (tmp_path / "test_case.py").write_text(source)
    mpirun = shutil.which("mpirun")
    assert mpirun is not None, "mpirun not found on PATH: the MPI tests need Open MPI"
    cmd = [
        mpirun,
        "-q",
        "-n",
        "2",
        sys.executable,
        "-m",
        "mpi4py",
        "-m",
        "pytest",
        "-q",
        "--color=no",
    ]
    cmd += ["-p", "no:cacheprovider", "-p", "_mpi_guard", "test_case.py"]
    env = _env(DM_TEST_RANK_TIMEOUT="3", PYTHONPATH=str(Path(__file__).parent))
    t0 = time.monotonic()
    proc = subprocess.run(
        cmd,
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        stdin=subprocess.DEVNULL,
    )
    return proc, time.monotonic() - t0


def test_a_failure_on_one_rank_aborts_the_run_with_its_report(tmp_path):
    """Rank 1 fails an assertion, rank 0 goes on into a collective: the run ends within
    seconds (DM_TEST_RANK_TIMEOUT = 3 s; it used to hang until test.sh's timeout), with a
    non-zero status, rank 1's failure and the name of the test on stderr."""
    proc, wall = _pytest_under_mpirun(tmp_path, SKEWED)
    assert proc.returncode != 0
    assert wall < 60.0, wall
    err = proc.stderr
    assert "[rank 1] test_case.py::test_fails_on_rank_1_only FAILED in call" in err, err
    assert "a rank-local value" in err
    assert "other ranks did not finish this test" in err and "aborting the run" in err


def test_a_failure_on_every_rank_does_not_abort(tmp_path):
    """A test that fails on every rank is an ordinary failure: the run goes on to the
    next test and reports both (1 failed, 1 passed)."""
    source = SKEWED.replace("if comm.rank == 1:", "if True:").replace("comm.rank == 0, ", "False, ")
    proc, _ = _pytest_under_mpirun(tmp_path, source)
    assert proc.returncode == 1, proc.stderr
    assert "1 failed, 1 passed" in proc.stdout, proc.stdout
    assert "aborting the run" not in proc.stderr


@pytest.mark.mpi
def test_under_mpirun_a_command_line_without_m_selects_the_mpi_tests(request):
    """tests/conftest.py's ``mpi_marks``: on 2 ranks every mpi and mpi2 test, on 3 the
    mpi tests but the mpi_not3 ones (scripts/test.sh's MPI passes give no -m); serially,
    and wherever the command line gives -m, the expression is the command line's."""
    assert mpi_marks(2) == "mpi or mpi2"
    assert mpi_marks(3) == mpi_marks(4) == "mpi and not mpi_not3"
    size = MPI.COMM_WORLD.size
    args = request.config.invocation_params.args
    given = any(a == "-m" or a.startswith("-m") and not a.startswith("--") for a in args)
    if size > 1 and not given:
        assert request.config.option.markexpr == mpi_marks(size)
    elif size == 1 and not given:
        assert request.config.option.markexpr == ""
