"""Everything a run writes (SCENES.md, "What a run writes"); the library writes nowhere else.

- ``summary.json`` (rank 0), rewritten atomically after every converged step, so
  a run that fails or is killed keeps every finished step and says where it stopped
  (one line per step record, the finished records' lines cached: :class:`SummaryText`);
- ``contact_<SLAVE>_<step>.csv`` (rank 0), one row per slave node, ordered by
  reference coordinates, identical for any number of ranks;
- ``fields.xdmf`` (+ ``.h5``): displacement and the contact fields (pressure,
  gap, state; tangential traction and slip where friction is modelled) as
  nodal functions of the mesh's degree, zero away from slave surfaces;
- ``contact_<SLAVE>.xdmf`` (+ ``.h5``), one per slave surface: the same fields on the
  slave surface as a mesh of its own (its facets, with their second-order geometry on a
  P2 mesh), for plots of the contact zone alone.

<SLAVE> is the slave surface's physical name, with every character other than a letter,
a digit, "_", "." or "-" replaced by "_" (:func:`contact_stem`): a name holding "/" wrote
into a subdirectory, and "../x" outside the output directory.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import logging
import os
import re
import shutil
import signal
import socket
import stat
import tempfile
import threading
import time
from io import StringIO
from pathlib import Path

import numpy as np
from dolfinx import fem, io
from mpi4py import MPI
from scipy.spatial import cKDTree

from . import compat
from .errors import OutputError, SceneError, first_on_any_rank
from .scene import contact_stem

log = logging.getLogger(__name__)

CSV_FIELDS_2D = ["x", "y", "X", "Y", "p_N", "p_T0", "gap", "slip", "state"]
CSV_FIELDS_3D = ["x", "y", "z", "X", "Y", "Z", "p_N", "p_T0", "p_T1", "gap", "slip", "state"]


#: Bytes the reserve of room for the final summary.json holds beyond the last summary.json
#: written and twice what the last step's record added to it (:meth:`OutputLock.reserve`,
#: :meth:`OutputWriter._check_room`): the final keys (``status``, ``error``,
#: ``timings``: about 0.5 kB and the error message) and block rounding.
RESERVE_MARGIN = 16384

#: The bound on the bytes a write adds (:meth:`OutputWriter._check_room`): this many times
#: the larger of the estimate (:meth:`OutputWriter._estimate`) and what the step before
#: added.
ROOM_FACTOR = 2.0

#: Bytes an HDF5 dataset takes beyond its values (its object header, the group entry
#: and index that name it), per dataset, and a text file beyond its text (a page), in
#: :meth:`OutputWriter._estimate`.
DATASET_OVERHEAD = 2048
FILE_OVERHEAD = 4096

#: :class:`SurfaceFields` matches a surface dof to the volume dof within 1e-10 of the
#: surface's size plus this many units of round-off of the largest coordinate
#: (eps·max|x|): the two spaces tabulate their dof coordinates apart, and far from the
#: origin (a CAD mesh in mm placed at 1e6) they differ by more than 1e-10 of a unit surface.
SURFACE_MATCH_ULPS = 64.0


def check_room(comm, out_dir: Path, need: float, what: str = "the next write") -> None:
    """Raise OutputError on every rank where the file system of ``out_dir`` has less room
    than ``need`` bytes, the bound on what the write ``what`` adds (collective: one allreduce
    on ``comm``, every rank's ``shutil.disk_usage``, whose ``free`` is what an unprivileged
    user may write; the smallest free space and the largest need are compared).

    A parallel HDF5 write that runs out of room fails on some ranks only; the others
    wait in the collective for good (a 3-rank run on a full disk hung), so the room is
    checked before it. A quota is not seen (``disk_usage`` reads the file system)."""
    try:
        free = float(shutil.disk_usage(out_dir).free)
    except OSError:  # the directory gone: the write would fail
        free = -1.0
    both = np.array([-free, float(need)])
    comm.Allreduce(MPI.IN_PLACE, both, op=MPI.MAX)
    free, need = -both[0], both[1]
    if free < 0:
        raise OutputError(
            f"the output could not be written to {out_dir}: its free space "
            "cannot be read (the directory is gone?)"
        )
    if free < need:
        raise OutputError(
            f"the output could not be written to {out_dir}: not enough room, "
            f"{free:.0f} bytes free, {need:.0f} needed for {what}"
        )


def _allocated(paths) -> int:
    """The bytes the files ``paths`` take on disk (local; each inode once: a hard link
    counts once; missing files count 0)."""
    seen, total = set(), 0
    for path in paths:
        try:
            st = os.lstat(path)
        except OSError:
            continue
        if (st.st_dev, st.st_ino) not in seen:
            seen.add((st.st_dev, st.st_ino))
            blocks = getattr(st, "st_blocks", None)  # not on Windows
            total += st.st_size if blocks is None else 512 * blocks
    return total


def replace_text(path: Path, text: str | bytes, tmp: Path | None = None) -> None:
    """Write ``text`` (str: as UTF-8; or bytes) to ``path`` atomically, through ``tmp``
    (default ``<path>.tmp``), then :func:`os.replace` (local). Whatever lies at ``tmp`` is
    removed first and the file created exclusively: a symbolic link left there would
    otherwise have the text written into its target, outside the output directory. A
    failed write (OSError) removes ``tmp`` and raises."""
    tmp = path.with_name(path.name + ".tmp") if tmp is None else tmp
    tmp.unlink(missing_ok=True)
    binary = isinstance(text, bytes)
    try:
        with open(tmp, "xb" if binary else "x", encoding=None if binary else "utf-8") as f:
            f.write(text)
    except OSError:  # a full disk: no truncated .tmp is left behind
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)


class SummaryText:
    """The text of summary.json, assembled from cached pieces (local; rank 0 keeps one).

    Layout: the summary's keys one per line, each value as ``json.dumps(indent=1)`` nests
    it, except ``steps``: one line per step record, compact JSON from the C encoder
    (``json.dumps`` without ``indent``). ``json.load`` of the text equals the summary (as
    ``json.dumps(summary, indent=1)`` wrote it before session 50). Rewriting the whole
    file with ``indent=1`` after each step, which runs Python's pure encoder, took 64 ms a
    step at step 1100 of a 1200-step run (summary.json grew 1.76 kB a step: BENCHMARKS.md
    §58).

    A step record's line is kept once a later record follows it in ``steps`` (its
    step's ``progress`` callback has returned: :func:`~dolfinx_mortar.runner.run`
    calls it after the step's write, and a callback that changes its record gets the
    change into the next write, as before) and used while the same record object stays at
    the same place (checked by identity at each write: a list changed in any other way is
    encoded again from the first difference on). The last record and every key but
    ``steps`` (``status``, ``error``, ``timings``: they change until the end) are
    encoded at each write. A record is final once the next one is written: a change made
    to an earlier record after that would not reach the file (nothing in the package
    makes one)."""

    def __init__(self):
        self._records: list = []  # the step records whose lines are kept, in order
        self._lines: list[str] = []

    @staticmethod
    def _line(record) -> str:
        return json.dumps(record, separators=(",", ":"), default=_json_default)

    def _steps(self, records: list) -> str:
        """The value of ``steps``: ``[`` + one line per record + `` ]``."""
        if not records:
            return "[]"
        final = len(records) - 1  # the records that a later one follows
        same = 0
        for kept, record in zip(self._records[:final], records, strict=False):
            if kept is not record:
                break
            same += 1
        del self._records[same:], self._lines[same:]
        for record in records[same:final]:
            self._records.append(record)
            self._lines.append(self._line(record))
        lines = self._lines + [self._line(records[-1])]
        return "[\n  " + ",\n  ".join(lines) + "\n ]"

    def text(self, summary: dict) -> str:
        """summary.json's text of ``summary`` (its ``steps`` a list of records)."""
        items = []
        for key, value in summary.items():
            if key == "steps" and isinstance(value, list):
                items.append(f' "steps": {self._steps(value)}')
            else:  # '{\n "key": value\n}' without the braces: nested as indent=1 nests it
                items.append(json.dumps({key: value}, indent=1, default=_json_default)[2:-2])
        return "{\n" + ",\n".join(items) + "\n}" if items else "{}"


