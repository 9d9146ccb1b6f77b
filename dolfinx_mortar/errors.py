"""Exceptions raised by dolfinx_mortar, and how the ranks of a run agree on a failure.

``SceneError`` is raised for bad user input (scene file, mesh, options) and is
turned into a one-line message and exit status 2 by the command-line driver. It is a
ValueError (``SceneTypeError``, a value of the wrong type, a TypeError), so that the
Python API (``ContactProblem``, ``MortarContact``, ``SolverSettings``), which checks its
arguments with the scene's rules, raises the exceptions Python callers expect.
``ConvergenceError`` is raised when a nonlinear or linear solve, or the Uzawa
augmentation loop, fails; the load-stepping driver catches it and cuts the step.
``OutputError`` is raised on every rank when a run's files cannot be written (a full
disk, a quota); the run stops with the steps written so far.
``Terminated`` (a SystemExit, status 128 + the signal's number) ends a run that SIGTERM
stopped (:func:`stops_on_signals`, :func:`check_stop`), after its summary was written.
"""

import contextlib
import errno
import os
import signal
import stat
import threading


class DolfinxMortarError(Exception):
    """Base class of the package's exceptions."""


class SceneError(DolfinxMortarError, ValueError):
    """Invalid input: the message names the offending key or object and the reason.
    A ValueError: the Python API's arguments are checked by the same rules, and their
    key is then the argument's name (``contact.penalty``, ``SolverSettings.rtol``).

    Parameters
    ----------
    key:
        Dotted path of the offending scene key (e.g. ``"material[1].nu"``) or an
        empty string when the error is not tied to one key.
    reason:
        Human-readable reason, one line.
    """

    def __init__(self, key: str, reason: str):
        self.key = key
        self.reason = reason
        super().__init__(f"{key}: {reason}" if key else reason)


class SceneTypeError(SceneError, TypeError):
    """Invalid input of the wrong type (a string where a number is expected, ...): a
    SceneError, and a TypeError for the Python API's callers."""


class ConvergenceError(DolfinxMortarError):
    """A solve did not converge (SNES, KSP or the Uzawa augmentation loop)."""


class FrozenStatesError(ConvergenceError):
    """The Uzawa rounds of a step stopped because the stick/slip states frozen by the
    chattering control were wrong at convergence, with a growing multiplier change,
    several rounds in a row (``solver.FROZEN_RETRY_ROUNDS_FREE``, or
    ``solver.FROZEN_RETRY_ROUNDS`` with carried states). The load-stepping driver
    first retries the step with the states carried between rounds
    (``contact.MortarContact.carry_states``), from ``resume`` (a
    ``solver.RoundResume`` of the attempt after its first round, or None), then cuts it
    back."""

    def __init__(self, message: str, resume=None):
        super().__init__(message)
        self.resume = resume


class InvertedElementsError(ConvergenceError):
    """A Newton solve converged to a state with inverted elements (det F <= 0 at a point
    checked, ``problem.ContactProblem.min_det_F``; ``solver.NewtonSolver``): a failed
    solve, so the step is cut back. ``det`` is the ``problem.DetF`` found."""

    def __init__(self, message: str, det=None):
        super().__init__(message)
        self.det = det


class OutputError(DolfinxMortarError):
    """A file of the run's output could not be written (an OSError on the rank that
    writes it: a full disk, a quota, the directory gone), raised on every rank."""


