"""Pytest hooks for runs under mpirun: a test that fails on some ranks only ends the run.

A test that fails on one rank while the other ranks go on into a collective (an
assertion on a rank-local value that differs at round-off between ranks, say) left
those ranks waiting forever: the run hung until the ``timeout`` of scripts/test.sh
(25 minutes) and printed no report, since pytest prints failures at the end. Under
mpirun (more than one rank) every rank now

- prints each of its failures on stderr as it happens, with the rank and the test;
- after every test, waits at most :data:`RANK_SKEW_TIMEOUT` seconds for all ranks to
  finish that test too (a non-blocking barrier on a communicator of its own, so that it
  never matches a collective of a test), and otherwise names the test and calls
  ``MPI_Abort``.

The hooks are registered by tests/conftest.py; ``DM_TEST_RANK_TIMEOUT`` (seconds)
overrides the wait. Nothing changes in a serial run.
"""

from __future__ import annotations

import os
import sys
import time

import pytest
from mpi4py import MPI

#: Seconds a rank that finished a test waits for every other rank to finish it (the
#: ranks of a collective test finish within milliseconds of each other).
RANK_SKEW_TIMEOUT = float(os.environ.get("DM_TEST_RANK_TIMEOUT", "300"))

_sync = None  # the barrier's communicator (a duplicate of COMM_WORLD), made on first use


def _parallel() -> bool:
    return MPI.COMM_WORLD.size > 1


def _say(text: str) -> None:
    sys.stderr.write(f"\n[rank {MPI.COMM_WORLD.rank}] {text}\n")
    sys.stderr.flush()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Print this rank's failure of a test phase at once (under mpirun)."""
    outcome = yield
    report = outcome.get_result()
    if _parallel() and report.failed:
        _say(f"{report.nodeid} FAILED in {report.when}:\n{report.longreprtext}")


def pytest_runtest_logfinish(nodeid, location):
    """Wait until every rank has finished the test ``nodeid``, for at most
    RANK_SKEW_TIMEOUT seconds; then abort the whole run (under mpirun; collective)."""
    global _sync
    if not _parallel():
        return
    if _sync is None:
        _sync = MPI.COMM_WORLD.Dup()
    request = _sync.Ibarrier()
    deadline = time.monotonic() + RANK_SKEW_TIMEOUT
    pause = 1e-4
    while not request.Test():
        if time.monotonic() > deadline:
            _say(
                f"{nodeid}: other ranks did not finish this test within "
                f"{RANK_SKEW_TIMEOUT:g} s of this one (a failure on some ranks only "
                "leaves the others waiting in a collective); aborting the run"
            )
            MPI.COMM_WORLD.Abort(1)
        time.sleep(pause)
        pause = min(2.0 * pause, 0.05)