@contextlib.contextmanager
def interrupts_after():
    """Ctrl-C (SIGINT) within the block takes effect when the block ends (local; in the
    main thread only, elsewhere nothing changes; where the block raises, its exception
    goes on and the Ctrl-C is dropped). A step's files and its summary.json record are
    written within one: an interrupt between them left fields.xdmf and the CSVs one step
    ahead of summary.json. (Under mpirun, Open MPI passes Ctrl-C on as SIGTERM, which
    stops a run at its next Newton iteration: :func:`~dolfinx_mortar.errors.stops_on_signals`;
    a write goes on to its end meanwhile.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:  # an exception of the block goes on as it is (a Ctrl-C meanwhile is dropped)
        signal.signal(signal.SIGINT, previous)
    if caught and previous is signal.default_int_handler:
        raise KeyboardInterrupt
    if caught and callable(previous):
        previous(signal.SIGINT, None)
    elif caught and previous == signal.SIG_DFL:
        os.kill(os.getpid(), signal.SIGINT)


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serialisable: {type(obj)}")


def output_names(slaves=()) -> list[str]:
    """The names of the files a run writes into its output directory, for the slave
    surfaces ``slaves`` (their physical names): ``fields.xdmf``/``.h5``, ``summary.json``
    (and the ``.tmp`` it is written through), ``contact_<SLAVE>.xdmf``/``.h5`` (the
    CSV files, one per step, are matched by :func:`check_out_dir`), and the hidden
    series and temporary index of each XDMF file (:class:`XDMFSeries`)."""
    names = ["summary.json", "summary.json.tmp"]
    for stem in ["fields", *(contact_stem(slave) for slave in slaves)]:
        names += [p.name for p in XDMFSeries.paths(Path(f"{stem}.xdmf")).values()]
    return names


def contact_csv_names(slaves) -> re.Pattern:
    """The names of the per-step contact CSV files of the slave surfaces ``slaves``
    (physical names): ``contact_<SLAVE>_<k>.csv``, and the ``.tmp`` each is written
    through (:func:`replace_text`; left behind by a run that was killed during a write).
    Match whole names with ``fullmatch``; no slaves match nothing."""
    stems = [re.escape(contact_stem(s)) for s in slaves]
    return re.compile(rf"(?:{'|'.join(stems)})_\d+\.csv(?:\.tmp)?" if stems else "(?!)")


def previous_slaves(out_dir: Path) -> set[str]:
    """The slave surfaces (physical names) of the run whose summary.json is in
    ``out_dir`` (``modelled.contact_pairs.*.slave``); empty where there is none or it is
    not a summary of this package, or not a regular file (local: a FIFO of that name
    blocked the run in its open)."""
    path = Path(out_dir) / "summary.json"
    try:
        if not path.is_file():
            return set()
        with open(path, encoding="utf-8") as fh:
            pairs = json.load(fh)["modelled"]["contact_pairs"]
        return {str(pair["slave"]) for pair in pairs.values()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError, RecursionError):
        return set()


def check_out_dir(out: Path | str, key: str, comm, slaves=(), files=(), lock: bool = True) -> None:
    """Raise SceneError on every rank if the output directory cannot be used (collective;
    rank 0 decides): an empty name, a path that exists and is not a directory, a dangling
    link, or one that cannot be created. A missing directory is created to find out, and
    removed again with the parents created for it: nothing is left (a clean error instead
    of an OSError from the writer, after the set-up). An existing directory must let a
    file be created in it, and hold no directory (nor a read-only file) where a file of
    the run goes (:func:`output_names` of the slave surfaces ``slaves``, and their
    ``contact_<SLAVE>_<k>.csv``, and the names ``files`` of a caller's own: the bench's
    CSV and plots) or where it removes an earlier run's contact files (those of the
    slaves its summary.json names: :meth:`OutputWriter.start`), and no other run may hold
    its lock (:func:`lock_problem`; :class:`OutputLock` takes the lock later, when the
    run starts to write; ``lock=False`` skips that: ``dolfinx-mortar check`` checks the
    directory as input, not whether a run writes there now)."""
    reason = None
    if comm.rank == 0:
        reason = _out_dir_problem(str(out), tuple(slaves), tuple(files), lock)
    reason = comm.bcast(reason, root=0)
    if reason is not None:
        raise SceneError(key, f"cannot use {str(out)!r} as output directory: {reason}")


def _out_dir_problem(out: str, slaves=(), files=(), lock: bool = True) -> str | None:
    """Why ``out`` cannot be the output directory, or None (local)."""
    if not out.strip():
        return "empty name"
    if "\0" in out:
        return "the name holds a NUL character"
    p = Path(out).absolute()
    if p.is_symlink() and not p.exists():
        return "a link to nothing (dangling or looping)"
    if p.exists():
        if not p.is_dir():
            return "it exists and is not a directory"
        return _existing_dir_problem(p, out, slaves, files, lock)
    top = p  # the outermost directory to create
    while not top.parent.exists() and top.parent != top:
        top = top.parent
    if not top.parent.is_dir():
        return f"{top.parent} is not a directory"
    return _try_to_create(p, top)


def _try_to_create(p: Path, top: Path) -> str | None:
    """Create the directory ``p`` and its missing parents from ``top`` down, then remove
    those that this call created, innermost first, each with ``rmdir`` (local): why one
    could not be created, or None. A directory that another process created meanwhile is
    used and not removed, and one that another process has written into (not empty) or
    removed is left as it is: the check of a concurrent run into a sibling directory of
    the same new parent removed that parent with the other run's files in it
    (``shutil.rmtree``)."""
    chain = [p, *p.parents]
    chain = chain[: chain.index(top) + 1][::-1]  # top, ..., p
    created = []
    try:
        for d in chain:
            try:
                d.mkdir()
            except FileExistsError:  # made by another process meanwhile: not ours
                st = os.stat(d)  # a looping link: OSError (ELOOP), the reason
                if not stat.S_ISDIR(st.st_mode):
                    return f"{d} is not a directory"
                continue
            created.append(d)
    except OSError as exc:
        return (exc.strerror or type(exc).__name__).lower()
    finally:
        for d in reversed(created):
            try:
                d.rmdir()
            except OSError:  # not empty (another run writes there) or gone: left
                break
    return None


def _existing_dir_problem(p: Path, out: str, slaves=(), files=(), lock=True) -> str | None:
    """Why the existing directory ``p`` (named ``out``) cannot take the run's files, or
    None (local): a file cannot be created in it (tried: ``os.access`` says yes to root
    on a read-only file system or in /proc), another run holds it (:func:`lock_problem`),
    (unless ``lock`` is False), or a directory or a read-only file is where one of the
    run's files goes."""
    try:
        with tempfile.TemporaryFile(dir=p):
            pass
    except OSError:
        return "not writable (a file cannot be created in it)"
    held = lock_problem(p) if lock else None
    if held is not None:
        return held
    slaves = tuple(slaves) + tuple(sorted(previous_slaves(p) - set(slaves)))
    csv = contact_csv_names(slaves)
    names = output_names(slaves) + list(files)
    names += sorted(f.name for f in p.iterdir() if csv.fullmatch(f.name))
    for name in names:
        f = p / name
        shown = os.path.join(out, name)
        if f.is_dir():
            return f"{shown!r} is a directory (the run writes a file there)"
        if f.exists() and not os.access(f, os.W_OK):
            return f"{shown!r} is not writable"
    return None