#: What a file that is not a regular one is, for :func:`file_problem`'s message.
_FILE_KINDS = (
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def file_problem(path, what: str) -> str | None:
    """Why ``path`` cannot be read as ``what`` (e.g. "a mesh file"), or None where it is
    a regular file (local; it follows links): missing ("file not found: PATH"), a link
    to nothing or one that loops, a directory, or not a regular file (a FIFO, a device
    such as /dev/null, a socket). The reason for a SceneError; the caller names the key."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        if os.path.islink(path):
            return f"{path} is a link to nothing (dangling)"
        return f"file not found: {path}"
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return f"{path} is a link that loops (too many levels of symbolic links)"
        return f"cannot read {path}: {(exc.strerror or type(exc).__name__).lower()}"
    except ValueError:  # a NUL in the name
        return f"cannot read {path!r}: the name holds a NUL character"
    if stat.S_ISDIR(st.st_mode):
        return f"{path} is a directory, not {what}"
    if not stat.S_ISREG(st.st_mode):
        kind = next((k for test, k in _FILE_KINDS if test(st.st_mode)), "not a regular file")
        return f"{path} is not a regular file ({kind}), not {what}"
    return None


def first_on_any_rank(comm, value):
    """The first rank's ``value`` that is not None, in rank order (collective).

    Returns (value, rank, everywhere): ``everywhere`` says whether every rank had one;
    (None, -1, False) where no rank had. For the errors that some ranks only meet (a file
    that rank 0 alone writes or opens), so that every rank takes the same way out instead
    of some waiting alone in a later collective."""
    gathered = comm.allgather(value)
    found = [r for r, v in enumerate(gathered) if v is not None]
    if not found:
        return None, -1, False
    return gathered[found[0]], found[0], len(found) == comm.size


def raise_on_every_rank(comm, error: tuple[str, str] | None) -> None:
    """Raise SceneError(key, reason) on every rank where some rank has ``error`` = (key,
    reason): the first such rank's, naming that rank where others had none (collective)."""
    found, rank, everywhere = first_on_any_rank(comm, error)
    if found is not None:
        key, reason = found
        raise SceneError(key, reason if everywhere else f"{reason} (on rank {rank})")


def every_rank_arrives(comm, seconds: float) -> bool:
    """Whether every rank of ``comm`` enters this call within ``seconds`` (a non-blocking
    barrier, polled; collective where it returns True). A rank that failed alone can
    then stop the others (``comm.Abort``) instead of leaving them in a collective."""
    from time import monotonic, sleep

    request = comm.Ibarrier()
    deadline = monotonic() + seconds
    while not request.Test():
        if monotonic() > deadline:
            return False
        sleep(0.005)
    return True


class Terminated(SystemExit):
    """A run stopped by a signal (SIGTERM: a batch scheduler's time limit, ``docker
    stop``, mpirun passing on Ctrl-C), raised on every rank at the same point
    (:func:`check_stop`). A SystemExit with ``code`` 128 + ``signum`` (143 for SIGTERM),
    so that a program that does not catch it ends quietly with a signal's exit status;
    ``message`` says what was kept (set by :func:`~dolfinx_mortar.runner.run` once
    summary.json says so)."""

    def __init__(self, signum: int, message: str = ""):
        super().__init__(128 + signum)
        self.signum = signum
        self.message = message or f"terminated by {signal.Signals(signum).name}"


#: The signals that stop a run cleanly within :func:`stops_on_signals` (SIGTERM: what a
#: batch scheduler sends at its time limit, ``docker stop`` sends, and Open MPI's mpirun
#: sends each rank when it is itself sent SIGINT or SIGTERM).
STOP_SIGNALS = (signal.SIGTERM,)

# The signal caught within :func:`stops_on_signals` (0: none) and whether a handler is
# in force (the same on every rank: :func:`check_stop` is collective only then).
_stop = {"signum": 0, "active": False}


@contextlib.contextmanager
def stops_on_signals(comm):
    """Within the block, a signal of :data:`STOP_SIGNALS` only records itself; the next
    :func:`check_stop` (each Newton iteration) raises :class:`Terminated` on every rank
    (collective: one allreduce at entry). A handler that raised at once could leave the
    other ranks waiting in a collective, and a step's write half done. Installed only
    where every rank runs the block in its main thread with the signal at its default
    (SIG_DFL: the process would die): a host program's own handler, or SIG_IGN, stays in
    force. The previous handlers are put back at the end."""
    from mpi4py import MPI

    names = [s for s in STOP_SIGNALS if hasattr(signal, s.name)]
    local = threading.current_thread() is threading.main_thread() and all(
        signal.getsignal(s) == signal.SIG_DFL for s in names
    )
    if not comm.allreduce(int(local), op=MPI.MIN) or _stop["active"]:
        yield
        return

    def record(signum, frame):
        _stop["signum"] = signum

    previous = {s: signal.signal(s, record) for s in names}
    _stop.update(signum=0, active=True)
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        _stop.update(signum=0, active=False)


def check_stop(comm) -> None:
    """Raise :class:`Terminated` on every rank where a rank has caught a stop signal
    within :func:`stops_on_signals` (collective there: one allreduce of an int; nothing,
    and no communication, outside it). Called at each Newton iteration (the SNES
    monitor), where every rank of the solve is."""
    if not _stop["active"]:
        return
    from mpi4py import MPI

    signum = comm.allreduce(_stop["signum"], op=MPI.MAX)
    if signum:
        raise Terminated(signum)
