"""End-to-end tests of the command line: bad input, serial and under ``mpirun``.

The contract (SCENES.md): bad input gives exactly one line
``dolfinx-mortar: error: KEY: REASON`` on stderr per rank, exit status 2, no Python
traceback, and leaves an existing output directory untouched. The tests run the program
in this process or as a subprocess (``python3 -m dolfinx_mortar``), so none of them may
itself run under mpirun (no nested MPI): none is marked ``mpi``. The MPI variants launch
``mpirun -n 2`` themselves.

The bad-input matrix (every case of CASES, ``check`` and ``run``: test_bad_input_serial)
runs in this process instead: ``cli.main([command, scene])``, what ``python3 -m
dolfinx_mortar`` calls (``sys.exit(main())``), in the case's working directory, its
stdout and stderr read at the file-descriptor level (``capfd``: C-level writes count),
the exit status from its return value or SystemExit (a process costs about 1.1 s of
interpreter start, MPI_Init and imports: as processes the 86 took 90 s of a serial run,
in this process 1.5 s; CHANGELOG, session 57). So does every other serial command of
the tests that do not need a process of their own (:func:`cli_call`: serially
:func:`cli_in_process`, under mpirun a process per rank; session 60: the file's test
time went from 509 s to 354 s in two runs side by side, its CPU time down 46 %:
CHANGELOG). A process of its own stays where only one shows the behaviour: the cold JIT cache (``XDG_CACHE_HOME``), the import order
(:func:`_main_and_modules`), signals, host programs, a scene file name that is not
UTF-8 (dolfinx's import reads sys.argv), the verbosity flags (dolfinx's import puts a
handler on the root logger first, which the runs here set aside), an MPMD launch, and
the bench scripts (their import changes sys.path and adds loggers). The process's
state is kept from one command to the next and from the files that the xdist worker
runs after this one, and what a command should leave as it found it is asserted
unchanged (:func:`_process_state_kept`: loggers, warning filters, signal handlers
Python's and C's, PETSc's options database, os.environ, sys.argv, the working
directory, open file descriptors, ...).

What a run in this process does not see, and test_bad_input_subprocess (one case of each
stage at which input fails, ``check`` and ``run`` between them, each a process of its
own) does:

- what the interpreter's start does: ``-m`` and ``__main__``, the first imports
  (PETSc's initialization and its signal handlers, the import-time warning filters:
  done before the first in-process run, :data:`_WARM_MODULES`), the command line as
  dolfinx's import hands it to its C++ logging (``cli._import_dolfinx``), MPI_Init's
  output, and the environment of :func:`_env` (PYTHONUNBUFFERED, no MPI job);
- what its exit does: output written at interpreter exit (PETSc's warnings of options
  left unused at PetscFinalize, atexit handlers and weakref finalizers, gmsh's and MPI's
  finalization, buffered output flushed), and the exit status as the OS reports it;
- state that one process keeps from a first call: per-process caches (forms and numba
  kernels compiled once, ffcx's parameter files read once), so that a first call's
  output (a cold JIT's build log: test_bad_input_cold_jit_cache) shows in one case only.

What a process prints at its start or exit depends on how far the command got (the
modules it imported, the PETSc options and objects a stage left for the finalizers), so
the subprocess subset takes a case of each stage: the TOML parser, the scene's values,
the mesh reader, the mesh and group checks, the contact surfaces after the forms are
compiled, the penalty rule and the generator's size.
"""

from __future__ import annotations

import contextlib
import ctypes
import faulthandler
import functools
import json
import logging
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import traceback
import warnings
from pathlib import Path

import pytest
from conftest import patch_press_scene, stick_only_scene, write_block_msh

from dolfinx_mortar.scene import dump_scene

TIMEOUT = 120  # seconds per subprocess
ERROR_LINE = re.compile(r"^dolfinx-mortar: error: (?P<key>[^:]*): (?P<reason>\S.*)$")

# Environment variables that tie a process to a running MPI job (an Open MPI singleton
# or an mpirun): a child must not inherit them, or it would try to join that job.
# A pytest-xdist worker starts with the C-level environ of the controller, which the MPI
# singleton extended (OMPI_MCA_ess=singleton, OMPI_MCA_pmix, OMPI_APP_CTX_NUM_PROCS,
# ORTE_SCHIZO_DETECTION): an mpirun started with those exits 1 without a word.
_MPI_JOB_PREFIXES = ("PMIX_", "PMI_", "OMPI_", "ORTE_")