#: The lock file of the run that writes in an output directory (:class:`OutputLock`).
LOCK_NAME = ".dolfinx_mortar.lock"
#: The errors with which a file system refuses flock (some Lustre mounts): the run goes on
#: without the lock, with a warning.
NO_FLOCK = (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS, errno.EINVAL)


def _holder(fd: int) -> str:
    """Who holds the lock file open as ``fd``, from its record (host, pid, since; for the
    refusal message only)."""
    try:
        record = json.loads(os.pread(fd, 4096, 0).split(b"\0", 1)[0])  # the reserve: NULs
        return f"host {record['host']}, pid {record['pid']}, since {record['since']}"
    except (OSError, ValueError, TypeError, KeyError):
        return "a run that has not yet written its host and pid"


def _held(who: str) -> str:
    """The refusal message where another open file description holds the lock file."""
    return (
        f"another run is writing there ({who}; lock file {LOCK_NAME}): "
        "give each run that runs at the same time an output directory of its own"
    )


def lock_problem(out_dir: Path) -> str | None:
    """Why another run holds the output directory ``out_dir``, or None (local): its lock
    file is locked (``flock``, tried and released at once). No lock file, one that no
    process holds (left by a killed run) or a file system without flock: no problem."""
    path = os.path.join(str(out_dir), LOCK_NAME)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except FileNotFoundError:
        return None
    except OSError as exc:  # a link (ELOOP), unreadable
        return f"{path!r} cannot be opened as a lock file: {exc.strerror or exc} (remove it)"
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return f"{path!r} is not a regular file (remove it)"
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return _held(_holder(fd))
        except OSError as exc:
            if exc.errno in NO_FLOCK:
                return None
            raise
        return None  # closing fd releases it
    finally:
        os.close(fd)


class OutputLock:
    """The lock of a run on its output directory (construction collective; rank 0 holds
    it): an advisory ``flock`` on ``<out_dir>/.dolfinx_mortar.lock``, which the kernel
    releases when the process ends, however it ends (no stale locks). Rank 0 tries it and
    broadcasts the outcome; where another open file description holds it (another run,
    also of this process; on Linux NFS between hosts too), every rank raises
    SceneError(``key``, "cannot use ... as output directory: another run is writing
    there (host H, pid P, since T; ...)"). Two runs in one directory deleted each other's
    contact files and failed in HDF5's file lock, and the first one ended "ok".

    Rank 0 opens the file (created where missing: a leftover of a killed run is simply
    taken), locks it (LOCK_EX | LOCK_NB), checks that the path still names the file it
    locked (a run that released it meanwhile unlinked it: opened again), then writes host,
    pid and time into it for the refusal message. :meth:`release` (rank 0; local) unlinks
    the file, then closes it; call it in a ``finally``. Where the file system refuses
    flock (ENOLCK, EOPNOTSUPP, ENOSYS, EINVAL: some Lustre mounts), one warning, and the
    run goes on without the lock. Creates the directory (and its parents) where missing.

    The lock file also holds the run's reserve of room for its final summary.json
    (:meth:`reserve`, :meth:`free_reserve`): blocks allocated after the record
    (``posix_fallocate``; they read as NUL bytes), which :meth:`OutputWriter.finish`
    frees right before it writes the final status. A run stopped by a full disk left
    summary.json at "running": the final rewrite needs room for a whole copy. Without the
    lock (a file system without flock) there is no reserve."""

    def __init__(self, comm, out_dir: Path, key: str):
        self.out_dir = Path(out_dir)
        self.path = self.out_dir / LOCK_NAME
        self._fd = None
        #: the record's length: the reserve lies beyond it (rank 0)
        self._record = 0
        #: the bytes reserved (rank 0; 0 elsewhere and without the lock)
        self.reserved = 0
        #: whether the file system refused the reserve's allocation (not for lack of room)
        self._no_reserve = False
        reason = None
        if comm.rank == 0:
            try:
                reason = self._take()
            except OSError as exc:
                reason = f"the lock file {LOCK_NAME} cannot be created: {exc}"
        reason = comm.bcast(reason, root=0)
        if reason is not None:
            raise SceneError(key, f"cannot use {str(out_dir)!r} as output directory: {reason}")

    def _take(self) -> str | None:
        """Lock the lock file (rank 0; local); why not, or None."""
        self.out_dir.mkdir(parents=True, exist_ok=True)
        for _ in range(10):  # the file unlinked by its holder between open and lock: again
            created = True
            flags = os.O_RDWR | os.O_NOFOLLOW | os.O_CLOEXEC
            try:
                fd = os.open(self.path, flags | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                created = False
                try:
                    fd = os.open(self.path, flags)
                except FileNotFoundError:
                    continue
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                st = os.fstat(fd)
                try:
                    now = os.stat(self.path)
                except FileNotFoundError:
                    now = None
                if now is None or (now.st_dev, now.st_ino) != (st.st_dev, st.st_ino):
                    os.close(fd)
                    continue
                record = {
                    "host": socket.gethostname(),
                    "pid": os.getpid(),
                    "since": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
                }
                data = json.dumps(record).encode()
                # written, then cut to its length (a leftover record may be longer): a
                # truncation to 0 before the write made ext4 flush it (auto_da_alloc), 1 ms
                # (a leftover's reserve, a killed run's, is freed too)
                os.pwrite(fd, data, 0)
                os.ftruncate(fd, len(data))
                self._record = len(data)
            except BlockingIOError:
                who = _holder(fd)
                os.close(fd)
                return _held(who)
            except OSError as exc:
                os.close(fd)
                if created:  # a record that a full disk refused left the file behind
                    self.path.unlink(missing_ok=True)
                if exc.errno not in NO_FLOCK:
                    raise
                log.warning(
                    "%s: the file system refuses flock (%s): the run goes on without the "
                    "lock of its output directory",
                    self.out_dir,
                    exc.strerror or exc,
                )
                return None
            except BaseException:
                os.close(fd)
                raise
            self._fd = fd
            return None
        return f"its lock file {LOCK_NAME} keeps changing (other runs start there)"

    @property
    def reserving(self) -> bool:
        """Whether this rank holds the lock, and with it the reserve (local; not where
        the file system refused to allocate it)."""
        return self._fd is not None and not self._no_reserve

    def reserve(self, nbytes: int) -> None:
        """Grow the reserve to ``nbytes`` (local; rank 0 with the lock: elsewhere nothing;
        never shrunk): ``posix_fallocate`` of the bytes after the record. OSError
        (ENOSPC, EDQUOT) where there is no room for them; any other OSError (a file
        system that cannot allocate so) is logged once, and the run goes on without
        the reserve."""
        if not self.reserving or nbytes <= self.reserved:
            return
        try:
            os.posix_fallocate(self._fd, self._record, nbytes)
        except OSError as exc:
            if exc.errno in (errno.ENOSPC, errno.EDQUOT):
                raise
            # a file system that allocates no blocks this way (EOPNOTSUPP, EINVAL, ...):
            # the run goes on without the reserve, as without the lock
            log.warning("%s: no reserve of room for the final summary.json: %s", self.path, exc)
            self._no_reserve = True
            return
        self.reserved = nbytes

    def free_reserve(self) -> None:
        """Free the reserve (local; the lock file cut to its record). OSError is logged."""
        if self._fd is None or not self.reserved:
            return
        try:
            os.ftruncate(self._fd, self._record)
            self.reserved = 0
        except OSError as exc:
            log.warning("could not free the reserve in %s: %s", self.path, exc)

    def release(self) -> None:
        """Unlink the lock file, then close it, which releases the lock, where this rank
        holds it (local; nothing on the other ranks). An OSError is logged."""
        if self._fd is None:
            return
        fd, self._fd = self._fd, None
        try:
            self.path.unlink()
        except OSError as exc:
            log.warning("could not remove the lock file %s: %s", self.path, exc)
        finally:
            os.close(fd)


def _on_rank_0(comm, action):
    """``action()`` on rank 0 (a file operation of its own), then one bcast (collective):
    where it raised OSError, RuntimeError with its message on every rank, as dolfinx
    raises where a collective HDF5 write fails (:meth:`OutputWriter._collective_io` makes
    it an OutputError). Returns what ``action`` returned on rank 0, None elsewhere."""
    result, reason = None, None
    if comm.rank == 0:
        try:
            result = action()
        except OSError as exc:
            reason = str(exc)
    reason = comm.bcast(reason, root=0)
    if reason is not None:
        raise RuntimeError(reason)
    return result


def write_contact_csv(path: Path, table: np.ndarray, gdim: int) -> None:
    """Write the slave-node table (rows = nodes, columns = CSV_FIELDS_{2D,3D}) sorted by
    reference coordinates, atomically (:func:`replace_text`: a full disk leaves no
    truncated file)."""
    header = CSV_FIELDS_2D if gdim == 2 else CSV_FIELDS_3D
    if table.size:
        order = np.lexsort(tuple(np.round(table[:, k], 12) for k in reversed(range(gdim))))
        table = table[order]
    fmt = ["%.17g"] * (len(header) - 1) + ["%d"]
    text = StringIO()
    np.savetxt(
        text,
        table.reshape(-1, len(header)) + 0.0,  # + 0.0: no "-0" (a −0.0 prints so)
        delimiter=",",
        header=",".join(header),
        comments="",
        fmt=fmt,
    )
    replace_text(Path(path), text.getvalue())


class XDMFIndex:
    """An XDMF index as dolfinx 0.5.2 writes it, assembled from the steps' pieces (local;
    rank 0 of an :class:`XDMFSeries` keeps one).

    ``skeleton``: the index of the mesh alone (dolfinx's, after ``write_mesh``). Each
    :meth:`add` takes dolfinx's index of one step (the skeleton, then one temporal
    collection per function written, each with that step's grids) and keeps the grids
    under their collections, their data references renamed (``rename``: how a reference
    to the hidden h5 file begins, and how one to the public file does, as bytes; the
    mesh's too); :meth:`text` is the index of every step added, byte for byte
    what dolfinx writes when it appends the steps to one file (pugixml's layout: two
    spaces per level; without the DOCTYPE line, which its append mode drops once a
    ``write_function`` saved the index: with no collection yet, the skeleton as it
    came, DOCTYPE included: a run without fields, or whose first write failed). It holds
    the index in memory: as large as ``<name>.xdmf`` (2.7 kB a step with six fields on a
    2D mesh), which is written whole after each step anyway."""

    _DOCTYPE = b'<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>\n'
    _TAIL = b"  </Domain>\n</Xdmf>\n"
    _COLLECTION = re.compile(
        rb'    <Grid Name="([^"\n]*)" GridType="Collection" CollectionType="Temporal">\n'
        rb"((?:      .*\n)*)    </Grid>\n"
    )

    def __init__(self, skeleton: bytes, rename: tuple[bytes, bytes]):
        #: the index published while no step has a collection (dolfinx's, untouched)
        self._published_skeleton = skeleton.replace(*rename)
        skeleton = skeleton.replace(self._DOCTYPE, b"", 1)
        #: whether ``skeleton`` ends as dolfinx 0.5.2 ends an index (otherwise nothing is
        #: ever added)
        self.usable = skeleton.endswith(self._TAIL)
        self._head = skeleton[: -len(self._TAIL)]  # as dolfinx writes it, and as published
        self._published_head = self._head.replace(*rename)
        self._rename = rename
        #: the collections' names and their steps' grids, in the order dolfinx wrote them
        self.grids: dict[bytes, list[bytes]] = {}

    def add(self, step: bytes) -> bool:
        """Keep the grids of dolfinx's index ``step`` (one step's); False, and nothing
        kept, where it is not the skeleton followed by temporal collections laid out as
        dolfinx 0.5.2 lays them out (checked: they rebuild ``step`` exactly)."""
        step = step.replace(self._DOCTYPE, b"", 1)
        if not (self.usable and step.startswith(self._head) and step.endswith(self._TAIL)):
            return False
        body = step[len(self._head) : -len(self._TAIL)]
        found, end = [], 0
        for match in self._COLLECTION.finditer(body):
            if match.start() != end:
                return False
            found.append((match.group(1), match.group(2)))
            end = match.end()
        if end != len(body):
            return False
        for name, grids in found:
            self.grids.setdefault(name, []).append(grids.replace(*self._rename))
        return True

    def text(self) -> bytes:
        """The index of the mesh and every step added."""
        if not self.grids:  # no write_function yet: dolfinx never saved the index
            return self._published_skeleton
        parts = [self._published_head]
        for name, grids in self.grids.items():
            parts.append(
                b'    <Grid Name="' + name + b'" GridType="Collection" CollectionType="Temporal">\n'
            )
            parts += grids
            parts.append(b"    </Grid>\n")
        parts.append(self._TAIL)
        return b"".join(parts)


class XDMFSeries:
    """An XDMF time series whose index file is replaced atomically after each step
    (collective construction and calls).

    dolfinx 0.5.2's XDMFFile rewrites its whole XML index in place when it closes
    (truncate, then write): a run killed at that moment left ``<name>.xdmf`` empty, and
    with it the index of every finished step (their HDF5 data were still there). Here
    dolfinx writes the series as ``.<name>.xdmf`` + ``.<name>.h5`` (hidden), ``<name>.h5``
    is a hard link to the same data, and after each close rank 0 writes the index to
    ``<name>.xdmf`` through a temporary file and :func:`os.replace`, its data references
    renamed: ``<name>.xdmf`` always holds a whole index of the steps written so far.
    :meth:`finish` removes the hidden names. Where the file system has no hard links,
    the series is written under the public names directly, as before.

    dolfinx also loads the whole index when it opens the file, and saves it after each
    ``write_function`` (6 a step with all the fields), so that a step's write grew with
    the steps before it (BENCHMARKS.md §58). With the hidden names, rank 0 therefore puts
    dolfinx's index back to the mesh alone before each step (:meth:`open`), so that
    dolfinx loads and saves one step's index, and assembles ``<name>.xdmf`` itself
    (:class:`XDMFIndex`: byte for byte the index dolfinx would have written). Where the
    first step's index is not laid out as expected (another dolfinx), the series goes on
    as before, dolfinx's index whole (logged).

    ``path``: the public ``<name>.xdmf``; ``mesh``: written once, at construction.
    """

    @staticmethod
    def paths(path: Path) -> dict[str, Path]:
        """The files of the series ``path`` (``<name>.xdmf``): "xdmf", "h5" (public),
        "live", "live_h5" (hidden, dolfinx's) and "tmp" (the index on its way to
        ``<name>.xdmf``). The one definition of these names (:func:`output_names`)."""
        live = path.with_name("." + path.name)
        return {
            "xdmf": path,
            "h5": path.with_suffix(".h5"),
            "live": live,
            "live_h5": live.with_suffix(".h5"),
            "tmp": path.with_name(path.name + ".tmp"),
        }

    def __init__(self, comm, path: Path, mesh):
        self.comm, self.path = comm, Path(path)
        names = self.paths(self.path)
        self.h5, self.live, self._tmp = names["h5"], names["live"], names["tmp"]
        self._live_h5 = live_h5 = names["live_h5"]
        # rank 0's own file operations below raise RuntimeError on every rank where they
        # fail (_on_rank_0), as dolfinx's collective writes do: an OSError on rank 0 alone
        # left the other ranks waiting in the next collective (a 2-rank run hung)
        # "w" below then creates a new file, not one a stale link shares
        _on_rank_0(comm, lambda: live_h5.unlink(missing_ok=True))
        with io.XDMFFile(comm, str(self.live), "w") as file:
            file.write_mesh(mesh)
        linked = True
        if comm.rank == 0:
            try:
                self.h5.unlink(missing_ok=True)
                os.link(live_h5, self.h5)
            except OSError as exc:
                log.info("%s written in place (no hard link: %s)", self.path.name, exc)
                linked = False
        if not comm.bcast(linked, root=0):
            _on_rank_0(
                comm, lambda: (self.live.unlink(missing_ok=True), live_h5.unlink(missing_ok=True))
            )
            self.live = self.path
            with io.XDMFFile(comm, str(self.live), "w") as file:
                file.write_mesh(mesh)
        #: rank 0, with the hidden names: the mesh's index, which :meth:`open` puts back,
        #: and the published index's pieces (None: dolfinx keeps the whole index)
        self._skeleton: bytes | None = None
        self._index: XDMFIndex | None = None
        if self.live != self.path:
            self._skeleton = _on_rank_0(comm, self.live.read_bytes)
        if self._skeleton is not None:  # rank 0
            self._index = XDMFIndex(self._skeleton, self._references())
        #: whether :meth:`open` calls on rank 0 to reset dolfinx's index (the same on every
        #: rank; rank 0 stops resetting where its :class:`XDMFIndex` cannot read the index)
        self._resets = comm.bcast(self._index is not None, root=0)
        _on_rank_0(comm, self._publish)
        #: the file, open in append mode between :meth:`open` and :meth:`close`
        self.file = None

    def open(self):
        """Open the series for the writes of one step; returns the XDMFFile (collective).
        First, where it resets dolfinx's index, rank 0 writes the mesh's index over it
        (in place: the hidden file; a kill then leaves ``<name>.xdmf`` whole); where
        that fails (OSError), RuntimeError on every rank and nothing is opened."""
        if self._resets:
            reason = None
            if self._index is not None:  # rank 0, the index read as expected so far
                try:
                    self.live.write_bytes(self._skeleton)
                except OSError as exc:
                    reason = f"{self.live}: {exc.strerror or exc}"
            reason = self.comm.bcast(reason, root=0)  # the others read it when they open
            if reason is not None:
                raise RuntimeError(reason)
        self.file = io.XDMFFile(self.comm, str(self.live), "a")
        return self.file

    def close(self) -> None:
        """Close the file (its data are on disk) and publish the index (collective)."""
        if self.file is not None:
            self.file.close()
            self.file = None
            self._publish()

    def _publish(self) -> None:
        """Rank 0: ``<name>.xdmf`` := the index of every step written, referencing
        ``<name>.h5``: assembled (:class:`XDMFIndex`) where dolfinx's holds one step, or
        dolfinx's renamed (as bytes: reading it as text decoded and copied it)."""
        if self.comm.rank != 0 or self.live == self.path:
            return
        live = self.live.read_bytes()
        if self._index is not None and not self._index.add(live):
            if self._index.grids:  # the steps before are in no index dolfinx has
                raise OSError(
                    errno.EPROTO, f"{self.live.name}: an XDMF index laid out unexpectedly"
                )
            # dolfinx's index holds every step (none before this one): it keeps them
            log.warning(
                "%s: dolfinx's XDMF index is not laid out as this package expects: "
                "the whole index stays in dolfinx's file (slower over many steps)",
                self.path.name,
            )
            self._index = None
        if self._index is not None:
            data = self._index.text()
        else:
            hidden, public = self._references()
            data = live.replace(hidden, public)
        replace_text(self.path, data, self._tmp)

    def _references(self) -> tuple[bytes, bytes]:
        """How the live index and ``<name>.xdmf`` begin a data reference (bytes)."""
        return tuple(b">" + os.fsencode(p.name) + b":" for p in (self._live_h5, self.h5))

    def finish(self) -> None:
        """Close, and remove the hidden names (the data stay under ``<name>.h5``)."""
        self.close()
        if self.comm.rank == 0 and self.live != self.path:
            self.live.unlink(missing_ok=True)
            self._live_h5.unlink(missing_ok=True)
        self.live = self.path  # nothing more is written
        self._resets, self._index = False, None  # nor reset: it would be the public index


class SurfaceFields:
    """The nodal fields of a volume mesh restricted to one of its facet groups, written as
    ``contact_<name>.xdmf`` on that surface's own mesh (collective construction and
    writes).

    ``Q``: the scalar Lagrange space of the volume fields (its dofs, in blocks, are those
    of the displacement space: the same element, the same layout); ``facets``: local
    indices of the group's facets. The surface mesh (:func:`~dolfinx_mortar.compat.facet_submesh`)
    holds each rank's owned facets, without ghost cells, and each of its vertices is owned
    by a rank whose cells hold it: every surface dof of a rank (owned and ghost) lies in
    one of its cells, where its coordinates are right, and dolfinx 0.5.2's XDMF writer,
    which takes a node's values from the rank's cells, writes every owned node's value.
    (Before session 51 the submesh kept the volume mesh's vertex owners, which on a 3-rank
    tetrahedral patch held none of the surface cells around a node: the file read 0 there.)
    Each surface dof is matched, on its rank, to the volume dof at the same coordinates
    among the dofs of that rank's owned facets (a k-d tree, within 1e-10 of the surface's
    size plus SURFACE_MATCH_ULPS of the coordinates' round-off; not among all dofs: a
    touching body can have a node at the same place). On a second-order mesh the surface
    has the facets' second-order geometry and its spaces the volume's degree (2): every
    facet node, midside and face-centre ones too, is a dof matched so; dolfinx writes a
    function of the geometry's degree as values at every geometry node. ``parent``
    (n_owned_surface_dofs,) holds the local volume dof of each owned surface dof; the
    surface's ghost values then come from their owners."""

    def __init__(self, path: Path, Q, facets: np.ndarray):
        mesh, comm = Q.mesh, Q.mesh.comm
        self.surface = compat.facet_submesh(mesh, facets)
        degree = Q.ufl_element().degree()
        self.Q = fem.FunctionSpace(self.surface, ("CG", degree))
        self.V = compat.vector_space(self.surface, degree)
        imap = self.Q.dofmap.index_map
        owned = imap.size_local
        local = owned + imap.num_ghosts
        # the surface dofs of this rank's cells: every local one (facet_submesh)
        held = np.unique(self.Q.dofmap.list.array)
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        facets = np.asarray(facets, dtype=np.int32)
        mine = facets[facets < mesh.topology.index_map(tdim - 1).size_local]
        candidates = fem.locate_dofs_topological(Q, tdim - 1, mine)
        lost = local - held.size  # a dof in no cell of its rank: none expected
        if held.size and candidates.size:
            x_vol = Q.tabulate_dof_coordinates()[candidates]
            dist, nearest = cKDTree(x_vol).query(self.Q.tabulate_dof_coordinates()[held])
            # 1e-10 of the surface's size, and the coordinates' round-off (the two spaces
            # tabulate them apart: 1e-10 at 1e6 from the origin, where 1e-10 of a unit
            # surface missed every dof)
            tol = 1e-10 * max(float(np.ptp(x_vol, axis=0).max()), 1e-300)
            tol += SURFACE_MATCH_ULPS * np.finfo(float).eps * float(np.abs(x_vol).max())
            lost += int(np.sum(dist > tol))
        else:
            lost += held.size
        lost = comm.allreduce(lost)
        if lost:  # on every rank, so that none waits in a collective
            raise RuntimeError(f"{path.name}: {lost} surface dof(s) without a volume dof")
        parent = np.full(local, -1, dtype=np.int64)
        if held.size:
            parent[held] = np.asarray(candidates, dtype=np.int64)[nearest]
        self.parent = parent[:owned]
        self.path = path
        self.series = XDMFSeries(comm, path, self.surface)
        self._functions: dict[str, fem.Function] = {}

    def begin_step(self) -> None:
        """Open the file for the writes of one step (collective)."""
        self.series.open()

    def end_step(self) -> None:
        """Close the file: the step's data are on disk, the index published (collective)."""
        self.series.close()

    def write(self, f: fem.Function, t: float) -> None:
        """Write the volume function ``f`` (scalar on Q, or vector on the displacement
        space) restricted to the surface, at time t, between :meth:`begin_step` and
        :meth:`end_step` (collective)."""
        name = f.name
        g = self._functions.get(name)
        if g is None:
            space = self.V if f.function_space.dofmap.index_map_bs > 1 else self.Q
            g = self._functions[name] = fem.Function(space, name=name)
        bs = g.function_space.dofmap.index_map_bs
        g.x.array.reshape(-1, bs)[: self.parent.size] = f.x.array.reshape(-1, bs)[self.parent]
        g.x.scatter_forward()
        self.series.file.write_function(g, t)

    def close(self) -> None:
        self.series.finish()


class OutputWriter:
    """Writes a run's files into ``out_dir`` (collective: every rank calls every method).

    Parameters
    ----------
    out_dir: output directory (created on the first write, never before).
    problem: the ContactProblem (its ``u``, ``V`` and contact terms are read).
    summary: the run-level part of summary.json (scene, source, modelled, ranks, dofs,
        versions).
    fields: the output field names requested by the scene.
    """

    def __init__(self, out_dir: Path, problem, summary: dict, fields=()):
        self.out_dir = Path(out_dir)
        self.problem = problem
        self.comm = problem.comm
        self.summary = dict(summary)
        self.summary.setdefault("steps", [])
        self.summary["status"] = "running"
        self.summary["error"] = None
        self.fields = tuple(fields)
        self._xdmf = None  # the XDMFSeries of fields.xdmf
        #: this rank's first failed write of a file (an OSError), until write_step
        #: raises it as an OutputError on every rank
        self._write_error: OSError | None = None
        self._contact_functions = {}
        self._surfaces: list[SurfaceFields] = []
        #: the bytes the last step's write added to the run's files (rank 0; 0 on the
        #: other ranks and before the first step: :meth:`_check_room`), and the CSVs
        #: it wrote
        self._growth = 0
        self._csv_written: list[Path] = []
        self._summary_text = SummaryText()
        #: the run's OutputLock (:func:`~dolfinx_mortar.runner.run` sets it), whose file
        #: holds the reserve of room for the final summary.json; None: no reserve
        self.lock = None
        #: the bytes of the last summary.json written and what that write added (rank 0)
        self._summary_bytes = 0
        self._summary_added = 0
        #: the seconds spent in this writer so far (local): :meth:`start`, every
        #: :meth:`write_step` and :meth:`finish` (run-level ``timings.output``)
        self.elapsed = 0.0

    def start(self) -> None:
        """Create the directory, remove the contact files an earlier run left there, and
        write the initial state (step 0).

        Removed: the contact CSV files of this run's slave surfaces (a shorter run would
        otherwise leave stale later steps) and their ``.tmp`` (:func:`contact_csv_names`),
        and every contact file (CSV and XDMF) of the slave surfaces that the directory's
        summary.json names and this run does not have (another scene run into the same
        directory), so that the directory holds one run's output only. Nothing else is
        touched.

        Raises OutputError on every rank where something of this fails (a full disk, an
        OSError of rank 0's: every rank is told; SurfaceFields' RuntimeError): the caller
        then ends the run with :meth:`fail_start`, which writes summary.json."""
        t0 = time.perf_counter()
        p = self.problem
        try:
            with self._collective_io():
                _on_rank_0(self.comm, self._remove_earlier_files)
            if self.comm.rank == 0 and self.lock is not None:
                # the reserve's first part (RESERVE_MARGIN) before the first room check, so
                # that a run stopped by it can still say so in summary.json (fail_start)
                with contextlib.suppress(OSError):  # no room for it: the check fails too
                    self.lock.reserve(self._reserve_bytes())
            self._check_room("the meshes and step 0", mesh=True)  # before the first HDF5 write
            with self._collective_io():
                self._xdmf = XDMFSeries(self.comm, self.out_dir / "fields.xdmf", p.mesh)
                if p.contacts:
                    Q = fem.FunctionSpace(p.mesh, ("CG", p.degree))
                    for key, name in self._contact_names().items():
                        self._contact_functions[key] = fem.Function(Q, name=name)
                    self._start_surfaces(Q)
        finally:
            self.elapsed += time.perf_counter() - t0
        self.write_step(0, 0.0, None)

    def _remove_earlier_files(self) -> None:
        """Create the directory and remove an earlier run's contact files (rank 0; local:
        :meth:`start`). An OSError of the directory is raised, one of a file logged."""
        self.out_dir.mkdir(parents=True, exist_ok=True)
        current = {term.slave_name for term in self.problem.contacts}
        earlier = previous_slaves(self.out_dir) - current
        csv = contact_csv_names(sorted(current | earlier))
        stale = {f.name for f in self.out_dir.iterdir() if csv.fullmatch(f.name)}
        stale.update(set(output_names(earlier)) - set(output_names()))
        for name in sorted(stale):
            f = self.out_dir / name
            if f.is_file() or f.is_symlink():
                try:
                    f.unlink()
                except OSError as exc:  # checked before (check_out_dir); rank 0 only
                    log.warning("could not remove the earlier run's %s: %s", f, exc)

    def fail_start(self, error: str, timings: dict | None = None) -> str:
        """End a run whose :meth:`start` raised OutputError (on every rank; collective):
        the series' files are closed and removed with the step-0 contact CSVs (rank 0:
        :meth:`_remove_run_files`; an earlier run's of the same names too, as the run would
        have replaced them), and summary.json says ``"status": "failed"``, ``error``, no
        steps and the run-level ``timings`` (with ``"output"``), the reserve of room for
        it freed first: the directory holds the run's summary.json and nothing else of it
        (before, a failure there left no summary.json, or one at "running", and the
        hidden series). Returns the one line for the caller (the same on every rank):
        ``error``, and where summary.json could not be written either (a full disk, the
        directory gone), why."""
        t0 = time.perf_counter()
        with contextlib.suppress(OutputError):  # a file left open by the failed write
            with self._collective_io():
                self._close_files()
        self._surfaces, self._xdmf = [], None
        if self.comm.rank == 0:
            self._remove_run_files()
        self.elapsed += time.perf_counter() - t0
        self.summary["status"] = "failed"
        self.summary["error"] = error
        if timings is not None:
            self.summary["timings"] = dict(timings, output=self.elapsed)
        reason = None
        if self.comm.rank == 0:
            self._free_reserve()
            try:
                self._write_summary()
            except OSError as exc:  # the caller's one line says so
                reason = str(exc)
        reason = self.comm.bcast(reason, root=0)
        if reason is None:
            return error
        return f"{error}; summary.json could not be written either: {reason}"

    def _remove_run_files(self) -> None:
        """Remove the run's XDMF series (public, hidden and temporary names), its contact
        CSVs and summary.json.tmp (rank 0; local; an OSError is logged): after a failed
        :meth:`start`, no step of them is whole."""
        slaves = [term.slave_name for term in self.problem.contacts]
        csv = contact_csv_names(slaves)
        names = set(output_names(slaves)) - {"summary.json"}
        try:
            names.update(f.name for f in self.out_dir.iterdir() if csv.fullmatch(f.name))
        except OSError as exc:  # the directory gone
            log.warning("could not list %s: %s", self.out_dir, exc)
            return
        for name in sorted(names):
            f = self.out_dir / name
            if f.is_file() or f.is_symlink():
                try:
                    f.unlink()
                except OSError as exc:
                    log.warning("could not remove %s of the failed start: %s", f, exc)

    def _contact_names(self) -> dict[str, str]:
        """The contact fields written ({output.fields key: function name}; local)."""
        p = self.problem
        if not p.contacts:
            return {}
        names = {
            "contact_pressure": "contact_pressure",
            "gap": "gap",
            "contact_state": "contact_state",
        }
        if any(getattr(c, "frictional", False) for c in p.contacts):
            names.update({"tangential_traction": "tangential_traction_norm", "slip": "slip"})
        # slip goes with the tangential traction (it was written whatever the scene's
        # fields, and output.fields cannot name it)
        wanted = set(self.fields) | ({"slip"} if "tangential_traction" in self.fields else set())
        return {key: name for key, name in names.items() if key in wanted}

    @contextlib.contextmanager
    def _collective_io(self):
        """The XDMF/HDF5 writes (collective): dolfinx raises RuntimeError where HDF5
        fails (a full disk: "Failed to write HDF5 local dataset into hyperslab"), on every
        rank of the collective write; it becomes OutputError, which stops the run with
        one line (it was a traceback per rank)."""
        try:
            yield
        except RuntimeError as exc:
            reason = " ".join(str(exc).split())
            raise OutputError(
                f"the output could not be written to {self.out_dir}: {reason}"
            ) from None

    def _start_surfaces(self, Q) -> None:
        """One :class:`SurfaceFields` per slave surface (collective), affine or curved
        (a P2 mesh's facets keep their second-order geometry: compat.facet_submesh)."""
        p = self.problem
        md = p.mesh_data
        for name in (term.slave_name for term in p.contacts):  # one pair per slave (scene)
            facets = compat.tagged_entities(md.facet_tags, md.facet_groups[name])
            path = self.out_dir / f"{contact_stem(name)}.xdmf"
            self._surfaces.append(SurfaceFields(path, Q, facets))

    def write_step(self, step: int, t: float, record: dict | None) -> None:
        """Write the state of converged step ``step`` at time t; ``record`` joins summary.json.

        The XDMF files are opened in append mode for the step and closed after it, so
        that the HDF5 data of every finished step is on disk: dolfinx 0.5.2's XDMFFile has
        no flush, and a file left open had an empty superblock until it was closed (a run
        killed by a batch job's time limit lost all its fields). Their indices are then
        replaced atomically (:class:`XDMFSeries`). A Ctrl-C meanwhile waits until the
        step's record is in summary.json (:func:`interrupts_after`).

        Before the files are opened, the room on the file system is checked
        (:meth:`_check_room`; collective): where it is short, OutputError on every rank
        and nothing of the step is written.

        ``record["timings"]["output"]`` gets the seconds of the step's write before the
        record joins summary.json (this rank's: the room check, the fields, the CSVs,
        the published indices; not the rewrite of summary.json that carries it), and
        :attr:`elapsed` the whole call's."""
        t0 = time.perf_counter()
        try:
            self._write_step(step, t, record, t0)
        finally:
            self.elapsed += time.perf_counter() - t0

    def _write_step(self, step: int, t: float, record: dict | None, t0: float) -> None:
        """:meth:`write_step`, which started at ``t0`` (``time.perf_counter``)."""
        self._check_room(f"step {step}")
        self._csv_written = []  # the step's CSVs are new files: none before
        before = self._allocated() if self.comm.rank == 0 else 0
        joined = False  # whether the step joined the summary (its CSVs then stay)
        try:
            with interrupts_after():
                with self._collective_io():
                    self._xdmf.open()
                    for surface in self._surfaces:
                        surface.begin_step()
                    try:
                        self._write_fields(step, t)
                    finally:
                        self._close_files()
                # the step joins summary.json where every rank wrote its files (collective)
                joined = self._first_write_error() is None
                if record is not None and joined:
                    record.setdefault("timings", {})["output"] = time.perf_counter() - t0
                    self.summary["steps"].append(record)
                self._flush()
        finally:
            if not joined:
                self._remove_csvs()
        if self.comm.rank == 0:
            self._growth = max(self._allocated() - before, 0)
        self._raise_write_error()

    def _remove_csvs(self) -> None:
        """Remove the contact CSVs of a step whose write failed (rank 0; local): its
        record is in no summary, and a failed write left them behind while summary.json
        and the indices stopped at the step before. They are new files of this run (an
        earlier run's were removed at the start); an OSError is logged."""
        for path in self._csv_written:
            try:
                path.unlink(missing_ok=True)
            except OSError as exc:
                log.warning("could not remove %s of the unfinished step: %s", path, exc)
        self._csv_written = []

    def _run_files(self) -> list[Path]:
        """The files whose size the step's writes change (rank 0): summary.json, each
        XDMF series (index, data, published index) and the last step's contact CSVs."""
        files = [self.out_dir / "summary.json", *self._csv_written]
        for series in [self._xdmf] + [s.series for s in self._surfaces]:
            if series is not None:
                files += [series.live, series.path, series._live_h5, series.h5]
        return files

    def _allocated(self) -> int:
        """The bytes the run's files take on disk (rank 0: :meth:`_run_files`)."""
        return _allocated(self._run_files())

    def _estimate(self, mesh: bool) -> float:
        """A bound on the bytes one step's write adds, from the problem's sizes (the same
        on every rank, no communication): 8 bytes per value of each field on the volume
        mesh's nodes (a vector as 3 values, as dolfinx writes it) and on the slave
        surfaces' nodes; a CSV row of 25 characters per column for
        each slave node; an HDF5 dataset's overhead per field and a page per file. With
        ``mesh``: also the meshes (the coordinates, 3 values per node, and the cells'
        node lists, 8 bytes each), which the series write first. A slave surface's nodes
        are its slave nodes, and on 10-node tetrahedra, whose slave nodes are the facets'
        vertices, at most one more per facet and midside node (the surface file has them)."""
        p = self.problem
        nodes = p.V.dofmap.index_map.size_global
        slaves = [int(term.n_global_nodes) for term in p.contacts]
        layout = p.mesh.geometry.cmap.create_dof_layout()
        per_facet = layout.num_entity_closure_dofs(p.mesh.topology.dim - 1)  # 2 to 9
        facets = sum(int(term.n_global_facets) for term in p.contacts)
        shown = sum(slaves) + sum(
            (per_facet - len(term.mixed)) * int(term.n_global_facets) for term in p.contacts
        )  # the surfaces' nodes (:meth:`_start_surfaces`)
        per_node = 3 * ("displacement" in self.fields) + len(self._contact_names())
        datasets = int("displacement" in self.fields) + len(self._contact_names())
        values = per_node * (nodes + shown)
        columns = len(CSV_FIELDS_2D if p.gdim == 2 else CSV_FIELDS_3D)
        files = len(slaves) * 2 + 2  # the CSVs, the .h5 files, summary.json
        size = 8 * values + 25 * columns * sum(slaves)
        size += DATASET_OVERHEAD * datasets * (1 + len(slaves)) + FILE_OVERHEAD * files
        if mesh:
            tdim = p.mesh.topology.dim
            cells = p.mesh.topology.index_map(tdim).size_global
            per_cell = p.mesh.geometry.cmap.create_dof_layout().num_dofs
            geometry = p.mesh.geometry.index_map().size_global
            size += 8 * (3 * geometry + per_cell * cells) + 4 * DATASET_OVERHEAD
            size += 8 * (3 * shown + per_facet * facets) + 4 * DATASET_OVERHEAD * len(slaves)
        return size

    def _check_room(self, what: str, mesh: bool = False) -> None:
        """Raise OutputError on every rank where the file system lacks room for the next
        write (collective: :func:`check_room`, one allreduce). The bound: ROOM_FACTOR
        times the larger of :meth:`_estimate` and what the last step's write added (rank
        0 measures it: the blocks of the run's files), plus the summary.json and the
        XDMF indices that rank 0 writes through temporary copies (:func:`replace_text`).
        A parallel HDF5 write that ran out of room failed on some ranks and left the
        others waiting in it (a 3-rank run hung); a rank's own OSError (a CSV) is
        caught after the write, as before (:meth:`_raise_write_error`)."""
        need = ROOM_FACTOR * max(self._estimate(mesh), self._growth)
        reserve = 0
        if self.comm.rank == 0:
            copies = [self.out_dir / "summary.json"]
            copies += [s.path for s in [self._xdmf] + [f.series for f in self._surfaces] if s]
            need += _allocated(copies)
            if self.lock is not None and self.lock.reserving:
                reserve = self._reserve_bytes()
                need += max(reserve - self.lock.reserved, 0)
        log.debug(
            "room check: %d bytes needed (estimate %d, the last step added %d)",
            need,
            self._estimate(mesh),
            self._growth,
        )
        check_room(self.comm, self.out_dir, need, what)
        if reserve:  # room checked for it: an OSError (a disk filled meanwhile) stops the run
            self._guarded(self.lock.reserve, reserve)

    def _reserve_bytes(self) -> int:
        """The reserve of room for the final summary.json before a write (rank 0): the
        last summary.json written, twice what its step added (the step written next adds
        its record) and RESERVE_MARGIN (the final keys). The final rewrite, through a
        temporary copy while summary.json stays, needs room for the whole text: a run
        stopped by a full disk (a room check that fails, an ENOSPC) left summary.json at
        "running" and without its run-level timings; the room checked for each write
        counts the reserve's growth, and :meth:`finish` (:meth:`abandon`) frees the
        reserve right before it writes the final status."""
        return int(self._summary_bytes + ROOM_FACTOR * self._summary_added + RESERVE_MARGIN)

    def _free_reserve(self) -> None:
        """Free the reserve before the final summary.json (rank 0; local)."""
        if self.lock is not None:
            self.lock.free_reserve()

    def _first_write_error(self) -> str | None:
        """The first failed write of any rank (rank order), or None (collective)."""
        error = self._write_error
        return first_on_any_rank(self.comm, None if error is None else str(error))[0]

    def _raise_write_error(self) -> None:
        """Raise OutputError on every rank where some rank failed to write a file of its
        own (collective). Rank 0 writes the CSVs and summary.json alone: an OSError
        there went up on rank 0 only, while the other ranks went on into the next
        collective write, and the run ended in a traceback and MPI_ABORT."""
        reason = self._first_write_error()
        if reason is not None:
            raise OutputError(f"the output could not be written to {self.out_dir}: {reason}")

    def _close_files(self) -> None:
        """Close the XDMF files opened for a step (collective; rank 0 then publishes each
        index, a write of its own: :meth:`_guarded`)."""
        if self._xdmf is not None:
            self._guarded(self._xdmf.close)
        for surface in self._surfaces:
            self._guarded(surface.end_step)

    def _write_fields(self, step: int, t: float) -> None:
        """The step's fields and contact CSVs (the files open; collective)."""
        p = self.problem
        if "displacement" in self.fields:
            self._xdmf.file.write_function(p.u, t)
            if self._surfaces:
                p.u.x.scatter_forward()
                for surface in self._surfaces:
                    surface.write(p.u, t)
        for term in p.contacts:
            table = term.node_table()  # gathered on rank 0
            if self.comm.rank == 0:
                path = self.out_dir / f"{contact_stem(term.slave_name)}_{step}.csv"
                self._csv_written.append(path)
                self._guarded(write_contact_csv, path, table, p.gdim)
        if self._contact_functions:
            functions = self._contact_functions
            size = next(iter(functions.values())).x.array.size
            # fields.xdmf: at a node of several slave surfaces, the values of the pair in
            # which it is in contact (MortarContact.fill_fields' ranking); each
            # contact_<SLAVE>.xdmf: its own pair's values (one slave surface per pair)
            claimed = np.full((size, 2), -np.inf)
            self._fill(functions, [(term, claimed) for term in p.contacts])
            for f in functions.values():
                self._xdmf.file.write_function(f, t)
            if self._surfaces:
                for term, surface in zip(p.contacts, self._surfaces, strict=True):
                    if len(p.contacts) > 1:  # one pair: its values are fields.xdmf's
                        self._fill(functions, [(term, None)])
                    for f in functions.values():
                        surface.write(f, t)

    @staticmethod
    def _fill(functions: dict, terms) -> None:
        """Set the contact functions to 0, then to the values of each (term, claimed) of
        ``terms`` in turn (MortarContact.fill_fields), update their ghosts, and give the
        midside nodes of 6-node slave facets their edges' means
        (MortarContact.fill_midsides; collective)."""
        for f in functions.values():
            f.x.array[:] = 0.0
        for term, claimed in terms:
            term.fill_fields(functions, claimed)
        for f in functions.values():
            f.x.scatter_forward()
        for term, _ in terms:
            term.fill_midsides(functions)

    def finish(self, status: str, error: str | None = None, timings: dict | None = None) -> None:
        """Close the files and write the final summary (status "ok" or "failed").

        ``timings`` (the run-level ones) get ``"output"``: :attr:`elapsed` once the files
        are closed, the output's seconds but the final rewrite of summary.json. The
        reserve of room for it (:meth:`_reserve_bytes`) is freed right before it, so that
        a run stopped by a full disk says so in summary.json."""
        t0 = time.perf_counter()
        self.summary["status"] = status
        self.summary["error"] = error
        closing = None
        try:
            with self._collective_io():
                self._close_files()
                if self._xdmf is not None:
                    self._guarded(self._xdmf.finish)
                for surface in self._surfaces:
                    self._guarded(surface.close)
        except OutputError as exc:  # summary.json is still written
            closing = exc
        self._surfaces = []
        self.elapsed += time.perf_counter() - t0
        if timings is not None:
            self.summary["timings"] = dict(timings, output=self.elapsed)
        self._free_reserve()
        self._flush()
        if closing is not None:
            raise closing
        self._raise_write_error()

    def abandon(self, error: str) -> None:
        """The run ends by an exception that is not a stop (a caller's ``progress``
        callback raised, Ctrl-C): summary.json says "failed" and ``error``, with every
        step written so far. Rank 0 writes it, and nothing here is collective: the
        exception may have come on some ranks only. The XDMF files keep their published
        steps and their hidden series stay, as after a kill."""
        self.summary["status"] = "failed"
        self.summary["error"] = error
        self._free_reserve()
        self._flush()  # an OSError is logged (not collective here: nothing raised)

    def _flush(self) -> None:
        """Rewrite summary.json (rank 0; atomically: :func:`replace_text`), from the
        cached lines of the finished step records (:class:`SummaryText`)."""
        if self.comm.rank == 0:
            self._guarded(self._write_summary)

    def _write_summary(self) -> None:
        data = self._summary_text.text(self.summary).encode("utf-8")
        replace_text(self.out_dir / "summary.json", data)
        self._summary_added = max(len(data) - self._summary_bytes, 0)
        self._summary_bytes = len(data)

    def _guarded(self, write, *args) -> None:
        """``write(*args)``, a write of this rank's own; an OSError is kept (the first)
        for :meth:`_raise_write_error` and logged, so that the collectives go on."""
        try:
            write(*args)
        except OSError as exc:
            log.error("writing the output failed: %s", exc)
            if self._write_error is None:
                self._write_error = exc