def _env(**extra: str) -> dict[str, str]:
    """A clean environment for a child: os.environ (not the C-level environ, which an
    MPI singleton extends), without MPI job variables, plus root-friendly Open MPI
    settings (as scripts/env.sh) and one thread per process."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(_MPI_JOB_PREFIXES)}
    # the container setting of scripts/env.sh is not a job variable: it is kept
    vader = "OMPI_MCA_btl_vader_single_copy_mechanism"
    if vader in os.environ:
        env[vader] = os.environ[vader]
    env.update(
        OMPI_ALLOW_RUN_AS_ROOT="1",
        OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
        OMPI_MCA_rmaps_base_oversubscribe="1",
        OMP_NUM_THREADS="1",
        OPENBLAS_NUM_THREADS="1",
        PYTHONUNBUFFERED="1",
    )
    env.update(extra)
    return env


def cli(cwd: Path, *args: str, ranks: int = 0, **env: str) -> subprocess.CompletedProcess:
    """Run ``python3 -m dolfinx_mortar ARGS`` in ``cwd``; under ``mpirun -n RANKS`` if ranks > 0."""
    cmd = [sys.executable, "-m", "dolfinx_mortar", *args]
    if ranks:
        mpirun = shutil.which("mpirun")
        assert mpirun is not None, "mpirun not found on PATH: the MPI tests need Open MPI"
        # -q: no "mpirun detected that one or more processes exited with non-zero status"
        # banner, so that stderr holds only what the ranks print
        cmd = [mpirun, "-q", "-n", str(ranks), *cmd]
    return subprocess.run(
        cmd,
        cwd=cwd,
        env=_env(**env),
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        stdin=subprocess.DEVNULL,
    )


# ------------------------------------------------------------------- in-process runs

# The signals whose handlers the in-process runs check: the standard ones but SIGKILL
# and SIGSTOP, which cannot be caught (glibc's sigaction refuses its internal 32 and 33).
_SIGNALS = [s for s in range(1, signal.SIGRTMIN) if s not in (signal.SIGKILL, signal.SIGSTOP)]
_SIGACTION_BYTES = 152  # sizeof(struct sigaction) of glibc on x86_64 and aarch64


def _c_signal_dispositions() -> dict[int, bytes]:
    """Each signal of _SIGNALS -> its C-level struct sigaction, read with sigaction(2): a
    handler that C code (gmsh, PETSc, MPI) installs is not seen by signal.getsignal.
    Empty off Linux."""
    if not sys.platform.startswith("linux"):
        return {}
    libc = ctypes.CDLL(None, use_errno=True)
    out = {}
    for s in _SIGNALS:
        buf = ctypes.create_string_buffer(_SIGACTION_BYTES)
        if libc.sigaction(s, None, buf) == 0:
            out[s] = buf.raw
    return out


#: sa_flags that matter only to a handler function: Python's signal.signal sets them with
#: any handler, SIG_DFL too (a run that puts SIGTERM back to SIG_DFL leaves them)
_SA_ONSTACK, _SA_RESTORER = 0x08000000, 0x04000000


def _disposition(raw: bytes) -> bytes:
    """The handler, the first 64 signals of the mask (the kernel's; glibc copies the
    rest of its 1024-bit mask from uninitialized memory) and the flags of a struct
    sigaction; of SIG_DFL and SIG_IGN the handler and the flags but SA_ONSTACK and
    SA_RESTORER (the mask and those flags act when a handler function runs)."""
    if int.from_bytes(raw[:8], "little") in (0, 1):  # SIG_DFL, SIG_IGN
        flags = int.from_bytes(raw[136:140], "little") & ~(_SA_ONSTACK | _SA_RESTORER)
        return raw[:8] + flags.to_bytes(4, "little")
    return raw[:16] + raw[136:140]


def _open_fds() -> dict[str, str]:
    """The process's open file descriptors -> what they point to (Linux; empty
    elsewhere), without the one that listed them."""
    if not os.path.isdir("/proc/self/fd"):
        return {}
    out = {}
    for fd in os.listdir("/proc/self/fd"):
        with contextlib.suppress(OSError):  # the listing's own, closed by now
            out[fd] = os.readlink(f"/proc/self/fd/{fd}")
    return out


#: Loggers whose level a library sets on each call, put back but not asserted unchanged:
#: ffcx.parameters.get_parameters sets ffcx's to its "verbosity" at each JIT compilation.
_LIBRARY_SET_LOGGERS = ("ffcx",)


def _loggers(library_set: bool = False) -> dict[str, tuple]:
    """Every logger but the root -> (level, handlers with their levels, propagate,
    disabled); those of _LIBRARY_SET_LOGGERS only where ``library_set``."""
    out = {}
    for name, lg in logging.root.manager.loggerDict.items():
        if (name in _LIBRARY_SET_LOGGERS) != library_set:
            continue
        if isinstance(lg, logging.Logger):
            handlers = tuple((h, h.level) for h in lg.handlers)
            out[name] = (lg.level, handlers, lg.propagate, lg.disabled)
    return out


def _package_state() -> dict[str, object]:
    """The module-level state of dolfinx_mortar that a command may change: the
    registered laws, the PETSc options the live solvers have loaded (and a host
    program's that they set aside), whether a stop-signal handler is in force."""
    from dolfinx_mortar import errors, laws, solver

    return {
        "laws": dict(laws._LAWS),
        "stop": dict(errors._stop),
        "solvers loaded": dict(solver._LOADED),
        "host options set aside": dict(solver._HOST_OPTIONS),
    }


def _process_state() -> dict[str, object]:
    """The process-global state that :func:`_process_state_kept` asserts unchanged."""
    import argparse

    import numpy as np
    from petsc4py import PETSc

    return {
        "loggers": _loggers(),
        "logging.disable": logging.root.manager.disable,
        "warning filters": list(warnings.filters),
        "signal handlers": {s: signal.getsignal(s) for s in _SIGNALS},
        "C-level signal dispositions": {
            s: _disposition(raw) for s, raw in _c_signal_dispositions().items()
        },
        "PETSc options": dict(PETSc.Options().getAll()),
        "os.environ": dict(os.environ),
        "sys.argv": list(sys.argv),
        "sys.path": list(sys.path),
        "cwd": os.getcwd(),
        "sys.stdin/stdout/stderr": (sys.stdin, sys.stdout, sys.stderr),
        "sys.excepthook": sys.excepthook,
        "faulthandler": faulthandler.is_enabled(),
        "ArgumentParser.error": argparse.ArgumentParser.error,
        "numpy errstate": np.geterr(),
        "dolfinx_mortar": _package_state(),
        "threads": set(threading.enumerate()),
        "open file descriptors": _open_fds(),
    }


#: The filters pytest puts first in each test's warning filters (its summary shows them);
#: a fresh interpreter has none of them (no -W, no PYTHONWARNINGS).
_PYTEST_FILTERS = (
    ("always", None, DeprecationWarning, None, 0),
    ("always", None, PendingDeprecationWarning, None, 0),
)


def _warning_to_stderr(message, category, filename, lineno, file=None, line=None):
    """warnings.showwarning as a fresh interpreter's: the warning on sys.stderr."""
    sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


#: The modules whose import changes the process's state (PETSc's C signal handlers, the
#: warning filters of numpy, scipy and pkg_resources): imported before the in-process
#: runs take their first snapshot, as a fresh ``python3 -m dolfinx_mortar`` imports them.
_WARM_MODULES = ("dolfinx", "dolfinx.fem.petsc", "dolfinx.io", "petsc4py.PETSc", "scipy.sparse")


@pytest.fixture(scope="module")
def warm_imports(tmp_path_factory):
    """Every module of dolfinx_mortar and :data:`_WARM_MODULES`, imported, and one C
    extension built with cffi, as FFCx's JIT builds a form that its cache lacks: the
    first build imports setuptools (its loggers) and sets ``os.environ["PLAT"]``
    (distutils' check_environ), state that a process keeps from its first compilation
    on (with an empty FFCx cache, CI's, the first case that compiled a form changed
    them: session 57's CI-like run)."""
    import importlib
    import pkgutil

    import cffi

    import dolfinx_mortar

    for name in _WARM_MODULES:
        importlib.import_module(name)
    for info in pkgutil.walk_packages(dolfinx_mortar.__path__, "dolfinx_mortar."):
        if info.name != "dolfinx_mortar.__main__":
            importlib.import_module(info.name)
    ffi = cffi.FFI()
    ffi.cdef("int _dm_warm(void);")
    ffi.set_source("_dm_warm_jit", "int _dm_warm(void) { return 0; }")
    ffi.compile(tmpdir=str(tmp_path_factory.mktemp("cffi_warm")))


@contextlib.contextmanager
def _process_state_kept(laws_file: bool = False):
    """Run the block (a call of ``cli.main``) as a process of its own would run it, and
    keep the tests that follow in this process (the xdist worker runs other files after
    this one) from seeing what it changed.

    As in a fresh ``python3``, the block runs with the root logger at WARNING with no
    handler (pytest's set aside: ``_setup_logging``'s basicConfig(force=True) would close
    them) and with the interpreter's warning filters and ``warnings.showwarning`` (pytest
    records the warnings for its summary: a warning the command leaks must reach stderr,
    as one more line). Afterwards the root logger (level, handlers and their levels) and
    the warning filters are put back, the handler the command set up closed.

    Asserted unchanged by the block, and put back where changed (but the threads and
    the file descriptors): the other loggers and ``logging.disable`` (ffcx's level put
    back, not asserted: :data:`_LIBRARY_SET_LOGGERS`), the warning filters the block ran
    with, the signal handlers of every signal, Python's and C's (sigaction: gmsh and
    PETSc install their own), PETSc's options database (a solver's options go with the
    solver: a failed ``check`` or ``run`` leaves none), os.environ, sys.argv, sys.path,
    the working directory, sys.stdin/stdout/stderr, sys.excepthook, faulthandler,
    argparse's ArgumentParser.error (``bench`` swaps it), numpy's floating-point error
    handling, dolfinx_mortar's module state (:func:`_package_state`), the threads and the
    open file descriptors (a .msh file that gmsh cannot parse too, case mesh-corrupt:
    gmsh 4.8 left it open; ``mesh.load_mesh`` closes it since session 58).

    ``laws_file``: the command runs a ``--laws`` file, whose laws stay registered in a
    process of its own (its purpose): they are put back, not asserted unchanged."""
    root = logging.getLogger()
    root_level, root_handlers = root.level, list(root.handlers)
    root_handler_levels = [h.level for h in root_handlers]
    root.handlers[:] = []
    root.setLevel(logging.WARNING)
    library_set = _loggers(library_set=True)
    c_before = _c_signal_dispositions()
    try:
        with warnings.catch_warnings():
            warnings.filters[:] = [f for f in warnings.filters if f not in _PYTEST_FILTERS]
            warnings.showwarning = _warning_to_stderr
            before = _process_state()
            try:
                yield
            finally:
                after = _process_state()
    finally:
        for h in root.handlers:
            if h not in root_handlers:
                h.close()
        root.handlers[:] = root_handlers
        root.setLevel(root_level)
        for h, level in zip(root_handlers, root_handler_levels, strict=True):
            h.setLevel(level)
    changed = [k for k in before if after[k] != before[k]]
    if laws_file and "dolfinx_mortar" in changed:  # the laws a --laws file registered
        kept = [
            {k: v for k, v in s["dolfinx_mortar"].items() if k != "laws"} for s in (before, after)
        ]
        if kept[0] == kept[1]:
            changed.remove("dolfinx_mortar")
    _put_back(before, after, c_before)
    _put_back_loggers(library_set)
    detail = "\n".join(f"{k}: {_difference(before[k], after[k])}" for k in changed)
    assert not changed, f"the command changed the process's {', '.join(changed)}:\n{detail}"


def _difference(before, after) -> str:
    """What differs between two states of :func:`_process_state` (of dicts, the keys)."""
    if isinstance(before, dict) and isinstance(after, dict):
        keys = sorted({*before, *after}, key=str)
        items = [(k, before.get(k, "-"), after.get(k, "-")) for k in keys]
        return "; ".join(f"{k!r}: {b!r} -> {a!r}" for k, b, a in items if b != a)
    return f"{before!r} -> {after!r}"


def _put_back_loggers(loggers: dict[str, tuple]) -> None:
    """Set the loggers as :func:`_loggers` gave them."""
    for name, (level, handlers, propagate, disabled) in loggers.items():
        lg = logging.getLogger(name)
        lg.setLevel(level)
        lg.handlers[:] = [h for h, _ in handlers]
        for h, hl in handlers:
            h.setLevel(hl)
        lg.propagate, lg.disabled = propagate, disabled


def _put_back(before: dict, after: dict, c_dispositions: dict[int, bytes]) -> None:
    """Undo what a command changed of :func:`_process_state` (``before``, ``after``), so
    far as it can be: the C-level signal dispositions from their structs
    ``c_dispositions``; not the threads nor the file descriptors."""
    import argparse

    import numpy as np

    _put_back_loggers(before["loggers"])
    logging.disable(before["logging.disable"])
    for s, handler in before["signal handlers"].items():
        if handler is not None and signal.getsignal(s) != handler:
            signal.signal(s, handler)
    now = _c_signal_dispositions()
    libc = ctypes.CDLL(None, use_errno=True)
    for s, raw in c_dispositions.items():
        if _disposition(now.get(s, b"")) != _disposition(raw):
            libc.sigaction(s, ctypes.create_string_buffer(raw, _SIGACTION_BYTES), None)
    if after["PETSc options"] != before["PETSc options"]:
        from petsc4py import PETSc

        opts = PETSc.Options()
        for key in set(after["PETSc options"]) - set(before["PETSc options"]):
            opts.delValue(key)
        for key, value in before["PETSc options"].items():
            opts.setValue(key, value)
    for key in set(os.environ) - set(before["os.environ"]):
        del os.environ[key]
    os.environ.update(before["os.environ"])
    sys.argv[:] = before["sys.argv"]
    sys.path[:] = before["sys.path"]
    sys.excepthook = before["sys.excepthook"]
    os.chdir(before["cwd"])
    sys.stdin, sys.stdout, sys.stderr = before["sys.stdin/stdout/stderr"]
    argparse.ArgumentParser.error = before["ArgumentParser.error"]
    np.seterr(**before["numpy errstate"])
    if after["dolfinx_mortar"] != before["dolfinx_mortar"]:
        from dolfinx_mortar import errors, laws

        laws._LAWS.clear()
        laws._LAWS.update(before["dolfinx_mortar"]["laws"])
        errors._stop.update(before["dolfinx_mortar"]["stop"])


def _exit_status(code) -> int:
    """The exit status of a process that raised SystemExit(code) (as the interpreter
    sets it; it prints a code that is not an integer on stderr)."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    sys.stderr.write(f"{code}\n")
    return 1


def cli_in_process(capfd, *args: str) -> tuple[int, str, str]:
    """``python3 -m dolfinx_mortar ARGS`` (that is ``sys.exit(cli.main())``) run in this
    process, in the working directory (the caller's monkeypatch.chdir), under
    :func:`_process_state_kept`: (exit status, stdout, stderr), the output read at the
    file-descriptor level (``capfd``: C-level writes count too). An exception that
    escapes ``main`` ends as the interpreter ends it: its traceback on stderr, status 1."""
    from dolfinx_mortar.cli import main

    capfd.readouterr()  # what came before is not the command's
    with _process_state_kept(laws_file="--laws" in args):
        try:
            rc = main(list(args))
        except SystemExit as exc:
            rc = _exit_status(exc.code)
        except Exception:
            traceback.print_exc()
            rc = 1
        sys.stdout.flush()
        sys.stderr.flush()
    out, err = capfd.readouterr()
    return rc, out, err


def snapshot(root: Path) -> dict[str, tuple]:
    """Every file and directory under ``root``: relative name -> (kind, mtime_ns, bytes)."""
    out = {}
    for path in sorted(root.rglob("*")):
        st = path.lstat()
        rel = path.relative_to(root).as_posix()
        if path.is_dir():
            out[rel] = ("dir", st.st_mtime_ns, None)
        else:
            out[rel] = ("file", st.st_mtime_ns, path.read_bytes())
    return out


# --------------------------------------------------------------------------- scenes


def to_toml(scene: dict) -> str:
    return dump_scene(scene)


def base_scene(mesh: str = "block.msh") -> dict:
    """Valid tiny bulk scene: small-strain block, fixed left, pulled right, one step."""
    return {
        "title": "cli test",
        "kinematics": "small",
        "mesh": {"file": mesh},
        "material": [{"region": "body", "model": "linear-elastic", "E": 100.0, "nu": 0.3}],
        "dirichlet": [{"boundary": "left", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]}],
        "traction": [{"boundary": "right", "path": [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0]]}],
        "steps": {"n": 1},
        "output": {"dir": "out"},
    }


def _contact(**kw) -> dict:
    return {"slave": "top", "master": "bottom", **kw}


def _set(section: str, index: int | None = None, **kw):
    """Edit: update ``scene[section]`` (or its ``index``-th table) with ``kw``."""

    def edit(s):
        target = s[section] if index is None else s[section][index]
        target.update(kw)

    return edit


def _add_contact(**kw):
    def edit(s):
        s["contact"] = [_contact(**kw)]

    return edit


def _pairs(*pairs):
    def edit(s):
        s["contact"] = [_contact(slave=a, master=b) for a, b in pairs]

    return edit


def _unnamed_group(s):
    s["mesh"]["file"] = "unnamed.msh"
    s["dirichlet"][0]["boundary"] = "top"
    del s["traction"]


def _small_hyperelastic(s):
    s["kinematics"] = "small"
    s["material"][0]["model"] = "neo-hookean"


def _unsorted_path(s):
    s["dirichlet"][0]["path"] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.0, 0.0]]


def _corrupt_mesh(s):
    s["mesh"]["file"] = "garbage.msh"  # written by write_case


def _empty_surface(s):
    s["mesh"]["file"] = "ghost.msh"
    s["contact"] = [_contact(slave="ghost", master="top")]


# (id, edit of the base scene, expected key, text expected in the reason)
CASES = [
    ("unknown-key", _set("material", 0, young=1.0), "material[0].young", "unknown key"),
    ("unknown-top-key", _set("steps", None, nn=2), "steps.nn", "unknown key"),
    (
        "missing-group-material",
        _set("material", 0, region="bdy"),
        "material[0].region",
        "'bdy' not found",
    ),
    (
        "missing-group-contact-slave",
        _add_contact(slave="nowhere"),
        "contact[0].slave",
        "'nowhere' not found",
    ),
    (
        "missing-group-dirichlet",
        _set("dirichlet", 0, boundary="lft"),
        "dirichlet[0].boundary",
        "'lft' not found",
    ),
    (
        "cell-group-as-boundary",
        _set("dirichlet", 0, boundary="body"),
        "dirichlet[0].boundary",
        "is a cell group, not a facet group",
    ),
    ("wrong-type", _set("material", 0, E="100"), "material[0].E", "expected a number"),
    ("E-zero", _set("material", 0, E=0.0), "material[0].E", "must be > 0"),
    ("E-negative", _set("material", 0, E=-5.0), "material[0].E", "must be > 0"),
    ("nu-half", _set("material", 0, nu=0.5), "material[0].nu", "(-1, 0.5)"),
    ("nu-minus-one", _set("material", 0, nu=-1.0), "material[0].nu", "(-1, 0.5)"),
    ("mu-negative", _add_contact(friction=-0.1), "contact[0].friction", "must be >= 0"),
    ("rtol-one", lambda s: s.update(solver={"rtol": 1.0}), "solver.rtol", "must be < 1"),
    (
        "slave-is-master",
        _add_contact(slave="top", master="top"),
        "contact[0].master",
        "same group",
    ),
    (
        "unknown-recovery",
        _add_contact(recovery="exact"),
        "contact[0].recovery",
        "unknown value 'exact'",
    ),
    (
        "unknown-model",
        _set("material", 0, model="mooney-rivlin"),
        "material[0].model",
        "unknown value 'mooney-rivlin'",
    ),
    ("mesh-missing", _set("mesh", None, file="nope/absent.msh"), "mesh.file", "not found"),
    ("mesh-corrupt", _corrupt_mesh, "mesh.file", "cannot read"),
    ("unsorted-path", _unsorted_path, "dirichlet[0].path", "not sorted in t"),
    (
        "component-out-of-range",
        _set("dirichlet", 0, components=[2], path=[[0.0, 0.0], [1.0, 0.0]]),
        "dirichlet[0].components",
        "component 2 out of range [0, 2)",
    ),
    ("toml-syntax", "syntax", "", "TOML syntax error"),
    ("empty-contact-surface", _empty_surface, "contact[0].slave", "'ghost' is empty"),
    (
        "surfaces-share-nodes",
        _add_contact(slave="top", master="left"),
        "contact[0].master",
        "'top' and 'left' share 1 mesh node(s)",
    ),
    ("small-hyperelastic", _small_hyperelastic, "material[0].model", 'kinematics = "small"'),
    ("pair-twice", _pairs(("top", "bottom"), ("top", "bottom")), "contact[1]", "contact[0] again"),
    (
        "pair-reversed",
        _pairs(("top", "bottom"), ("bottom", "top")),
        "contact[1]",
        "slave and master swapped",
    ),
    (
        "slave-twice",
        _pairs(("top", "bottom"), ("top", "left")),
        "contact[1].slave",
        "'top' is already the slave of contact[0]",
    ),
    (
        "slave-file-names-collide",
        _pairs(("a b", "bottom"), ("a_b", "left")),
        "contact[1].slave",
        "would write the same files",
    ),
    ("too-many-steps", _set("steps", None, n=10**20), "steps.n", "at most 1000000 load steps"),
    ("mesh-empty", _set("mesh", None, file="empty.msh"), "mesh.file", "empty.msh is empty"),
    (  # passed `check`; the run failed with a LinAlgError traceback (a NaN node) or a
        # hint that blamed the loads (cells of zero area)
        "mesh-nan-node",
        _set("mesh", None, file="nan.msh"),
        "mesh.file",
        "1 node(s) with a non-finite coordinate, e.g. node 1 (nan, 0, 0)",
    ),
    (
        "mesh-zero-area-cells",
        _set("mesh", None, file="flat.msh"),
        "mesh.file",
        "2 cell(s) of group 'body' with zero area",
    ),
    (
        "mesh-twin-names",
        _set("mesh", None, file="twins.msh"),
        "mesh",
        "the physical name 'inner' is given to two groups of dimension 1",
    ),
    (
        "mesh-unnamed-group",
        _unnamed_group,
        "material",
        "cell group(s) '2' (a physical group without a name: its tag) have no [[material]]",
    ),
    (
        "mesh-loose-nodes",
        _set("mesh", None, file="loose.msh"),
        "mesh",
        "lies outside every physical group of cells",
    ),
    (  # gmsh meshed the surface apart from its volume: the message said "give every
        # body a physical group of cells", which every body had
        "mesh-not-conforming",
        _set("mesh", None, file="detached.msh"),
        "mesh",
        "the physical group 'top' (dimension 1) uses 6 node(s) that no element of a "
        "physical group of cells uses (node 7 at (0, 1, 0)); 6 of them lie where a cell's "
        "node lies: the mesh is not conforming there (duplicate nodes; "
        "gmsh.model.mesh.removeDuplicateNodes() merges them)",
    ),
    (
        "mesh-cells-in-two-groups",
        _set("mesh", None, file="overlap.msh"),
        "mesh",
        "the physical groups 'body' and 'all' share cells",
    ),
    (
        "mesh-facets-in-two-groups",
        _set("mesh", None, file="twofacet.msh"),
        "mesh",
        "the physical groups 'top' and 'load' share facets",
    ),
    (  # the contact stiffness was inf, and the hint of the NaN residual blamed the loads
        "E-overflows-contact-stiffness",
        lambda s: (_set("material", 0, E=1e308)(s), _add_contact()(s)),
        "contact[0]",
        "the contact stiffness 100 E*/h overflows",
    ),
    (  # `check` said ok with a leaked RuntimeWarning (ε/A overflowed); `run` leaked five
        # and stopped after 6 cutbacks, "the first residual is not finite" (session 52)
        "penalty-far-beyond-auto",
        _add_contact(penalty=1e308),
        "contact[0].penalty",
        "times the auto penalty (100 E*/h, at most",
    ),
    (
        "penalty-tangential-far-beyond-auto",
        _add_contact(friction=0.3, penalty_tangential=1e20),
        "contact[0].penalty_tangential",
        "times the auto penalty (100 E*/h, at most",
    ),
    (  # ran with a leaked RuntimeWarning: μ p ε_T overflowed in the return mapping
        "friction-huge",
        _add_contact(friction=1e308),
        "contact[0].friction",
        "friction coefficient must be at most 1e+06, got 1e+308",
    ),
    (  # node integration has no rule: the degree was ignored (session 64)
        "quadrature-degree-with-node",
        _add_contact(integration="node", quadrature_degree=6),
        "contact[0].quadrature_degree",
        "node integration has no quadrature rule",
    ),
    (  # basix's collapsed rules grow as degree² points per facet
        "quadrature-degree-huge",
        _add_contact(quadrature_degree=1000),
        "contact[0].quadrature_degree",
        "must be <= 30, got 1000",
    ),
    (  # gmsh died of std::bad_alloc (or meshed for ages), `check` too (session 53)
        "mesh-generator-too-big",
        lambda s: s.update(mesh={"generator": "patch2d", "params": {"n_lower": 2000000000}}),
        "mesh.params",
        "n_lower = 2000000000, n_upper = 7, n_y = 3, order = 1 ask patch2d for about 8e+09 "
        "mesh nodes, more than it meshes (MAX_NODES = 2e+07",
    ),
]
CASE_IDS = [c[0] for c in CASES]
CASE_BY_ID = {c[0]: c for c in CASES}


@pytest.fixture(scope="module")
def meshes(tmp_path_factory) -> Path:
    """block.msh (2D block, groups body/left/right/bottom/top) and ghost.msh (the same
    plus a facet group "ghost" that has no elements: a discrete curve never meshed)."""
    import gmsh

    d = tmp_path_factory.mktemp("meshes")
    write_block_msh(d / "block.msh", 2, n=2)
    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(d / "block.msh"))
        curve = gmsh.model.addDiscreteEntity(1)
        tag = gmsh.model.addPhysicalGroup(1, [curve])
        gmsh.model.setPhysicalName(1, tag, "ghost")
        gmsh.write(str(d / "ghost.msh"))
    finally:
        gmsh.finalize()
    write_two_squares_msh(d / "inner.msh")
    write_two_squares_msh(d / "loose.msh", loose=True)
    write_two_squares_msh(d / "detached.msh", detached=True)
    write_two_squares_msh(d / "unnamed.msh", unnamed=True)
    write_two_squares_msh(d / "overlap.msh", extra_group=(2, "all"))
    write_two_squares_msh(d / "twofacet.msh", extra_group=(1, "load"))
    (d / "empty.msh").write_bytes(b"")
    # gmsh's API refuses a second group of one name, a .msh file can hold it
    inner = (d / "inner.msh").read_text()
    assert inner.count('"top"') == 1
    (d / "twins.msh").write_text(inner.replace('"top"', '"inner"'))
    return d


def write_two_squares_msh(
    path: Path, loose: bool = False, unnamed: bool = False, extra_group=None, detached=False
) -> None:
    """Two unit squares sharing the edge x = 1: groups body, inner (the shared, interior
    edge) and top. ``loose``: the group body holds the first square only, so the file has
    nodes of the second that no cell uses (dolfinx 0.5.2 crashed on those); ``unnamed``:
    body holds the first square, the second is a physical group without a name;
    ``extra_group`` (dim, name): one more group of the squares (dim 2, as a whole-domain
    group "all": cells in two groups, which broke dolfinx's mesh creation) or of the top
    edges (dim 1: facets in two groups, of which dolfinx kept one); ``detached``: top is
    a line of its own from (0, 1) to (1, 1), not fragmented with the squares: its nodes
    duplicate the squares' (a non-conforming mesh)."""
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        a, b = occ.addRectangle(0, 0, 0, 1, 1), occ.addRectangle(1, 0, 0, 1, 1)
        occ.fragment([(2, a)], [(2, b)])
        line = occ.addLine(occ.addPoint(0, 1, 0), occ.addPoint(1, 1, 0)) if detached else None
        occ.synchronize()
        model = gmsh.model
        model.setPhysicalName(
            2, model.addPhysicalGroup(2, [a] if loose or unnamed else [a, b]), "body"
        )
        if unnamed:
            model.addPhysicalGroup(2, [b])
        for name, axis, value in (("inner", 0, 1.0), ("top", 1, 1.0)):
            tags = [
                t
                for _, t in model.getEntities(1)
                if abs(occ.getCenterOfMass(1, t)[axis] - value) < 1e-9
            ]
            if detached and name == "top":
                tags = [line]
            model.setPhysicalName(1, model.addPhysicalGroup(1, tags), name)
            if extra_group and extra_group[0] == 1 and name == "top":
                model.setPhysicalName(1, model.addPhysicalGroup(1, tags), extra_group[1])
        if extra_group and extra_group[0] == 2:
            model.setPhysicalName(2, model.addPhysicalGroup(2, [a, b]), extra_group[1])
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.fixture
def workdir(meshes, tmp_path) -> Path:
    """A fresh working directory with the meshes and the output of an earlier run."""
    cwd = tmp_path / "work"
    cwd.mkdir()
    for name in (
        "block.msh",
        "ghost.msh",
        "inner.msh",
        "loose.msh",
        "detached.msh",
        "empty.msh",
        "twins.msh",
        "unnamed.msh",
        "overlap.msh",
        "twofacet.msh",
    ):
        shutil.copy(meshes / name, cwd / name)
    out = cwd / "out"
    (out / "sub").mkdir(parents=True)
    (out / "sentinel.txt").write_text("results of an earlier run\n")
    (out / "summary.json").write_text('{"status": "ok", "steps": []}\n')
    (out / "sub" / "contact_top_0.csv").write_bytes(b"x,y\n0,0\n")
    old = 1_000_000_000  # 2001: any rewrite, even with equal content, changes the mtime
    for p in [*out.rglob("*"), out]:
        os.utime(p, (old, old))
    return cwd


def write_case(cwd: Path, case_id: str) -> Path:
    _, edit, _, _ = CASE_BY_ID[case_id]
    path = cwd / "bad.toml"
    if edit == "syntax":
        text = to_toml(base_scene()).replace("E = 100.0", "E = = 100.0")
        assert text.count("E = = 100.0") == 1
    else:
        scene = base_scene()
        edit(scene)
        text = to_toml(scene)
    if case_id == "mesh-corrupt":
        (cwd / "garbage.msh").write_bytes(bytes(range(256)) * 4 + b"$MeshFormat\n\x00\xff")
    if case_id in ("mesh-nan-node", "mesh-zero-area-cells"):
        # two triangles in the physical group "body": a node at x = NaN, or every y = 0
        y = 0 if case_id == "mesh-zero-area-cells" else 1
        x0 = "nan" if case_id == "mesh-nan-node" else 0
        (cwd / ("nan.msh" if y else "flat.msh")).write_text(
            '$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n2 1 "body"\n'
            f"$EndPhysicalNames\n$Nodes\n4\n1 {x0} 0 0\n2 1 0 0\n3 1 {y} 0\n4 0 {y} 0\n"
            "$EndNodes\n$Elements\n2\n1 2 2 1 1 1 2 3\n2 2 2 1 1 1 3 4\n$EndElements\n"
        )
    path.write_text(text)
    return path


def assert_bad_input(result, case_id: str, ranks: int, before: dict, cwd: Path) -> None:
    """The bad-input contract for ``result`` (exit status, stdout, stderr) of case
    ``case_id`` on ``ranks`` ranks; ``before``: :func:`snapshot` of ``cwd`` before."""
    returncode, stdout, stderr = result
    _, _, key, reason = CASE_BY_ID[case_id]
    where = f"\nstdout:\n{stdout}\nstderr:\n{stderr}"
    assert "Traceback" not in stderr + stdout, where
    assert returncode == 2, where
    lines = stderr.splitlines()
    assert len(lines) == ranks, f"expected {ranks} line(s) on stderr{where}"
    assert len(set(lines)) == 1, f"ranks disagree{where}"
    if key:
        m = ERROR_LINE.match(lines[0])
        assert m, where
        assert m.group("key") == key, where
        assert reason in m.group("reason"), where
    else:  # TOML syntax error: no key, the file, line and column instead
        assert lines[0].startswith("dolfinx-mortar: error: "), where
        assert "bad.toml, line" in lines[0] and reason in lines[0], where
    assert snapshot(cwd) == before, f"the working or output directory was touched{where}"


# --------------------------------------------------------------------------- bad input


def _result(res: subprocess.CompletedProcess) -> tuple[int, str, str]:
    return res.returncode, res.stdout, res.stderr


@pytest.fixture
def in_process(workdir, monkeypatch, capfd, warm_imports):
    """``in_process(*args)``: the command line ``args`` run in this process in
    ``workdir`` (:func:`cli_in_process`): (exit status, stdout, stderr)."""
    monkeypatch.chdir(workdir)
    return functools.partial(cli_in_process, capfd)


@pytest.fixture
def cli_call(monkeypatch, capfd, warm_imports):
    """``cli_call(cwd, *args, ranks=0)``: as :func:`cli`, but serially (``ranks = 0``) the
    command runs in this process in ``cwd`` (:func:`cli_in_process`); under ``mpirun -n
    RANKS`` a process per rank as before. Either way a CompletedProcess (returncode,
    stdout, stderr)."""

    def call(cwd: Path, *args: str, ranks: int = 0) -> subprocess.CompletedProcess:
        if ranks:
            return cli(cwd, *args, ranks=ranks)
        monkeypatch.chdir(cwd)
        rc, out, err = cli_in_process(capfd, *args)
        return subprocess.CompletedProcess(["dolfinx_mortar", *args], rc, out, err)

    return call


@pytest.mark.parametrize("command", ["check", "run"])
@pytest.mark.parametrize("case_id", CASE_IDS)
def test_bad_input_serial(workdir, in_process, case_id, command):
    """Every case, in this process (``cli.main``, as ``python3 -m dolfinx_mortar`` calls
    it; what only a process of its own shows: test_bad_input_subprocess)."""
    scene = write_case(workdir, case_id)
    before = snapshot(workdir)
    result = in_process(command, scene.name)
    assert_bad_input(result, case_id, 1, before, workdir)


#: One case of each stage at which input fails, `check` or `run`, run as a process of
#: its own (the module docstring: what the in-process runs do not see).
SUBPROCESS_CASES = [
    ("toml-syntax", "run"),  # the TOML parser
    ("unknown-key", "check"),  # a scene value: the schema
    ("E-zero", "run"),  # a scene value: a range
    ("mesh-corrupt", "check"),  # a mesh that cannot be read
    ("mesh-nan-node", "run"),  # a mesh check
    ("mesh-unnamed-group", "check"),  # a group check
    ("empty-contact-surface", "check"),  # a contact surface, after the forms are compiled
    ("surfaces-share-nodes", "run"),  # the same
    ("penalty-far-beyond-auto", "run"),  # the penalty rule
    ("mesh-generator-too-big", "check"),  # the generator's size
]


@pytest.mark.parametrize("case_id, command", SUBPROCESS_CASES)
def test_bad_input_subprocess(workdir, case_id, command):
    """The same as a process of its own (``python3 -m dolfinx_mortar``, serial)."""
    scene = write_case(workdir, case_id)
    before = snapshot(workdir)
    res = cli(workdir, command, scene.name)
    assert_bad_input(_result(res), case_id, 1, before, workdir)


@pytest.mark.parametrize(
    "case_id, command",
    [
        ("unknown-key", "run"),
        ("missing-group-material", "check"),
        ("mesh-corrupt", "run"),
        ("mesh-nan-node", "check"),
        ("empty-contact-surface", "run"),
        ("surfaces-share-nodes", "run"),
        ("penalty-far-beyond-auto", "check"),
        ("mesh-generator-too-big", "run"),
    ],
)
def test_bad_input_mpirun(workdir, case_id, command):
    """The same under ``mpirun -n 2`` (launched here: this test must not run under mpirun),
    a case of each stage (serially only: unsorted-path, a value that the same
    ``load_scene`` refuses on every rank as unknown-key; mesh-zero-area-cells, found on
    rank 0 by the same ``mesh._check_geometry`` as mesh-nan-node)."""
    scene = write_case(workdir, case_id)
    before = snapshot(workdir)
    res = cli(workdir, command, scene.name, ranks=2)
    assert_bad_input(_result(res), case_id, 2, before, workdir)


def test_bad_input_cold_jit_cache(workdir, tmp_path_factory):
    """An error found after the forms are compiled: with an empty JIT cache the
    compiler's build log must not reach stderr (only the one error line)."""
    scene = write_case(workdir, "empty-contact-surface")
    before = snapshot(workdir)
    cache = tmp_path_factory.mktemp("jit_cache")
    res = cli(workdir, "run", scene.name, XDG_CACHE_HOME=str(cache))
    assert_bad_input(_result(res), "empty-contact-surface", 1, before, workdir)


#: A child that runs the command line's main() on its arguments and prints its exit
#: status and which of the heavy modules it imported.
_MAIN_AND_MODULES = (
    "import sys\n"
    "from dolfinx_mortar.cli import main\n"
    "rc = main(sys.argv[1:])\n"
    "heavy = {'dolfinx', 'gmsh', 'ufl', 'petsc4py', 'dolfinx_mortar.output'}\n"
    "print(rc, sorted(heavy & set(sys.modules)))\n"
)


def _main_and_modules(cwd: Path, *args: str) -> subprocess.CompletedProcess:
    """:data:`_MAIN_AND_MODULES` run on ``args`` in ``cwd`` (a process of its own)."""
    return subprocess.run(
        [sys.executable, "-c", _MAIN_AND_MODULES, *args],
        cwd=cwd,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        stdin=subprocess.DEVNULL,
    )


@pytest.mark.parametrize(
    "case_id, command, extra",
    [
        ("unknown-key", "check", []),
        ("E-zero", "run", []),
        ("toml-syntax", "check", []),
        (None, "run", ["-dm_ksp_rtol", "nan"]),  # the command line's PETSc options
    ],
)
def test_a_scene_error_is_found_before_dolfinx_and_gmsh_are_imported(
    workdir, case_id, command, extra
):
    """A mistake in the scene file or in the command-line PETSc options is answered
    before dolfinx and gmsh are imported (session 57): `check bad.toml` took 1.1 s,
    of which the scene's checks are milliseconds. The same one line, exit 2; dolfinx,
    ufl, PETSc, gmsh and the output module are not in sys.modules after main()."""
    if case_id is None:
        (workdir / "bad.toml").write_text(to_toml(base_scene()))
    else:
        write_case(workdir, case_id)
    before = snapshot(workdir)
    res = _main_and_modules(workdir, command, "bad.toml", *extra)
    where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert res.returncode == 0 and res.stdout == "2 []\n", where
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("dolfinx-mortar: error: "), where
    if case_id is None:
        assert ERROR_LINE.match(lines[0]).group("key") == "solver.petsc.ksp_rtol", where
    elif case_id != "toml-syntax":
        assert ERROR_LINE.match(lines[0]).group("key") == CASE_BY_ID[case_id][2], where
    assert snapshot(workdir) == before


def test_a_mesh_error_imports_dolfinx_after_the_scene(workdir):
    """The other side of the fast path: a scene whose error is in the mesh (a group
    that it lacks) still reads the mesh with dolfinx and gmsh, and says so in one line."""
    write_case(workdir, "missing-group-dirichlet")
    res = _main_and_modules(workdir, "check", "bad.toml")
    where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    heavy = "['dolfinx', 'dolfinx_mortar.output', 'gmsh', 'petsc4py', 'ufl']"
    assert res.returncode == 0 and res.stdout == f"2 {heavy}\n", where
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and ERROR_LINE.match(lines[0]).group("key") == "dirichlet[0].boundary"


def test_missing_scene_file(cli_call, workdir):
    before = snapshot(workdir)
    res = cli_call(workdir, "run", "-vv", "absent.toml")
    where = f"\nstderr:\n{res.stderr}"
    assert res.returncode == 2, where
    assert res.stderr.splitlines() == [
        "dolfinx-mortar: error: cannot read scene file absent.toml: No such file or directory"
    ], where
    assert snapshot(workdir) == before


@pytest.mark.parametrize("where", ["--out", "output.dir"])
def test_output_dir_is_a_file(cli_call, workdir, where):
    """An output directory that cannot be created (a file is in the way) is bad input too."""
    scene = base_scene()
    args = []
    if where == "--out":
        args = ["--out", "out/sentinel.txt"]
    else:
        scene["output"]["dir"] = "out/sentinel.txt/results"
    (workdir / "good.toml").write_text(to_toml(scene))
    before = snapshot(workdir)
    res = cli_call(workdir, "run", "good.toml", *args)
    where_ = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert "Traceback" not in res.stderr, where_
    assert res.returncode == 2, where_
    lines = res.stderr.splitlines()
    assert len(lines) == 1, where_
    m = ERROR_LINE.match(lines[0])
    assert m and m.group("key") == where and "not a directory" in m.group("reason"), where_
    assert snapshot(workdir) == before


@pytest.mark.parametrize(
    "out, reason",
    [
        ("", "empty name"),
        ("../dangling", "a link to nothing"),
        ("/proc/dolfinx_mortar_test", "no such file or directory"),
        ("../looping/results", "too many levels of symbolic links"),
    ],
    ids=["empty", "dangling-link", "cannot-create", "looping-link"],
)
def test_output_dir_that_cannot_be_used(cli_call, workdir, out, reason):
    """Other output directories that cannot be used: one line naming ``--out``, exit 2,
    nothing written (an empty ``--out`` wrote into the working directory; a dangling
    link or a directory that cannot be created gave a traceback after the set-up)."""
    (workdir / "good.toml").write_text(to_toml(base_scene()))
    (workdir.parent / "dangling").symlink_to(workdir / "nowhere" / "at_all")
    (workdir.parent / "looping").symlink_to(workdir.parent / "looping")
    before = snapshot(workdir)
    res = cli_call(workdir, "run", "good.toml", "--out", out)
    _one_error_line(res, 1, "--out", reason)
    assert snapshot(workdir) == before


def test_output_dir_with_a_nul_character(cli_call, workdir):
    """A NUL in ``output.dir`` (TOML's \\u0000; a command line cannot hold one) is one
    error line naming the key, exit 2, nothing written (os calls raise ValueError)."""
    scene = base_scene()
    scene["output"]["dir"] = "res\0ults"
    (workdir / "good.toml").write_text(to_toml(scene))
    before = snapshot(workdir)
    res = cli_call(workdir, "run", "good.toml")
    _one_error_line(res, 1, "output.dir", "the name holds a NUL character")
    assert snapshot(workdir) == before


@pytest.mark.parametrize("ranks", [0, 2], ids=["serial", "mpirun2"])
def test_check_refuses_the_output_dir_that_run_refuses(cli_call, workdir, ranks):
    """``check`` refuses an ``output.dir`` that ``run`` refuses, with the same line on
    every rank, exit 2, nothing written (session 52: ``check`` said ok to a directory
    that is a file); a missing one is created to find out and removed again, and a lock
    that another run holds is no input error for ``check`` (it is for ``run``). On 2
    ranks `check` of the file in the way, of the missing directory, and `run` of the
    held one: `run` of the file in the way and `check` of the held one make the same
    call as those (``check_out_dir``, the lock or not), asserted serially."""
    import fcntl

    n = max(ranks, 1)
    scene = base_scene()
    scene["output"]["dir"] = "afile"
    (workdir / "afile").write_text("x\n")
    (workdir / "s.toml").write_text(to_toml(scene))
    before = snapshot(workdir)
    lines = []
    for command in ("check", "run") if not ranks else ("check",):
        res = cli_call(workdir, command, "s.toml", ranks=ranks)
        _one_error_line(res, n, "output.dir", "it exists and is not a directory")
        lines.append(res.stderr)
    assert len(set(lines)) == 1
    scene["output"]["dir"] = "new/deep/results"
    (workdir / "s.toml").write_text(to_toml(scene))
    before = snapshot(workdir)
    res = cli_call(workdir, "check", "s.toml", ranks=ranks)
    assert res.returncode == 0 and res.stdout.startswith("s.toml: ok"), res.stderr
    assert snapshot(workdir) == before  # nothing left of the directory checked
    (workdir / "held").mkdir()
    scene["output"]["dir"] = "held"
    (workdir / "s.toml").write_text(to_toml(scene))
    with open(workdir / "held" / ".dolfinx_mortar.lock", "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)  # "another run is writing there"
        if not ranks:
            res = cli_call(workdir, "check", "s.toml")
            assert res.returncode == 0 and res.stdout.startswith("s.toml: ok"), res.stderr
        res = cli_call(workdir, "run", "s.toml", ranks=ranks)
        _one_error_line(res, n, "output.dir", "another run is writing there")


#: (id, a file of the run where a directory is, the reason): the output directories that
#: cannot take the run's files
_FILES_IN_THE_WAY = [
    ("summary", "summary.json", "'out/summary.json' is a directory"),
    ("fields-h5", "fields.h5", "'out/fields.h5' is a directory"),
    ("surface-xdmf", "contact_top.xdmf", "'out/contact_top.xdmf' is a directory"),
    ("csv", "contact_top_1.csv", "'out/contact_top_1.csv' is a directory"),
    ("hidden-h5", ".fields.h5", "'out/.fields.h5' is a directory"),  # the live series
    ("read-only", None, "not writable"),
]


@pytest.mark.parametrize(
    "where, reason, ranks",
    [pytest.param(w, r, 0, id=f"serial-{i}") for i, w, r in _FILES_IN_THE_WAY]
    + [
        pytest.param(w, r, 2, id=f"mpirun2-{i}")
        for i, w, r in _FILES_IN_THE_WAY
        if i in ("summary", "read-only")
    ],
)
def test_output_dir_that_cannot_take_the_files(cli_call, workdir, where, reason, ranks):
    """An existing output directory that is not writable, or that holds a directory
    where a file of the run goes, is one error line per rank naming ``--out``, exit 2,
    before the mesh is read (a traceback after the set-up: an HDF5 dump, a
    RuntimeError or an IsADirectoryError, exit 1). Read-only: /proc/1 as root (root
    writes in a chmod 555 directory), a chmod 555 directory otherwise. Rank 0 decides
    (``output.check_out_dir`` broadcasts its reason): on 2 ranks one directory in a
    file's place and the read-only one, every case serially."""
    scene = base_scene()
    scene["contact"] = [_contact()]
    scene["mesh"]["file"] = "absent.msh"  # the mesh is never read
    (workdir / "good.toml").write_text(to_toml(scene))
    out = workdir / "out"
    out.mkdir(exist_ok=True)
    arg = "out"
    if where is not None:
        (out / where).unlink(missing_ok=True)  # the earlier run's file
        (out / where).mkdir()
    elif os.geteuid() == 0:
        arg = "/proc/1"
    else:
        out.chmod(0o555)
    try:
        res = cli_call(workdir, "run", "good.toml", "--out", arg, ranks=ranks)
    finally:
        out.chmod(0o755)
    _one_error_line(res, max(ranks, 1), "--out", reason)


@pytest.mark.parametrize("ranks", [0, 2], ids=["serial", "mpirun2"])
def test_output_dir_that_another_run_holds(cli_call, workdir, ranks):
    """An output directory whose lock another process holds (flock, as a run writing
    there does: conftest.hold_lock) is one error line per rank naming ``--out``, with the
    holder's host, pid and time, exit 2, before the mesh is read, and the lock file is
    left as it was."""
    import socket

    from conftest import hold_lock

    from dolfinx_mortar.output import LOCK_NAME

    scene = base_scene()
    scene["mesh"]["file"] = "absent.msh"  # the mesh is never read
    (workdir / "good.toml").write_text(to_toml(scene))
    out = workdir / "out"
    holder = hold_lock(out)
    try:
        record = (out / LOCK_NAME).read_text()
        res = cli_call(workdir, "run", "good.toml", "--out", "out", ranks=ranks)
    finally:
        holder.kill()
        holder.wait()
    reason = (
        f"cannot use 'out' as output directory: another run is writing there (host "
        f"{socket.gethostname()}, pid {holder.pid}, since 2026-01-01 00:00:00 UTC; lock file "
        f"{LOCK_NAME}): give each run that runs at the same time an output directory of its own"
    )
    _one_error_line(res, max(ranks, 1), "--out", reason)
    assert (out / LOCK_NAME).read_text() == record


def test_usage_errors_are_one_line(cli_call, workdir):
    """argparse's usage errors are one ``dolfinx-mortar: error: command line: ...`` line
    per rank, exit 2 (they printed the usage and a second line). Under mpirun, on 3
    ranks (every rank parses its own command line: one usage error stands for all)."""
    for args, reason in (
        ((), "the following arguments are required: command"),
        (("run",), "the following arguments are required: scene"),
        (("run", "s.toml", "--out"), "argument --out: expected one argument"),
        (("frobnicate",), "invalid choice: 'frobnicate'"),
        # an option of the subcommand before it: where it goes, not the PETSc prefix
        (("-v", "run", "s.toml"), "unrecognized argument -v (an option of `run`: put it after"),
        (("-x", "run", "s.toml"), "unrecognized argument -x (PETSc options of `run` take"),
        # run's own options are not PETSc's
        (("check", "s.toml", "--out", "x"), "argument --out (an option of `run`, not of `check`)"),
        (("check", "s.toml", "-snes_monitor"), "-snes_monitor (PETSc options of `check` take"),
        (("generators", "extra"), "argument extra (`generators` takes no such argument)"),
    ):
        _one_error_line(cli_call(workdir, *args), 1, "command line", reason)
    # every rank prints before any exits (the first to exit made mpirun kill the others:
    # on 3 ranks 5 of 30 such runs lost a line (BENCHMARKS §46), so four runs catch it
    # about one time in two)
    for _ in range(4):
        res = cli_call(workdir, "run", "s.toml", "--bogus", ranks=3)
        _one_error_line(res, 3, "command line", "unrecognized argument --bogus")


def test_a_usage_error_waits_a_bounded_time_for_the_other_ranks(workdir):
    """A rank with a command-line error waits for the others so that every rank prints
    its line, but not for ever: in an MPMD launch the other rank runs another command
    and never joins (a blocking barrier hung there). The bound is 1 s here
    (DOLFINX_MORTAR_USAGE_ERROR_WAIT; 10 s by default: the test waited for it)."""
    mpirun = shutil.which("mpirun")
    py = [sys.executable, "-m", "dolfinx_mortar"]
    cmd = [mpirun, "-q", "-n", "1", *py, "run", "--bogus", ":", "-n", "1", *py, "generators"]
    env = _env(DOLFINX_MORTAR_USAGE_ERROR_WAIT="1")
    res = subprocess.run(cmd, cwd=workdir, env=env, capture_output=True, text=True, timeout=TIMEOUT)
    assert res.returncode == 2, res.stderr
    assert "dolfinx-mortar: error: command line:" in res.stderr, res.stderr


def test_the_usage_error_wait_is_read_from_the_environment(monkeypatch):
    """DOLFINX_MORTAR_USAGE_ERROR_WAIT sets the bound of the wait above (seconds, >= 0);
    unset, or not such a number, the bound is cli_module.USAGE_ERROR_WAIT."""
    from dolfinx_mortar import cli as cli_module

    monkeypatch.delenv("DOLFINX_MORTAR_USAGE_ERROR_WAIT", raising=False)
    assert cli_module._usage_error_wait() == cli_module.USAGE_ERROR_WAIT == 10.0
    for text, seconds in (("1", 1.0), ("0", 0.0), ("2.5", 2.5)):
        monkeypatch.setenv("DOLFINX_MORTAR_USAGE_ERROR_WAIT", text)
        assert cli_module._usage_error_wait() == seconds, text
    for text in ("", "soon", "-1", "nan", "inf"):
        monkeypatch.setenv("DOLFINX_MORTAR_USAGE_ERROR_WAIT", text)
        assert cli_module._usage_error_wait() == cli_module.USAGE_ERROR_WAIT, text


def test_petsc_errors_in_the_solve_stop_the_run(cli_call, workdir):
    """PETSc options that PETSc accepts at set-up but refuses in the solve stop the run
    cleanly (exit 1, summary.json "failed" with PETSc's reason, no traceback; they gave a
    traceback); an option PETSc never read is named in a warning."""
    scene = base_scene()
    scene["solver"] = {"petsc": {"mat_mumps_icntl_7": 99}}  # not an ordering MUMPS has
    scene["output"]["dir"] = "bad_petsc"
    (workdir / "s.toml").write_text(to_toml(scene))
    for ranks in (0, 2):
        res = cli_call(workdir, "run", "s.toml", ranks=ranks)
        where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
        assert res.returncode == 1 and "Traceback" not in res.stderr, where
        summary = json.loads((workdir / "bad_petsc" / "summary.json").read_text())
        assert summary["status"] == "failed" and summary["steps"] == [], summary
        assert "PETSc failed in the solve" in summary["error"], summary["error"]
        assert "Valid values are 0=AMD" in summary["error"], summary["error"]
        assert summary["timings"]["unfinished"] > 0.0, summary["timings"]  # docs/scenes.md
        # one line says why, on rank 0 (the runner logged it once more on every rank)
        assert res.stderr.count(summary["error"]) == 1, where
    scene["solver"] = {"petsc": {"snes_monitr": True}}
    scene["output"]["dir"] = "typo"
    (workdir / "s.toml").write_text(to_toml(scene))
    res = cli_call(workdir, "run", "s.toml")
    assert res.returncode == 0, res.stderr
    assert "PETSc never read the option(s) -dm_snes_monitr" in res.stderr, res.stderr


def test_interior_contact_surface(cli_call, workdir):
    """A contact surface made of interior facets (shared by two cells) is unusable."""
    scene = base_scene("inner.msh")
    scene["kinematics"] = "finite"
    scene["material"][0]["model"] = "neo-hookean"
    scene["dirichlet"][0]["boundary"] = "top"
    del scene["traction"]
    scene["contact"] = [{"slave": "inner", "master": "top"}]
    (workdir / "bad.toml").write_text(to_toml(scene))
    before = snapshot(workdir)
    res = cli_call(workdir, "check", "bad.toml")
    where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert "Traceback" not in res.stderr, where
    assert res.returncode == 2, where
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and ERROR_LINE.match(lines[0]), where
    assert ERROR_LINE.match(lines[0]).group("key") == "contact[0].slave", where
    assert snapshot(workdir) == before


def test_verbosity_flags():
    """-v gives INFO, -vv DEBUG (as the help says): the flag counts."""
    from dolfinx_mortar.cli import _parser

    assert _parser().parse_args(["run", "s.toml"]).verbose == 0
    assert _parser().parse_args(["run", "-v", "s.toml"]).verbose == 1
    assert _parser().parse_args(["run", "-vv", "s.toml"]).verbose == 2


@pytest.mark.parametrize("flag,levels", [("", set()), ("-v", {"INFO"}), ("-vv", {"INFO", "DEBUG"})])
def test_verbosity_reaches_the_log(cli_call, workdir, flag, levels):
    """-v and -vv change what the run logs on stderr (importing dolfinx puts a handler on
    the root logger first: without ``force`` the flags printed nothing); without them,
    nothing but the step lines on stdout. The flags in a process of their own (the
    handler that dolfinx's import puts on its root logger: this process's runs set
    pytest's aside), no flag in this process."""
    (workdir / "good.toml").write_text(to_toml(base_scene()))
    res = cli(workdir, "run", flag, "good.toml") if flag else cli_call(workdir, "run", "good.toml")
    assert res.returncode == 0, res.stderr
    found = set(re.findall(r"^\[(INFO|DEBUG) dolfinx_mortar[.\w]*\] ", res.stderr, re.M))
    assert found == levels, res.stderr
    if not flag:
        assert res.stderr == "", res.stderr


def _signal_a_long_run(workdir: Path, signum: int) -> tuple[int, str]:
    """Run the base scene in 400 steps, with displacement fields, from the command line
    in ``workdir`` (out/), send it ``signum`` once it has printed 3 step lines, and return
    its exit status and stderr. The child starts with SIGINT at its default: a
    pytest-xdist worker ignores SIGINT, and a child that starts so keeps ignoring it."""
    import signal

    scene = base_scene()
    scene["steps"]["n"] = 400
    scene["output"]["fields"] = ["displacement"]
    (workdir / "long.toml").write_text(to_toml(scene))
    proc = subprocess.Popen(
        [sys.executable, "-m", "dolfinx_mortar", "run", "long.toml"],
        cwd=workdir,
        env=_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        seen = 0
        for line in proc.stdout:
            seen += line.startswith("step")
            if seen == 3:
                proc.send_signal(signum)
                break
        _, err = proc.communicate(timeout=TIMEOUT)
    finally:
        proc.kill()
    return proc.returncode, err


def test_a_killed_run_keeps_the_fields_of_its_finished_steps(workdir):
    """A run killed between steps (a batch job's time limit: SIGKILL) keeps every step it
    finished in fields.xdmf / fields.h5, as SCENES.md promises: the HDF5 file is closed
    after each step. It was left open, and its superblock was still empty when the run
    died, so no field of any step could be read."""
    import signal

    from dolfinx import io
    from mpi4py import MPI

    _signal_a_long_run(workdir, signal.SIGKILL)
    out = workdir / "out"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "running" and len(summary["steps"]) >= 3, summary["status"]
    assert (out / "fields.h5").read_bytes()[:8] == b"\x89HDF\r\n\x1a\n"
    with io.XDMFFile(MPI.COMM_SELF, str(out / "fields.xdmf"), "r") as f:
        mesh = f.read_mesh(name="mesh")
    assert mesh.topology.index_map(mesh.topology.dim).size_local > 0
    times = re.findall(r'<Time Value="([^"]+)"', (out / "fields.xdmf").read_text())
    assert len(times) >= len(summary["steps"]) + 1, times  # step 0 and every finished step


def test_the_sigint_handler_survives_import_and_mesh_loading(tmp_path):
    """gmsh 4.8 sets SIGINT to SIG_DFL when it is imported and, when it finalizes, to the
    handler it saw then: Ctrl-C killed the process with no KeyboardInterrupt (summary.json
    left "running"), and a host program's handler was replaced. Both now keep the
    handler in force (a fresh process: gmsh must not be imported yet). gmsh is imported
    by the mesh loading, not by the modules' import (it was, through compat, before
    session 57)."""
    code = (
        "import signal, sys\n"
        "def host(signum, frame): pass\n"
        "signal.signal(signal.SIGINT, host)\n"
        "from mpi4py import MPI\n"
        "from dolfinx_mortar.mesh import load_mesh\n"
        "import dolfinx_mortar.output, dolfinx_mortar.problem\n"
        "assert 'gmsh' not in sys.modules, 'imported with the modules'\n"
        "assert signal.getsignal(signal.SIGINT) is host, 'import'\n"
        "load_mesh(MPI.COMM_SELF, generator='patch2d', params={'n_lower': 2, 'n_upper': 3})\n"
        "assert 'gmsh' in sys.modules\n"
        "assert signal.getsignal(signal.SIGINT) is host, 'load_mesh'\n"
        "print('kept')\n"
    )
    res = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=_env(), capture_output=True, text=True
    )
    assert res.returncode == 0 and res.stdout.strip() == "kept", res.stderr


def _run_host_program(code: str, cwd: Path) -> None:
    """Run ``code``, a host program, in a fresh Python process in ``cwd`` (``sys.argv[1]``
    is the tests' directory, for conftest's scenes): it must exit 0 and print a line
    that starts with "ran"."""
    res = subprocess.run(
        [sys.executable, "-c", code, str(Path(__file__).parent)],
        cwd=cwd,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0 and res.stdout.startswith("ran"), res.stderr[-3000:]


def test_a_host_whose_warnings_are_errors_runs_a_scene(tmp_path):
    """A host program that turns warnings into errors (``warnings.simplefilter("error")``,
    as a test suite's ``filterwarnings = error`` does) runs a frictional scene, and its
    warning filters stay as they were. numba, which a run imports on first use, imports
    llvmlite, whose import (Debian bookworm's 0.39 on Python 3.11) warns
    ``DeprecationWarning: path is deprecated. Use files() instead``: the run raised it with
    a traceback from deep inside the contact module (session 58). A fresh process: numba
    must not be imported yet."""
    code = (
        "import sys, warnings\n"
        "sys.path.insert(0, sys.argv[1])\n"
        "from conftest import patch_press_scene\n"
        "from mpi4py import MPI\n"
        "from dolfinx_mortar import parse_scene, run\n"
        "assert 'numba' not in sys.modules, 'imported with the package'\n"
        "warnings.simplefilter('error')\n"
        "filters = list(warnings.filters)\n"
        "scene = parse_scene(patch_press_scene(steps=1, friction=0.3), '.')\n"
        "summary = run(scene, MPI.COMM_SELF, out_dir='out')\n"
        "assert summary['status'] == 'ok', summary['error']\n"
        "assert 'numba' in sys.modules\n"
        "assert warnings.filters == filters, 'the host filters changed'\n"
        "print('ran', summary['steps'][-1]['contact_force'])\n"
    )
    _run_host_program(code, tmp_path)


def test_a_host_runs_scenes_in_a_worker_thread(tmp_path):
    """A host program that runs scenes outside its main thread (a thread pool, a GUI's
    worker): the runs complete, a generator's and a mesh file's, with gmsh imported
    there first, and the main thread's SIGINT handler stays. gmsh 4.8's module calls
    ``signal.signal`` when it is imported and in ``gmsh.finalize``, which Python allows
    in the main thread only: the first run raised ValueError "signal only works in main
    thread of the main interpreter" from the import, and every later one from the
    finalize (session 58). A fresh process: gmsh must not be imported yet."""
    code = (
        "import signal, sys\n"
        "from concurrent.futures import ThreadPoolExecutor\n"
        "sys.path.insert(0, sys.argv[1])\n"
        "from conftest import patch_press_scene\n"
        "from mpi4py import MPI\n"
        "from dolfinx_mortar import parse_scene, run\n"
        "def host(signum, frame): pass\n"
        "signal.signal(signal.SIGINT, host)\n"
        "assert 'gmsh' not in sys.modules, 'imported with the package'\n"
        "def go(k):\n"
        "    data = patch_press_scene(steps=1)\n"
        "    if k == 1:  # the same mesh from a file (written here, in the main thread)\n"
        "        data['mesh'] = {'file': 'patch.msh'}\n"
        "    return run(parse_scene(data, '.'), MPI.COMM_SELF, out_dir=f'out{k}')\n"
        "with ThreadPoolExecutor(1) as pool:\n"
        "    first = pool.submit(go, 0).result()\n"
        "    assert 'gmsh' in sys.modules\n"
        "    import gmsh\n"
        "    from dolfinx_mortar import generators\n"
        "    from dolfinx_mortar.gmsh_session import gmsh_model\n"
        "    with gmsh_model(gmsh):\n"
        "        generators.build('patch2d', {'n_lower': 2, 'n_upper': 3, 'n_y': 1})\n"
        "        gmsh.write('patch.msh')\n"
        "    second = pool.submit(go, 1).result()\n"
        "assert signal.getsignal(signal.SIGINT) is host, 'SIGINT'\n"
        "forces = [s['steps'][-1]['contact_force'] for s in (first, second)]\n"
        "assert [s['status'] for s in (first, second)] == ['ok', 'ok'], forces\n"
        "print('ran', forces)\n"
    )
    _run_host_program(code, tmp_path)


def test_ctrl_c_stops_a_run_in_one_line(workdir):
    """SIGINT (Ctrl-C) in a run: exit status 130, one line and no traceback, and
    summary.json says "failed", "interrupted by KeyboardInterrupt", with the finished
    steps, whose fields stay readable. (gmsh had set SIG_DFL: the process died at once,
    summary.json left "running".)"""
    import signal

    returncode, err = _signal_a_long_run(workdir, signal.SIGINT)
    assert returncode == 130, err
    assert err.splitlines() == [
        "dolfinx-mortar: interrupted: summary.json keeps the finished steps"
    ], err
    summary = json.loads((workdir / "out" / "summary.json").read_text())
    assert summary["status"] == "failed", summary["status"]
    assert summary["error"].startswith("interrupted by KeyboardInterrupt")
    assert len(summary["steps"]) >= 3
    times = re.findall(r'<Time Value="([^"]+)"', (workdir / "out" / "fields.xdmf").read_text())
    assert len(times) >= len(summary["steps"]) + 1, times


def _terminate_a_long_run(workdir: Path, ranks: int, target: str, steps: int):
    """Run the patch press in ``steps`` steps (CSVs and displacement fields) from the command
    line in ``workdir`` (out/), serially or under ``mpirun -q -n RANKS``, send SIGTERM
    once summary.json holds a step: to the python processes (``target = "ranks"``, as
    SLURM does at a time limit) or to mpirun (``"mpirun"``: Open MPI passes it on to the
    ranks as SIGTERM ``odls_base_sigkill_timeout`` seconds later, 5 here, and SIGKILL as
    long after that; the ranks' output goes to ``rank_<R>.out`` and ``.err``). Returns
    the exit status and the standard error (rank 0's file for ``"mpirun"``)."""
    import signal
    import time

    scene = patch_press_scene(steps=steps)
    scene["output"] = {"dir": "out", "fields": ["displacement", "contact_pressure"]}
    (workdir / "long.toml").write_text(to_toml(scene))
    cmd = [sys.executable, "-m", "dolfinx_mortar", "run", "long.toml"]
    if ranks and target == "mpirun":
        # as README advises for a signalled mpirun: the ranks' output to files (mpirun
        # stops forwarding it once signalled, and a rank that prints then blocks in its
        # write until SIGKILL), and time between its SIGTERM and SIGKILL to the ranks
        line = (
            " ".join(cmd)
            + ' > rank_"$OMPI_COMM_WORLD_RANK".out 2> rank_"$OMPI_COMM_WORLD_RANK".err'
        )
        cmd = ["--mca", "odls_base_sigkill_timeout", "5", "-n", str(ranks)]
        cmd = [shutil.which("mpirun"), "-q", *cmd, "sh", "-c", f"exec {line}"]
    elif ranks:
        cmd = [shutil.which("mpirun"), "-q", "-n", str(ranks), *cmd]
    proc = subprocess.Popen(
        cmd,
        cwd=workdir,
        env=_env(),
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
        # a run keeps an ignored SIGTERM ignored: the child starts with the default
        preexec_fn=lambda: signal.signal(signal.SIGTERM, signal.SIG_DFL),
    )
    try:
        summary, deadline = workdir / "out" / "summary.json", time.monotonic() + TIMEOUT
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                if json.loads(summary.read_text())["steps"]:
                    break
            except (OSError, ValueError):  # not there yet, or replaced meanwhile
                pass
            time.sleep(0.01)
        pids = [proc.pid]
        if ranks and target == "ranks":
            found = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True)
            pids = [int(p) for p in found.stdout.split()]
            assert len(pids) == ranks, found
        for pid in pids:
            os.kill(pid, signal.SIGTERM)
        _, err = proc.communicate(timeout=TIMEOUT)
        if ranks and target == "mpirun":
            err = (workdir / "rank_0.err").read_text()
        return proc.returncode, err
    finally:
        proc.kill()


@pytest.mark.parametrize(
    "ranks,target",
    [(0, "ranks"), (2, "ranks"), (2, "mpirun")],
    ids=["serial", "mpirun2", "to-mpirun"],
)
def test_sigterm_stops_a_run_cleanly(workdir, ranks, target):
    """SIGTERM (a batch scheduler's time limit, docker stop, Ctrl-C under mpirun) killed
    the run at once: exit status 143 (serial; mpirun: 1), summary.json left "running",
    and under mpirun the CSV of the step being written could be there without its record.
    Now the ranks stop together at the next Newton iteration: exit status 143 (mpirun's own
    is 1 when it was signalled), one line, summary.json "failed" with the step, and every
    file of the finished steps (none of the abandoned one), the series closed."""
    # to mpirun: with Open MPI's defaults a rank that printed a step line after mpirun was
    # signalled blocked in that write (the output is no longer forwarded) and died by the
    # SIGKILL a second after its SIGTERM: "running" (a loaded machine showed it; README);
    # a summary that says "failed" shows that the ranks stopped before their SIGKILL
    n = 3000 if target == "mpirun" else 300  # still running when the ranks get SIGTERM
    returncode, err = _terminate_a_long_run(workdir, ranks, target, n)
    out = workdir / "out"
    summary = json.loads((out / "summary.json").read_text())
    steps = summary["steps"]
    k = len(steps) + 1
    expected = (
        f"terminated by SIGTERM during step {k}; steps 1..{k - 1} kept (to t = {steps[-1]['t']:g})"
    )
    assert summary["status"] == "failed" and summary["error"] == expected, summary["error"]
    assert 1 <= len(steps) < n
    assert [s["t"] for s in steps] == pytest.approx([i / n for i in range(1, k)], rel=1e-12)
    assert returncode == (1 if target == "mpirun" else 143), err
    assert err.splitlines() == [f"dolfinx-mortar: {expected}"], err
    csv = sorted(int(f.stem.rsplit("_", 1)[1]) for f in out.glob("contact_*.csv"))
    assert csv == list(range(k)), csv  # step 0 and the finished steps, not step k
    times = re.findall(r'<Time Value="([^"]+)"', (out / "fields.xdmf").read_text())
    assert sorted({float(t) for t in times}) == pytest.approx([0.0] + [s["t"] for s in steps])
    assert not list(out.glob(".*")), list(out.glob(".*"))  # finished: no hidden series


def test_ctrl_c_before_the_first_step_says_so(cli_call, workdir):
    """A Ctrl-C before the steps began (here: raised by a --laws file) said that
    summary.json keeps the finished steps, where there was no summary.json of this run."""
    (workdir / "good.toml").write_text(to_toml(base_scene()))
    (workdir / "interrupt.py").write_text("raise KeyboardInterrupt\n")
    res = cli_call(workdir, "run", "good.toml", "--laws", "interrupt.py", "--out", "never")
    assert res.returncode == 130, res.stderr
    assert res.stderr.splitlines() == ["dolfinx-mortar: interrupted before the first load step"]
    assert not (workdir / "never").exists()


# --------------------------------------------------------------------------- good input


@pytest.mark.parametrize("ranks", [0, 2])
def test_generators(cli_call, tmp_path, ranks):
    """The list of generators, once (rank 0 only under mpirun: it was once per rank)."""
    res = cli_call(tmp_path, "generators", ranks=ranks)
    assert res.returncode == 0, res.stderr
    assert len(re.findall(r"^hertz2d: ", res.stdout, re.M)) == 1, res.stdout
    assert res.stderr == ""


@pytest.mark.parametrize("ranks", [0, 2])
def test_version(cli_call, tmp_path, ranks):
    """``--version``: one line on stdout (rank 0 only under mpirun), exit 0."""
    import dolfinx

    import dolfinx_mortar

    res = cli_call(tmp_path, "--version", ranks=ranks)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert len(lines) == 1, res.stdout
    assert lines[0].startswith(f"dolfinx-mortar {dolfinx_mortar.__version__} (")
    assert f"dolfinx {dolfinx.__version__}" in lines[0] and "petsc 3." in lines[0]


def test_check_ok(workdir, tmp_path_factory):
    (workdir / "good.toml").write_text(to_toml(base_scene()))
    before = snapshot(workdir)
    # cold JIT cache: nothing but the ok line, not even the compiler's build log
    cache = tmp_path_factory.mktemp("jit_cache")
    res = cli(workdir, "check", "good.toml", XDG_CACHE_HOME=str(cache))
    assert res.returncode == 0, res.stderr
    assert res.stderr == ""
    lines = res.stdout.splitlines()
    assert len(lines) == 1 and re.match(r"^good\.toml: ok \(2D, triangle P1, \d+ dofs", lines[0])
    assert snapshot(workdir) == before


def test_check_names_each_pair_s_rule(cli_call, workdir):
    """`check` prints, under its ok line, a line per contact pair with what the scene left
    to the defaults as the run will take it: the integration and its quadrature rule (on
    P1 tetrahedra degree 12 for a frictionless element pair, 4 with friction: contact.
    default_quadrature_degree), the recovery, the friction, the penalty (the auto rule
    and its range over the slave nodes, or the scene's number) and the slave facets, the
    same as summary.json's ``modelled.contact_pairs``."""
    scene = patch_press_scene()
    scene["mesh"] = {
        "generator": "patch3d",
        "params": {"n_lower": 2, "n_upper": 3, "n_y": 1, "quads": False},
    }
    scene["dirichlet"] = [
        {"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]},
        {"boundary": "upper_top", "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, -0.01]]},
    ]
    (workdir / "tets.toml").write_text(to_toml(scene))
    scene["contact"][0].update(friction=0.3, penalty=1000.0)
    (workdir / "friction.toml").write_text(to_toml(scene))
    lines = {}
    for name in ("tets", "friction"):
        res = cli_call(workdir, "check", f"{name}.toml")
        assert res.returncode == 0 and res.stderr == "", res.stderr
        lines[name] = res.stdout.splitlines()
        assert len(lines[name]) == 2, res.stdout
        assert lines[name][0].startswith(f"{name}.toml: ok (3D, tetrahedron P1, ")
    head = "  upper_bottom:lower_top: element integration "
    assert re.fullmatch(
        re.escape(head + "(degree 12, 33 points per slave facet), lumped recovery, "
                  "frictionless, penalty auto: 100 E*/h_I = ") + r"[0-9.e+]+( … [0-9.e+]+)?, "
        r"\d+ slave facets",
        lines["tets"][1],
    ), lines["tets"][1]  # fmt: skip
    assert lines["friction"][1].startswith(
        head + "(degree 4, 6 points per slave facet), lumped recovery, friction 0.3, "
        "penalty 1e+03, "
    ), lines["friction"][1]


def test_run_ok(cli_call, workdir):
    scene = base_scene()
    scene["output"]["dir"] = "fresh/results"
    (workdir / "good.toml").write_text(to_toml(scene))
    res = cli_call(workdir, "run", "good.toml")
    assert res.returncode == 0, res.stderr
    assert "Traceback" not in res.stderr
    summary = json.loads((workdir / "fresh" / "results" / "summary.json").read_text())
    assert summary["status"] == "ok" and summary["error"] is None
    assert summary["ranks"] == 1
    assert summary["modelled"]["kinematics"] == "small"
    import dolfinx_mortar

    assert summary["versions"]["dolfinx_mortar"] == dolfinx_mortar.__version__
    assert set(summary["versions"]) == {
        "dolfinx_mortar",
        "dolfinx",
        "petsc",
        "mpi",
        "numpy",
        "python",
    }
    assert [s["t"] for s in summary["steps"]] == [1.0]
    assert all(s["converged"] for s in summary["steps"])
    assert (workdir / "fresh" / "results" / "fields.xdmf").is_file()


LAWS_FILE = """
import ufl
from dolfinx_mortar import register_law
from dolfinx_mortar.bulk import lame


def psi(F, E, nu):  # the compressible neo-Hookean law of bulk.py, written by hand
    lm, mu = lame(E, nu)
    J = ufl.det(F)
    I1 = ufl.tr(F.T * F) + (1.0 if F.ufl_shape[0] == 2 else 0.0)
    return mu / 2 * (I1 - 3 - 2 * ufl.ln(J)) + lm / 2 * ufl.ln(J) ** 2


register_law("hand-neo-hooke", psi, replace=True)
"""


def _one_error_line(res, ranks: int, key: str, reason: str) -> None:
    where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert res.returncode == 2 and "Traceback" not in res.stderr, where
    lines = res.stderr.splitlines()
    assert len(lines) == ranks and len(set(lines)) == 1, where
    m = ERROR_LINE.match(lines[0])
    assert m and m.group("key") == key and reason in m.group("reason"), where


@pytest.mark.parametrize("ranks", [0, 2], ids=["serial", "mpirun2"])
def test_laws_file(cli_call, workdir, ranks):
    """``--laws FILE`` runs a Python file that registers a law on every rank, so that a
    scene run from the command line can name it; without it, or with a file that is
    missing or raises, the scene is one error line per rank, exit status 2.

    On 2 ranks: the run with the law (the file run on every rank), a file that raises on
    every rank, one that raises on rank 1 only and one that registers the law on rank 0
    only (the scene's reading is collective too). The other refusals, asserted serially,
    are a SceneError raised on every rank by the same calls: a file that is missing, a
    directory or exits, as the one that raises (``_on_every_rank(comm, load_laws,
    path)``), and a law that no file registered by the scene's reading, as
    test_bad_input_mpirun[unknown-key-run]; `check` with the file runs the same
    ``load_laws`` as `run` (a `check` that says ok on 2 ranks:
    test_check_refuses_the_output_dir_that_run_refuses[mpirun2])."""
    (workdir / "laws.py").write_text(LAWS_FILE)
    (workdir / "broken.py").write_text("raise RuntimeError('no such law\\nhere')\n")
    scene = base_scene()
    scene["kinematics"] = "finite"
    scene["material"][0]["model"] = "hand-neo-hooke"
    scene["output"]["dir"] = "law_out"
    (workdir / "law.toml").write_text(to_toml(scene))
    n = max(ranks, 1)
    if not ranks:
        res = cli_call(workdir, "check", "law.toml", "--laws", "laws.py")
        assert res.returncode == 0, res.stderr
        assert res.stdout.startswith("law.toml: ok (2D")
        # a file named twice runs once (its second run registered another function: an
        # error)
        res = cli_call(workdir, "check", "law.toml", "--laws", "laws.py", "--laws", "laws.py")
        assert res.returncode == 0 and res.stdout.startswith("law.toml: ok (2D"), res.stderr
    res = cli_call(workdir, "run", "law.toml", "--laws", "laws.py", ranks=ranks)
    assert res.returncode == 0, res.stderr
    summary = json.loads((workdir / "law_out" / "summary.json").read_text())
    assert summary["status"] == "ok" and summary["ranks"] == n
    assert summary["modelled"]["materials"] == {"body": "hand-neo-hooke"}
    assert summary["modelled"]["laws"]["hand-neo-hooke"].endswith(".psi (laws.py)")
    if not ranks:
        res = cli_call(workdir, "run", "law.toml")
        _one_error_line(res, n, "material[0].model", "dolfinx_mortar.register_law")
        res = cli_call(workdir, "check", "law.toml", "--laws", "missing.py")
        _one_error_line(res, n, "--laws", "file not found: missing.py")
        (workdir / "lawdir").mkdir()  # session 52: it said "file not found"
        res = cli_call(workdir, "check", "law.toml", "--laws", "lawdir")
        _one_error_line(res, n, "--laws", "lawdir is a directory, not a Python file")
        (workdir / "quits.py").write_text("import sys\nsys.exit(0)\n")
        res = cli_call(workdir, "run", "law.toml", "--laws", "quits.py")
        _one_error_line(res, n, "--laws", "quits.py failed: SystemExit: 0")
    res = cli_call(workdir, "run", "law.toml", "--laws", "broken.py", ranks=ranks)
    _one_error_line(res, n, "--laws", "broken.py failed: RuntimeError: no such law here")
    if ranks:  # a file that fails on one rank only: every rank reports it, none waits
        (workdir / "rank1.py").write_text(
            "from mpi4py import MPI\n"
            "if MPI.COMM_WORLD.rank == 1:\n    raise RuntimeError('only here')\n"
        )
        res = cli_call(workdir, "check", "law.toml", "--laws", "rank1.py", ranks=ranks)
        _one_error_line(res, n, "--laws", "RuntimeError: only here (on rank 1)")
        # a law registered on rank 0 only: the scene is valid there and not on rank 1;
        # rank 0 went on into the mesh's collectives and the run hung (QA, session 65)
        (workdir / "rank0.py").write_text(
            "from mpi4py import MPI\n"
            "if MPI.COMM_WORLD.rank == 0:\n    exec(open('laws.py').read())\n"
        )
        res = cli_call(workdir, "run", "law.toml", "--laws", "rank0.py", ranks=ranks)
        _one_error_line(res, n, "material[0].model", "register_law) (on rank 1)")


def test_run_not_converging(cli_call, workdir):
    """Newton cannot converge: exit 1, summary.json says failed with an error, step 0 kept."""
    scene = base_scene()
    scene["kinematics"] = "finite"
    scene["material"][0]["model"] = "neo-hookean"
    del scene["traction"]
    scene["dirichlet"].append(
        {"boundary": "right", "components": [0], "path": [[0.0, 0.0], [1.0, 1.0]]}
    )
    scene["steps"] = {"n": 1, "max_cutbacks": 1}
    scene["solver"] = {"max_it": 1, "rtol": 1e-14}
    scene["output"]["dir"] = "failed"
    (workdir / "stretch.toml").write_text(to_toml(scene))
    res = cli_call(workdir, "run", "stretch.toml")
    where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert res.returncode == 1, where
    assert "Traceback" not in res.stderr, where
    assert "dolfinx-mortar: run failed: " in res.stderr, where
    out = workdir / "failed"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed"
    assert isinstance(summary["error"], str) and summary["error"]
    assert summary["steps"] == []
    xdmf = (out / "fields.xdmf").read_text()
    assert '<Time Value="0"' in xdmf
    assert (out / "fields.h5").stat().st_size > 0


def test_petsc_options_flag_and_rejected_value(cli_call, workdir):
    """[solver.petsc]: a boolean true is a bare flag (-dm_snes_monitor works), a boolean
    false leaves the option out (no warning that PETSc never read it); a value
    PETSc rejects (a viewer named "true") is one clear error naming solver.petsc, and
    the earlier output is left as it was."""
    scene = base_scene()
    scene["solver"] = {"petsc": {"snes_monitor": True}}
    (workdir / "flag.toml").write_text(to_toml(scene))
    res = cli_call(workdir, "run", "flag.toml", "--out", "flag_out")
    assert res.returncode == 0, res.stderr
    assert "SNES Function norm" in res.stdout
    # a boolean false leaves the option out (it was passed as the viewer name "false")
    scene["solver"] = {"petsc": {"snes_monitor": False, "ksp_converged_reason": False}}
    (workdir / "off.toml").write_text(to_toml(scene))
    res = cli_call(workdir, "run", "off.toml", "--out", "off_out")
    assert res.returncode == 0 and not res.stderr, res.stderr
    assert "SNES Function norm" not in res.stdout
    scene["solver"] = {"petsc": {"snes_monitor": "true"}}
    (workdir / "bad.toml").write_text(to_toml(scene))
    before = snapshot(workdir)
    res = cli_call(workdir, "run", "bad.toml")
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    (line,) = res.stderr.splitlines()
    m = ERROR_LINE.match(line)
    assert m and m.group("key") == "solver.petsc.snes_monitor", line
    assert m.group("reason") == "PETSc rejected 'true': Unsupported viewer true", line
    assert snapshot(workdir) == before


#: [solver.petsc] options the solver refuses: (option, a bad value in the scene, its
#: error, a bad value on the command line (-dm_...), its error, the key named)
REFUSED_PETSC_OPTIONS = [
    # PETSc takes any number: a cap <= 0 ran "ok" with more Newton iterations
    ("snes_linesearch_maxstep", -1.0, "must be > 0, got -1", "0", "must be > 0, got 0"),
    # silently ignored: the solver sets them from [solver] rtol and atol on every solve,
    # and PETSc counted them as read
    ("snes_atol", 1e-3, "set by [solver] atol", "1", "set by [solver] atol"),
    ("snes_rtol", 1e-3, "set by [solver] rtol", "-1", "set by [solver] rtol"),
    # honoured in a step's first solve only: the continuations went on to [solver] max_it
    ("snes_max_it", 1, "set by [solver] max_it", "-1", "set by [solver] max_it"),
    # one linear solve, no residual history: every step stopped on an IndexError (no
    # residual norm), with a traceback and summary.json left "running"
    ("snes_type", "ksponly", "'ksponly' solves one", "ksponly", "contact is nonlinear"),
]


@pytest.mark.parametrize(
    ("option", "value", "reason", "cli_value", "cli_reason"),
    REFUSED_PETSC_OPTIONS,
    ids=[o[0] for o in REFUSED_PETSC_OPTIONS],
)
def test_refused_solver_petsc_options(
    cli_call, workdir, option, value, reason, cli_value, cli_reason
):
    """Options of [solver.petsc] that the solver refuses, in the scene (`run` and `check`)
    or on the command line: one error line per rank naming the key, exit 2, nothing
    written. `run` of the scene on 2 ranks for one option of each branch of
    ``NewtonSolver._refused_option`` (local: each rank finds the same), serially for
    the others (snes_rtol, snes_max_it: snes_atol's branch)."""
    scene = base_scene()
    scene["solver"] = {"petsc": {option: value}}
    (workdir / "bad.toml").write_text(to_toml(scene))
    scene["solver"] = {}
    (workdir / "good.toml").write_text(to_toml(scene))
    before = snapshot(workdir)
    key = f"solver.petsc.{option}"
    ranks = 2 if option in ("snes_linesearch_maxstep", "snes_atol", "snes_type") else 0
    _one_error_line(cli_call(workdir, "run", "bad.toml", ranks=ranks), max(ranks, 1), key, reason)
    _one_error_line(cli_call(workdir, "check", "bad.toml"), 1, key, reason)  # said "ok"
    res = cli_call(workdir, "run", "good.toml", f"-dm_{option}", cli_value)
    _one_error_line(res, 1, key, cli_reason)
    assert snapshot(workdir) == before


@pytest.mark.parametrize(
    ("option", "value", "reason"),
    [
        ("snes_max_it", "99999999999", "must be at most 2147483647 in magnitude (a C int)"),
        ("ksp_rtol", "nan", "must be a finite number, got nan"),
    ],
)
def test_command_line_petsc_numbers_obey_the_scene_rules(cli_call, workdir, option, value, reason):
    """-dm_snes_max_it 99999999999 wrapped in PETSc and -dm_ksp_rtol nan was taken (the
    scene refuses both): one error line per rank naming the key, exit 2, nothing
    written (session 52). The first on 2 ranks, the second serially (the same
    ``scene.petsc_value``, local on every rank)."""
    (workdir / "good.toml").write_text(to_toml(base_scene()))
    before = snapshot(workdir)
    ranks = 2 if option == "snes_max_it" else 0
    res = cli_call(workdir, "run", "good.toml", f"-dm_{option}", value, ranks=ranks)
    _one_error_line(res, max(ranks, 1), f"solver.petsc.{option}", reason)
    assert snapshot(workdir) == before


@pytest.mark.parametrize("value", ["nonexistent_ksp", "pre only"])
def test_check_validates_the_petsc_options(cli_call, workdir, value):
    """`check` sets the solver up as `run` does (without solving): a KSP type PETSc does
    not know is the same error line as `run`'s, exit 2 (check said "ok")."""
    scene = base_scene()
    scene["solver"] = {"petsc": {"ksp_type": value}}
    (workdir / "bad.toml").write_text(to_toml(scene))
    reason = f"Unable to find requested KSP type {value}"
    res = cli_call(workdir, "check", "bad.toml")
    _one_error_line(res, 1, "solver.petsc.ksp_type", reason)
    assert cli_call(workdir, "run", "bad.toml").stderr == res.stderr


def test_a_rejected_petsc_option_is_named_alone(cli_call, workdir):
    """Where PETSc's message names the value of one option, the error names that option
    only (it listed every option set); where it names none, the list stays."""
    scene = base_scene()
    scene["solver"] = {"petsc": {"ksp_type": "nonexistent", "snes_monitr": True, "ksp_rtol": 1e-3}}
    (workdir / "bad.toml").write_text(to_toml(scene))
    _one_error_line(
        cli_call(workdir, "check", "bad.toml"),
        1,
        "solver.petsc.ksp_type",
        "PETSc rejected 'nonexistent': Unable to find requested KSP type nonexistent",
    )
    from dolfinx_mortar.solver import _options_named_in

    petsc = {"ksp_type": "gmres", "pc_type": "lu", "ksp_rtol": 1e-3, "ksp_monitor": True}
    assert _options_named_in("Unable to find requested PC type lu", petsc, "dm_") == ["pc_type"]
    assert _options_named_in("Unsupported viewer true", petsc, "dm_") == []
    assert _options_named_in("Bad -dm_ksp_rtol", petsc, "dm_") == ["ksp_rtol"]


def test_a_viewer_file_that_cannot_be_opened(cli_call, workdir):
    """A PETSc viewer option whose file cannot be opened (a missing directory), in the
    scene or on the command line: one error line on every rank naming the option, exit 2,
    nothing written. Under mpirun `check` printed rank 0's line and hung (rank 0 alone
    opens the file, the other ranks went on into a collective), and `run` with
    -dm_snes_view (opened at the end of the first solve) hung without a word."""
    scene = base_scene()
    scene["solver"] = {"petsc": {"snes_monitor": "ascii:nodir/monitor.txt"}}
    (workdir / "bad.toml").write_text(to_toml(scene))
    scene["solver"] = {}
    (workdir / "good.toml").write_text(to_toml(scene))
    before = snapshot(workdir)
    reason = "cannot open the viewer file nodir/monitor.txt: no directory nodir"
    for ranks in (0, 2):
        _one_error_line(
            cli_call(workdir, "check", "bad.toml", ranks=ranks),
            ranks or 1,
            "solver.petsc.snes_monitor",
            reason,
        )
    viewer = ["-dm_snes_view", "ascii:nodir/view.txt"]
    res = cli_call(workdir, "run", "good.toml", "--out", "o", *viewer, ranks=2)
    _one_error_line(res, 2, "solver.petsc.snes_view", "cannot open the viewer file nodir/view")
    assert snapshot(workdir) == before
    from dolfinx_mortar.solver import _viewer_file_errors

    (workdir / "adir").mkdir()
    bad = {
        "a": "binary:adir",  # a directory in the file's place
        "b": "hdf5:nodir/x.h5",
        "c": "ascii:absent.txt::read",  # a file to read that is missing
    }
    good = {
        "d": "ascii:ok.txt",
        "e": "ascii:stderr",
        "f": "::ascii_info",  # stdout, a format
        "g": "draw:nodir",  # no file
        "h": True,
        "i": "ascii:adir/ok.txt:ascii_info_detail:append",
    }
    cwd = os.getcwd()
    os.chdir(workdir)
    try:
        errors = _viewer_file_errors({**bad, **good})
    finally:
        os.chdir(cwd)
    assert [k for k, _ in errors] == [f"solver.petsc.{k}" for k in bad], errors


#: a law without volumetric stiffness, ψ = μ/2 (tr FᵀF − 2): its Newton iterates run wild
#: (displacements of 1e13), and a slave facet collapses to round-off
NO_VOLUME_LAW = """
import ufl
from dolfinx_mortar import register_law


def psi(F, E, nu):
    return E / (2 * (1 + nu)) / 2 * (ufl.tr(F.T * F) - 2)


register_law("no-volume", psi)
"""


# a --laws file runs on every rank before the scene is read: here it makes the writer's
# start fail as a surface without its volume dofs does (SurfaceFields' RuntimeError)
START_FAILS = """
from dolfinx_mortar import output

Tree = output.cKDTree


class FarTree(Tree):
    def query(self, x):
        dist, nearest = super().query(x)
        return dist + 1.0, nearest  # no volume dof within the match's tolerance


output.cKDTree = FarTree
"""


def test_a_run_whose_output_cannot_start_ends_in_one_line_and_its_summary(
    cli_call, workdir, monkeypatch
):
    """The writer's start fails (the slave surface's file cannot be set up): exit status
    1, one line on stderr (rank 0's, also on 2 ranks), no traceback, and the output
    directory holds summary.json ("failed", the same reason, no step) and nothing else
    of the run, the lock released. It left the series (hidden names too) and no
    summary.json."""
    from dolfinx_mortar import output

    # the --laws file, run in this process serially, replaces output.cKDTree: put back
    monkeypatch.setattr(output, "cKDTree", output.cKDTree)
    (workdir / "fail.py").write_text(START_FAILS)
    (workdir / "press.toml").write_text(to_toml(patch_press_scene(steps=2)))
    for ranks in (0, 2):
        out = f"start{ranks}"
        res = cli_call(workdir, "run", "press.toml", "--laws", "fail.py", "--out", out, ranks=ranks)
        where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
        assert res.returncode == 1 and "Traceback" not in res.stderr, where
        lines = res.stderr.splitlines()
        assert len(lines) == 1, where
        assert re.fullmatch(
            rf"dolfinx-mortar: run failed: the output could not be written to {out}: "
            r"contact_upper_bottom\.xdmf: \d+ surface dof\(s\) without a volume dof "
            r"\(at set-up, before the initial state was written\)",
            lines[0],
        ), where
        assert sorted(f.name for f in (workdir / out).iterdir()) == ["summary.json"]
        summary = json.loads((workdir / out / "summary.json").read_text())
        assert summary["status"] == "failed" and summary["steps"] == [], summary
        assert lines[0] == f"dolfinx-mortar: run failed: {summary['error']}", summary


def test_a_facet_collapsed_by_a_wild_iterate_stops_the_run_cleanly(cli_call, workdir):
    """A Newton iterate that collapses a contact facet to zero size (the kernels divide by
    its Jacobian) gives a NaN residual, so the step is cut back and the run stops (exit 1,
    summary.json "failed", no traceback), serially and on 2 ranks; it stopped with a
    ZeroDivisionError traceback from the pairing kernel."""
    (workdir / "law.py").write_text(NO_VOLUME_LAW)
    materials = "".join(
        f'[[material]]\nregion = "{r}"\nmodel = "no-volume"\nE = 100.0\nnu = 0.3\n'
        for r in ("lower", "upper")
    )
    bcs = "".join(
        f'[[dirichlet]]\nboundary = "{b}"\ncomponents = [{c}]\npath = [[0.0, 0.0], [1.0, 0.0]]\n'
        for b, c in (("lower_bottom", 1), ("lower_left", 0), ("upper_left", 0))
    )
    (workdir / "s.toml").write_text(
        'title = "collapse"\nkinematics = "finite"\n[mesh]\ngenerator = "patch2d"\n'
        "[mesh.params]\nn_lower = 2\nn_upper = 3\nn_y = 1\n"
        + materials
        + '[[contact]]\nslave = "upper_bottom"\nmaster = "lower_top"\npenalty = "auto"\n'
        + bcs
        + '[[traction]]\nboundary = "upper_top"\npath = [[0.0, 0.0, 0.0], [1.0, 0.0, -2.0]]\n'
        + "[steps]\nn = 2\n"
    )
    for ranks in (0, 2):
        res = cli_call(
            workdir, "run", "s.toml", "--laws", "law.py", "--out", f"o{ranks}", ranks=ranks
        )
        where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
        assert res.returncode == 1 and "Traceback" not in res.stderr, where
        assert "dolfinx-mortar: run failed: " in res.stderr, where
        summary = json.loads((workdir / f"o{ranks}" / "summary.json").read_text())
        assert summary["status"] == "failed", summary


def test_a_scene_file_name_that_is_not_utf8(workdir):
    """A scene file named in latin-1 bytes: dolfinx's import handed sys.argv to its C++
    logging, which refused it (a TypeError traceback, exit 1, before any check). The
    command now sees the file as named."""
    name = "sc\udce9ne.toml"  # the byte 0xE9 (surrogate escape): not valid UTF-8
    (workdir / name).write_text(to_toml(base_scene()))
    res = subprocess.run(
        [sys.executable, "-m", "dolfinx_mortar", "check", name],
        cwd=workdir,
        env=_env(),
        capture_output=True,
        timeout=TIMEOUT,
        stdin=subprocess.DEVNULL,
    )
    assert res.returncode == 0 and b"Traceback" not in res.stderr, res.stderr
    assert b"sc\xe9ne.toml: ok" in res.stdout, res.stdout


def test_a_scene_file_with_a_byte_order_mark(cli_call, workdir):
    """A UTF-8 byte-order mark (editors on Windows write one) is not TOML; the scene
    reads as without it (it was "line 1, column 1: TOML syntax error")."""
    (workdir / "bom.toml").write_bytes(b"\xef\xbb\xbf" + to_toml(base_scene()).encode())
    res = cli_call(workdir, "check", "bom.toml")
    assert res.returncode == 0 and res.stdout.startswith("bom.toml: ok (2D"), res.stderr


def test_a_non_finite_first_residual_stops_the_run_cleanly(cli_call, workdir):
    """A traction of 1e300 makes the first residual norm overflow: PETSc's SNES stops
    before it records a norm. The step is cut back, then the run stops with the reason
    (exit 1, summary.json "failed", no traceback); before, an IndexError."""
    scene = base_scene()
    scene["traction"][0]["path"] = [[0.0, 0.0, 0.0], [1.0, 1e300, 0.0]]
    scene["steps"]["max_cutbacks"] = 1
    (workdir / "big.toml").write_text(to_toml(scene))
    res = cli_call(workdir, "run", "big.toml", "--out", "o_big")
    assert res.returncode == 1 and "Traceback" not in res.stderr, res.stderr
    assert "DIVERGED_FNORM_NAN: the first residual is not finite" in res.stderr, res.stderr
    summary = json.loads((workdir / "o_big" / "summary.json").read_text())
    assert res.stderr.count(summary["error"]) == 1, res.stderr  # once, not logged as well
    assert summary["status"] == "failed" and summary["steps"] == []
    # the failed step's attempts are timed in the run-level "unfinished"
    assert summary["timings"]["unfinished"] > 0.0 and summary["timings"]["total"] == 0.0


def test_petsc_options_on_the_command_line(cli_call, workdir):
    """``run SCENE -dm_KEY [VALUE]``: PETSc options with the solver prefix override the
    scene's [solver.petsc]; a bare option is a flag; any other extra argument is a usage
    error (exit 2) and nothing is written (its one line on every rank of an mpirun:
    test_usage_errors_are_one_line, ``run s.toml --bogus`` on 3 ranks)."""
    scene = base_scene()
    scene["solver"] = {"petsc": {"snes_linesearch_type": "l2"}}
    (workdir / "s.toml").write_text(to_toml(scene))
    res = cli_call(workdir, "run", "s.toml", "--out", "o1", "-dm_snes_monitor")
    assert res.returncode == 0, res.stderr
    assert "SNES Function norm" in res.stdout
    res = cli_call(workdir, "run", "s.toml", "--out", "o2", "-dm_snes_linesearch_type", "nonsense")
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    assert "solver.petsc" in res.stderr and "snes_linesearch_type" in res.stderr
    run_line = res.stderr.strip()
    before = snapshot(workdir)
    for args in (["run", "s.toml", "--bogus"], ["run", "s.toml", "-snes_monitor"],
                 ["check", "s.toml", "-snes_monitor"]):  # fmt: skip
        res = cli_call(workdir, *args)
        assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
        (line,) = res.stderr.splitlines()
        m = ERROR_LINE.match(line)
        assert m and m.group("key") == "command line", line
        assert f"unrecognized argument {args[-1]}" in m.group("reason"), line
    # `check` takes the same -dm_ options and checks them as `run` does (it refused them
    # as arguments it does not take: a command line could not be checked before its run)
    res = cli_call(workdir, "check", "s.toml", "-dm_ksp_type", "gmres", "-dm_snes_monitor")
    assert res.returncode == 0 and res.stdout.startswith("s.toml: ok"), res.stderr
    res = cli_call(workdir, "check", "s.toml", "-dm_snes_linesearch_type", "nonsense")
    assert res.returncode == 2 and res.stderr.strip() == run_line, (res.stderr, run_line)
    assert snapshot(workdir) == before


def test_petsc_arguments_parsing():
    from dolfinx_mortar.cli import petsc_arguments

    assert petsc_arguments([]) == {}
    assert petsc_arguments(["-dm_snes_monitor", "-dm_ksp_rtol", "1e-8"]) == {
        "snes_monitor": True,
        "ksp_rtol": "1e-8",
    }
    assert petsc_arguments(["-dm_snes_divergence_tolerance", "-1"]) == {
        "snes_divergence_tolerance": "-1"
    }
    for bad in (["-dm_"], ["ksp_rtol"], ["-ksp_rtol", "1"]):
        with pytest.raises(ValueError):
            petsc_arguments(bad)


def test_bench_hard_runs_the_sweep_script(tmp_path):
    """``dolfinx-mortar bench hard`` is issue 5's name for the hard-case sweep: it runs
    bench/bench_hard_cases.py with the arguments that follow (one case here)."""
    out = tmp_path / "hard"
    res = cli(tmp_path, "bench", "hard", "--cases", "patch2d_ratio4_segment", "--out", str(out))
    assert res.returncode == 0, res.stderr
    rows = (out / "hard_cases.csv").read_text().splitlines()
    assert rows[0].startswith("case,") and len(rows) == 2, rows
    assert rows[1].startswith("patch2d_ratio4_segment,") and ",True," in rows[1], rows
    assert "| patch2d_ratio4_segment |" in (out / "hard_cases.md").read_text()


def test_bench_hard_refuses_mpirun_and_a_missing_script(tmp_path, monkeypatch, capsys):
    """Under mpirun ``bench hard`` stops with one error line (its cases are serial
    processes); without the checkout's bench/ script, one line names the missing file."""
    res = cli(tmp_path, "bench", "hard", "--quick", "--out", str(tmp_path / "x"), ranks=2)
    lines = res.stderr.splitlines()
    assert res.returncode != 0 and len(lines) == 2, res.stderr
    assert all(ERROR_LINE.match(ln) and "without mpirun" in ln for ln in lines), lines
    assert not (tmp_path / "x").exists()

    from dolfinx_mortar import cli as cli_module

    monkeypatch.setitem(cli_module.BENCH_SCRIPTS, "hard", "no_such_script.py")
    assert cli_module.main(["bench", "hard", "--quick"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "no_such_script.py not found" in err[0], err


@pytest.mark.parametrize("name", ["patch2d", "hard", "locking"])
def test_bench_refuses_an_empty_output_name(tmp_path, name):
    """``bench NAME --out ''``: the output directory's one-line error (Path("") is the
    working directory, into which the sweeps wrote their CSVs, plots and runs)."""
    res = cli(tmp_path, "bench", name, *(["--quick"] if name != "patch2d" else []), "--out", "")
    _one_error_line(res, 1, "--out", "cannot use '' as output directory: empty name")
    assert not list(tmp_path.iterdir())


def test_a_bench_interrupted_says_what_its_csv_keeps(tmp_path, monkeypatch, capsys):
    """Ctrl-C in a sweep: one line naming the CSV of the finished runs, or saying that none
    had finished (it spoke of a load step and summary.json, a single run's), exit 130."""
    from dolfinx_mortar import bench
    from dolfinx_mortar import cli as cli_module

    def sweep(name, levels, out, *args, finished, **kwargs):
        out.mkdir(parents=True, exist_ok=True)
        if finished:
            (out / bench.CSV_FILE).write_text("benchmark\nhertz2d\n")
        raise KeyboardInterrupt

    for finished, line in (
        (False, "dolfinx-mortar: interrupted before the first run finished"),
        (
            True,
            f"dolfinx-mortar: interrupted: {tmp_path / 'b1' / 'bench.csv'} keeps the finished runs",
        ),
    ):
        monkeypatch.setattr(bench, "run_bench", functools.partial(sweep, finished=finished))
        out = tmp_path / f"b{int(finished)}"
        assert cli_module.main(["bench", "hertz2d", "--levels", "2", "--out", str(out)]) == 130
        assert capsys.readouterr().err.splitlines() == [line]


@pytest.mark.parametrize("where", ["bench.csv", "cost.png"])
def test_bench_refuses_a_directory_where_its_csv_or_a_plot_goes(cli_call, tmp_path, where):
    """A directory at the sweep's CSV or a plot: the output directory's one line before
    any run (an IsADirectoryError traceback after the first run, or after them all)."""
    (tmp_path / "q" / where).mkdir(parents=True)
    res = cli_call(tmp_path, "bench", "patch2d", "--levels", "1", "--out", "q")
    _one_error_line(res, 1, "--out", f"'q/{where}' is a directory")
    assert [f.name for f in (tmp_path / "q").iterdir()] == [where]


@pytest.mark.parametrize("name", ["hard", "locking"])
def test_bench_scripts_refuse_an_output_path_on_a_file(tmp_path, name):
    """``bench hard|locking --out FILE``: one error line naming --out, exit 2 (it was a
    FileExistsError traceback, exit 1)."""
    (tmp_path / "afile").write_text("x\n")
    res = cli(tmp_path, "bench", name, "--quick", "--out", "afile")
    _one_error_line(res, 1, "--out", "it exists and is not a directory")
    assert (tmp_path / "afile").read_text() == "x\n"


def test_bench_levels_and_timeout_bounds(cli_call, tmp_path):
    """``bench NAME --levels K`` takes 1 .. MAX_LEVELS (K = 100000 ran on, writing a
    directory per level, until it was killed); ``bench hard --timeout`` must be > 0 (a
    negative one recorded every case as timed out, exit 0). Nothing written."""
    from dolfinx_mortar.bench import MAX_LEVELS

    res = cli_call(tmp_path, "bench", "patch2d", "--levels", str(MAX_LEVELS + 1), "--out", "b")
    _one_error_line(res, 1, "--levels", f"must be in 1 .. {MAX_LEVELS}, got {MAX_LEVELS + 1}")
    # bench hard loads a script (bench/) whose import changes sys.path: a process of its own
    res = cli(tmp_path, "bench", "hard", "--cases", "hertz2d_auto", "--timeout", "-5")
    _one_error_line(res, 1, "bench hard", "--timeout must be > 0 seconds, got -5")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    "argv,reason",
    [
        (["hard", "--cases", "nosuch"], "argument --cases: invalid choice: 'nosuch'"),
        (["hard", "--timeout", "soon"], "argument --timeout: invalid float value: 'soon'"),
        (["locking", "--no-such-option"], "unrecognized arguments: --no-such-option"),
        # a ratio of 0 was a ZeroDivisionError traceback mid-sweep, -1 a TypeError
        (["locking", "--ratios", "0"], "argument --ratios: must be a finite number > 0"),
        (["locking", "--patch-n", "0"], "argument --patch-n: must be a finite number > 0"),
        (["locking", "--hertz-h", "-1"], "argument --hertz-h: must be a finite number > 0"),
        # an unknown recovery was skipped, and an empty locking.csv written
        (["locking", "--recoveries", "foo"], "argument --recoveries: invalid choice: 'foo'"),
    ],
)
def test_bench_script_usage_errors_are_one_line(tmp_path, argv, reason):
    """The bench scripts' own argument errors read as the command line's: one line
    ``dolfinx-mortar: error: bench NAME: MESSAGE``, exit 2 (argparse printed its usage
    block first, 8 lines for ``bench hard``), and nothing written."""
    res = cli(tmp_path, "bench", *argv)
    _one_error_line(res, 1, f"bench {argv[0]}", reason)
    assert not list(tmp_path.iterdir())


def test_bench_locking_takes_the_study_options(tmp_path):
    """``dolfinx-mortar bench locking`` hands its arguments to bench/bench_locking.py."""
    res = cli(tmp_path, "bench", "locking", "--help")
    assert res.returncode == 0, res.stderr
    assert "--kappas" in res.stdout and "--uzawa-ratios" in res.stdout, res.stdout


def test_a_body_free_along_its_frictionless_contact_is_named(cli_call, workdir):
    """patch2d's lower block held in u_y only, under a frictionless press: nothing holds
    it along x (frictionless contact gives no tangential support). `check` and `run` say
    so up front in one warning naming the body and the motion, and the scene is not
    refused: without a load along x the run completes. Pushed along x by a traction on
    its left face, the run stops (exit 1, no traceback) and the one error line names the
    body and its free motion; it blamed "the pair's surfaces and the bodies' positions"
    (a probe's 3D Hertz scene whose block symmetry faces were in unnamed groups).
    `check` serially (it warns in the same call as `run`, runner.prepare), both runs
    serially and on 2 ranks."""
    scene = patch_press_scene(lower_bottom=(1,))
    scene["steps"]["max_cutbacks"] = 1
    warning = (
        "[WARNING dolfinx_mortar.runner] body 'lower' is free in translation along x: no "
        "[[dirichlet]] condition holds these motions, and its frictionless contact "
        "(upper_bottom:lower_top) cannot"
    )
    (workdir / "free.toml").write_text(to_toml(scene))
    scene["traction"] = [{"boundary": "lower_left", "path": [[0.0, 0.0, 0.0], [1.0, 0.5, 0.0]]}]
    (workdir / "pushed.toml").write_text(to_toml(scene))
    res = cli_call(workdir, "check", "free.toml")
    where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert res.returncode == 0 and "free.toml: ok" in res.stdout, where
    assert res.stderr.count(warning) == 1 and len(res.stderr.splitlines()) == 1, where
    for ranks in (0, 2):
        res = cli_call(workdir, "run", "free.toml", "--out", f"free{ranks}", ranks=ranks)
        where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
        assert res.returncode == 0 and res.stderr.count(warning) == 1, where
        res = cli_call(workdir, "run", "pushed.toml", "--out", f"pushed{ranks}", ranks=ranks)
        where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
        assert res.returncode == 1 and "Traceback" not in res.stderr, where
        assert res.stderr.count(warning) == 1, where
        errors = [ln for ln in res.stderr.splitlines() if ln.startswith("dolfinx-mortar:")]
        assert len(errors) == 1 and errors[0].startswith("dolfinx-mortar: run failed: "), where
        assert (
            "body 'lower' is free in translation along x, held there by no [[dirichlet]] "
            "condition nor by its frictionless contact (upper_bottom:lower_top)" in errors[0]
        ), where
        assert "the bodies' positions" not in errors[0], where
        summary = json.loads((workdir / f"pushed{ranks}" / "summary.json").read_text())
        assert summary["status"] == "failed" and summary["error"] in errors[0], summary


@pytest.mark.parametrize("ranks", [0, 2], ids=["serial", "mpirun2"])
def test_bodies_joined_by_contact_that_nothing_holds_are_named(cli_call, workdir, ranks):
    """patch2d's two blocks with no [[dirichlet]] at all, the upper one pressed down by a
    traction (frictionless): each block alone is held by the other's surface along y and
    in rotation, so only its x translation was named, but nothing holds the two moving
    together (a probe's shrink fit with no [[dirichlet]] said "ok" and failed after 6
    cutbacks). `check` and `run` name the two bodies and their joint motions in one
    warning; the run stops (the load pushes them along y together: exit 1, no traceback)
    with one error line that names them too. With the lower block clamped, no such
    warning (the upper one held by contact alone against it is a sound scene). Serial and
    under ``mpirun -n 2``; `check free.toml` serially only (its warnings are the run's,
    runner.prepare: the run asserts them on 2 ranks)."""
    scene = patch_press_scene()
    scene["dirichlet"] = []
    scene["traction"] = [{"boundary": "upper_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.5]]}]
    scene["steps"]["max_cutbacks"] = 1
    (workdir / "free.toml").write_text(to_toml(scene))
    scene["dirichlet"] = [{"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0]]}]
    (workdir / "clamped.toml").write_text(to_toml(scene))
    warning = (
        "[WARNING dolfinx_mortar.runner] bodies 'lower' and 'upper' are free together in "
        "translation along x, translation along y and rotation in the plane: no "
        "[[dirichlet]] condition holds these motions of the bodies moving as one, and their "
        "contact (upper_bottom:lower_top) cannot, frictionless or not"
    )
    own = "is free in translation along x: no [[dirichlet]]"  # each body's, along x
    if not ranks:
        res = cli_call(workdir, "check", "free.toml")
        where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
        assert res.returncode == 0 and "free.toml: ok" in res.stdout, where
        assert res.stderr.count(warning) == 1, where
        # and each body's own warning (the flat contact holds no x translation)
        assert res.stderr.count(own) == 2, where
        assert len(res.stderr.splitlines()) == 3, where
    res = cli_call(workdir, "run", "free.toml", "--out", "free", ranks=ranks)
    where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert res.returncode == 1 and "Traceback" not in res.stderr, where
    assert res.stderr.count(warning) == 1, where
    assert res.stderr.count(own) == 2, where  # once each, rank 0's
    (line,) = [x for x in res.stderr.splitlines() if x.startswith("dolfinx-mortar:")]
    assert line.startswith("dolfinx-mortar: run failed: "), where
    assert (
        "bodies 'lower' and 'upper' are free together in translation along x, translation "
        "along y and rotation in the plane, held there by no [[dirichlet]] condition, and "
        "their contact (upper_bottom:lower_top) keeps every gap along them" in line
    ), where
    res = cli_call(workdir, "check", "clamped.toml", ranks=ranks)
    where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert res.returncode == 0 and "clamped.toml: ok" in res.stdout, where
    assert "free together" not in res.stderr, where
    assert res.stderr.count("body 'upper' is free in translation along x") == 1, where
    assert len(res.stderr.splitlines()) == 1, where


def test_a_traction_on_a_prescribed_component_and_an_unwritten_field_are_named(cli_call, workdir):
    """A [[traction]] on a boundary whose [[dirichlet]] prescribes the same component
    moves nothing there: one warning names the boundary and the component, and the
    boundary's reaction takes the traction (its y reaction differs from the run without
    it by −t_y × L = 0.5, L = 1 the face's length). `output.fields` naming
    "tangential_traction" in a frictionless run writes no such field: one warning says
    why. Both said nothing before. `check` and `run` serially, `run` on 2 ranks: exit 0,
    each warning once (rank 0's), no traceback. (`check` logs them in the same call as
    `run`, runner.prepare: on 2 ranks `run` shows them once, and
    test_bodies_joined_by_contact_that_nothing_holds_are_named[mpirun2] runs a `check`
    that warns on 2 ranks.)"""
    scene = patch_press_scene()
    scene["output"] = {"fields": ["displacement", "tangential_traction"]}
    (workdir / "plain.toml").write_text(to_toml(scene))
    scene["traction"] = [{"boundary": "upper_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.5]]}]
    (workdir / "both.toml").write_text(to_toml(scene))
    dropped = (
        "[WARNING dolfinx_mortar.problem] [[traction]] on 'upper_top': a [[dirichlet]] "
        "condition prescribes component(s) 1 (y) of the same boundary, so the traction's "
        "part in them moves nothing (it goes into the boundary's reaction, not into the body)"
    )
    unwritten = (
        "[WARNING dolfinx_mortar.runner] output.fields: 'tangential_traction' is not "
        "written: every [[contact]] pair is frictionless"
    )
    reactions = {}
    for ranks in (0, 2):
        for name in ("plain", "both"):
            for command in ("check", "run") if not ranks else ("run",):
                out = ("--out", f"{name}{ranks}") if command == "run" else ()
                res = cli_call(workdir, command, f"{name}.toml", *out, ranks=ranks)
                where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
                assert res.returncode == 0 and "Traceback" not in res.stderr, where
                assert res.stderr.count(dropped) == (name == "both"), where
                assert res.stderr.count(unwritten) == 1, where
                assert len(res.stderr.splitlines()) == 1 + (name == "both"), where
            summary = json.loads((workdir / f"{name}{ranks}" / "summary.json").read_text())
            reactions[name, ranks] = summary["steps"][-1]["reactions"]["upper_top"]
            h5 = (workdir / f"{name}{ranks}" / "fields.xdmf").read_text()
            assert "tangential_traction" not in h5 and "slip" not in h5
        (x1, y1), (x0, y0) = reactions["both", ranks], reactions["plain", ranks]
        assert abs(x1 - x0) < 1e-9 and abs(y1 - y0 - 0.5) < 1e-9, (ranks, reactions)


@pytest.mark.parametrize("ranks", [0, 2], ids=["serial", "mpirun2"])
def test_a_body_held_by_stick_alone_that_escapes_stops_the_run(cli_call, workdir, ranks):
    """A body held along x by stick alone, not in contact at t = 0
    (``conftest.stick_only_scene``): ``check`` warns at set-up, naming the body, the
    motion and the fix; ``run`` stops with one error line (exit 1) that says the body
    escaped, instead of ending "ok" with the cylinder slid 3.0 along x and no node in
    contact. Serial and under ``mpirun -n 2``; `check` serially only: `run` logs the same
    warning (runner.prepare), asserted here on 2 ranks."""
    (workdir / "stick.toml").write_text(to_toml(stick_only_scene()))

    def warned_once(stderr: str, where: str) -> None:
        warned = [ln for ln in stderr.splitlines() if "but for stick" in ln]
        warned = [ln for ln in warned if not ln.startswith("dolfinx-mortar:")]
        assert len(warned) == 1, where
        assert "body 'cylinder' is free in translation along x but for stick" in warned[0], where
        assert "prescribe these components with [[dirichlet]], or start the bodies" in warned[0]

    if not ranks:
        res = cli_call(workdir, "check", "stick.toml")
        where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
        assert res.returncode == 0, where
        warned_once(res.stderr, where)
    res = cli_call(workdir, "run", "stick.toml", "--out", "out", ranks=ranks)
    where = f"\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert "Traceback" not in res.stderr, where
    assert res.returncode == 1, where
    warned_once(res.stderr, where)
    (line,) = [x for x in res.stderr.splitlines() if x.startswith("dolfinx-mortar:")]
    assert line.startswith("dolfinx-mortar: run failed: step to t = "), where
    assert "failed after 6 cutbacks" in line and "the body escaped" in line, where
    # the stop names the body and the fix, and blames no surfaces' positions
    assert "body 'cylinder' is free in translation along x but for stick" in line, where
    assert "the bodies' positions" not in line, where
    moved = float(re.search(r"moved a body held by contact alone by (\S+) ", line).group(1))
    assert moved > 0.2, where  # more than one facet size (h_mean 0.52)
