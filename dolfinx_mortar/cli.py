"""Command line: ``dolfinx-mortar run | check | generators | bench`` (or Debian's
``/usr/bin/python3 -m dolfinx_mortar``).

``run`` and ``check`` take ``--laws FILE``: a Python file, run on every rank before the
scene is read, that registers bulk laws of one's own (:func:`dolfinx_mortar.register_law`)
for the scene's ``[[material]]`` to name.

``bench hard`` and ``bench locking`` run the hard-case sweep and the surface-locking
study of a source checkout (``bench/bench_hard_cases.py``, ``bench/bench_locking.py``);
the arguments after the name go to the script (``dolfinx-mortar bench hard --help``).

Bad input ends every rank with one line ``dolfinx-mortar: error: KEY: REASON``
on stderr and exit status 2, without a traceback and before any output is
written. A mistake in the scene file or in the command-line PETSc options is found
before dolfinx and gmsh are imported (about 0.5 s, not 1 s). A run that stops on
non-convergence exits with status 1 after writing every finished step. Any other
exception aborts all ranks (no hang).
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import sys
import traceback
from pathlib import Path

from .bench import BENCH_SCRIPTS
from .errors import (
    OutputError,
    SceneError,
    Terminated,
    every_rank_arrives,
    file_problem,
    raise_on_every_rank,
)


class _Versions(argparse.Action):
    """``--version``: this package's version and the stack's (imported only when asked)."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        from mpi4py import MPI

        from .runner import software_versions

        v = software_versions()
        mine = v.pop("dolfinx_mortar")
        if MPI.COMM_WORLD.rank == 0:  # one line under mpirun
            print(f"dolfinx-mortar {mine} ({', '.join(f'{k} {x}' for k, x in v.items())})")
        parser.exit(0)


class _OneLineParser(argparse.ArgumentParser):
    """argparse whose usage errors are one line, ``dolfinx-mortar: error: command line:
    MESSAGE``, with exit status 2 (every rank parses its arguments, so under mpirun each
    prints that line once; the subcommands' parsers are of this class too)."""

    def error(self, message: str):
        _usage_exit(f"dolfinx-mortar: error: command line: {' '.join(message.split())}")


def _parser() -> argparse.ArgumentParser:
    p = _OneLineParser(
        prog="dolfinx-mortar", description=__doc__.split("\n\n")[0].replace("``", "")
    )
    p.add_argument("--version", action=_Versions, help="print the versions and exit")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a scene (under mpirun for several ranks)")
    r.add_argument("scene", type=Path)
    r.add_argument("--out", default=None, help="output directory (overrides [output] dir)")
    r.add_argument(
        "-v", "--verbose", action="count", default=0, help="log at INFO level (DEBUG with -vv)"
    )
    r.epilog = (
        "PETSc options of the solver follow with the prefix dm_, e.g. -dm_snes_monitor or "
        "-dm_ksp_type gmres; they override the scene's [solver.petsc]."
    )
    c = sub.add_parser("check", help="validate a scene (reads the mesh) without solving")
    c.add_argument("scene", type=Path)
    c.epilog = (
        "PETSc options with the prefix dm_ are checked as `run` takes them, e.g. "
        "-dm_ksp_type gmres."
    )
    for x in (r, c):
        x.add_argument(
            "--laws",
            type=Path,
            action="append",
            default=[],
            metavar="FILE",
            help="a Python file that registers bulk laws of your own with "
            "dolfinx_mortar.register_law, run on every rank before the scene is read "
            "(repeatable)",
        )
    sub.add_parser(
        "generators",
        help="list the built-in mesh generators, their parameters and their physical groups",
    )
    b = sub.add_parser(
        "bench", help="mesh-level sweep of a benchmark: CSV row per run and PNG plots"
    )
    b.add_argument(
        "name",
        help="hertz2d, hertz3d, patch2d, cattaneo2d, ironing2d or all; hard or locking run "
        "the hard-case sweep or the surface-locking study (their own options follow: "
        "`dolfinx-mortar bench hard --help`)",
    )
    b.add_argument("--levels", type=int, default=3, help="mesh levels 0 .. K-1 [3]")
    # a string, not a Path: Path("") is ".", and check_out_dir must see the empty name
    b.add_argument("--out", default="bench/out", help="output dir [bench/out]")
    b.add_argument(
        "--integration",
        choices=("element", "segment", "both"),
        default="both",
        help="mortar integration(s) to run [both]",
    )
    b.add_argument(
        "--recovery",
        choices=("lumped", "unconstrained", "constrained", "all"),
        default="lumped",
        help="recovery(ies) to run, each a curve of the plots [lumped]",
    )
    b.add_argument(
        "--tiny",
        action="store_true",
        help="coarser level-0 meshes (bench.TINY_H0: h_contact 0.4 for hertz2d): a smoke run",
    )
    return p


def _setup_logging(rank: int, verbose: int) -> None:
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    level = level if rank == 0 else logging.ERROR
    # force: importing dolfinx has already put a handler on the root logger, which made
    # basicConfig a no-op and left the root at WARNING (-v and -vv printed nothing)
    logging.basicConfig(
        level=level, format="[%(levelname)s %(name)s] %(message)s", stream=sys.stderr, force=True
    )
    # The level goes on the handlers too: setuptools (used by the JIT compilation of forms)
    # lowers the root logger's level, which would print its build log on stderr.
    for handler in logging.getLogger().handlers:
        handler.setLevel(level)


def _error_line(text: str) -> None:
    """Write one line to stderr in a single write: print() writes the text and the newline
    separately, which (with unbuffered stderr, e.g. PYTHONUNBUFFERED=1) lets the lines of
    several ranks interleave under mpirun."""
    sys.stderr.write(" ".join(text.splitlines()) + "\n")
    sys.stderr.flush()


#: Seconds a rank with a command-line error waits for the other ranks under mpirun
#: (:func:`_every_rank_has_printed`); the environment variable
#: ``DOLFINX_MORTAR_USAGE_ERROR_WAIT`` (seconds, a number >= 0) sets another bound.
USAGE_ERROR_WAIT = 10.0


def _usage_error_wait() -> float:
    """The bound of :func:`_every_rank_has_printed`: ``DOLFINX_MORTAR_USAGE_ERROR_WAIT``
    where it is a finite number >= 0, else USAGE_ERROR_WAIT (an unreadable value is
    ignored: the command line's own error is the one to report)."""
    text = os.environ.get("DOLFINX_MORTAR_USAGE_ERROR_WAIT", "")
    try:
        seconds = float(text)
    except ValueError:
        return USAGE_ERROR_WAIT
    return seconds if math.isfinite(seconds) and seconds >= 0.0 else USAGE_ERROR_WAIT


def _every_rank_has_printed() -> None:
    """Under mpirun (Open MPI's or MPICH's environment says more than one rank), wait
    until every rank gets here, or USAGE_ERROR_WAIT seconds (a non-blocking barrier;
    nothing otherwise; ``DOLFINX_MORTAR_USAGE_ERROR_WAIT`` sets another bound:
    :func:`_usage_error_wait`). Each rank parses its own command line and finds the same
    error; the first to exit made mpirun kill the others before they had printed theirs
    (3 ranks: 5 of 30 runs lost a line, BENCHMARKS §46). The wait is bounded: ranks of an
    MPMD launch (or ranks that run another command) never get here, and a blocking
    barrier hung them."""
    size = os.environ.get("OMPI_COMM_WORLD_SIZE") or os.environ.get("PMI_SIZE") or "1"
    if size.isdigit() and int(size) > 1:
        from mpi4py import MPI

        every_rank_arrives(MPI.COMM_WORLD, _usage_error_wait())


def _usage_exit(text: str):
    """Exit with status 2 after the one line ``text`` (a command-line error), once every
    rank has printed its own (:func:`_every_rank_has_printed`)."""
    _error_line(text)
    _every_rank_has_printed()
    sys.exit(2)


def load_laws(path: Path) -> None:
    """Run the Python file ``path`` (``--laws``; local: every rank runs it): it registers
    bulk laws with :func:`dolfinx_mortar.register_law` for the scene to name. Raises
    SceneError (key ``--laws``) where the file is missing or not a regular file (a
    directory, a FIFO: :func:`~dolfinx_mortar.errors.file_problem`), raises or calls
    sys.exit()."""
    import runpy

    problem = file_problem(path, "a Python file")
    if problem is not None:
        raise SceneError("--laws", problem)
    try:
        runpy.run_path(str(path), run_name="__dolfinx_mortar_laws__")
    except (Exception, SystemExit) as exc:  # whatever the user's file raises, or exit()
        reason = " ".join(f"{type(exc).__name__}: {exc}".split())
        raise SceneError("--laws", f"{path} failed: {reason}") from None


def _on_every_rank(comm, action, *args):
    """``action(*args)`` on every rank (collective), its result: where it raises
    SceneError on some ranks, every rank raises the first rank's error (naming that rank
    where others did not fail), so that no rank waits alone in a later collective."""
    error = result = None
    try:
        result = action(*args)
    except SceneError as exc:
        error = (exc.key, exc.reason)
    raise_on_every_rank(comm, error)
    return result


def _progress(comm):
    def show(step, rec):
        if comm.rank == 0:
            its = "+".join(str(i) for i in rec["newton_iterations"])
            forces = " ".join(
                f"{k}={[round(v, 6) + 0.0 for v in f]}" for k, f in rec["contact_force"].items()
            )
            print(
                f"step {step:4d}  t = {rec['t']:.6g}  newton {its}  uzawa {rec['uzawa_rounds']}"
                f"  cutbacks {rec['cutbacks']}  active {rec['active_nodes']}  {forces}"
                f"  {rec['wall_time']:.2f} s",
                flush=True,
            )

    return show


def _pair_line(name: str, pair: dict) -> str:
    """``check``'s line for one contact pair, from its summary.json ``modelled`` entry
    (:meth:`dolfinx_mortar.contact.MortarContact.describe`): the choices the scene left to
    the defaults (the quadrature rule, the penalty) as the run will make them."""
    rule = f" ({pair['quadrature']})" if "quadrature" in pair else ""
    friction = f"friction {pair['friction']:g}" if pair["friction"] else "frictionless"
    lo, hi = (f"{v:.3g}" for v in pair["penalty_range"])
    penalty = lo if lo == hi else f"{lo} … {hi}"
    if isinstance(pair["penalty"], str):  # a rule ("auto: 100 E*/h_I"), not a number
        penalty = f"{pair['penalty']} = {penalty}"
    return (
        f"  {name}: {pair['integration']} integration{rule}, {pair['recovery']} recovery, "
        f"{friction}, penalty {penalty}, {pair['slave_facets']} slave facets"
    )


def _bench_progress(comm):
    """``bench``'s progress lines (:func:`dolfinx_mortar.bench.run_bench`) on stdout, once
    under mpirun (rank 0)."""

    def show(line: str) -> None:
        if comm.rank == 0:
            print(line, flush=True)

    return show


def petsc_arguments(tokens: list[str], prefix: str = "dm_") -> dict:
    """``[solver.petsc]`` entries from command-line tokens ``-dm_KEY [VALUE] ...``: KEY
    without the prefix, VALUE the next token unless that is another option (a bare flag is
    True). Raises ValueError naming the first token that is not such an option."""
    out, i = {}, 0
    while i < len(tokens):
        tok = tokens[i]
        if not tok.startswith("-" + prefix) or len(tok) == len(prefix) + 1:
            raise ValueError(tok)
        nxt = tokens[i + 1] if i + 1 < len(tokens) else None
        flag = nxt is None or (nxt.startswith("-") and not _is_number(nxt))
        out[tok[len(prefix) + 1 :]] = True if flag else nxt
        i += 1 if flag else 2
    return out


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _bench_script(name: str, argv: list[str]) -> int:
    """Run ``bench/BENCH_SCRIPTS[name]`` of the source checkout with ``argv`` (its main
    takes them). Returns the exit status: 2 with one error line where the checkout's
    bench/ directory is missing (an installed package without the sources), or for
    ``hard`` under mpirun (it runs every case in a serial process of its own)."""
    import importlib.util

    from mpi4py import MPI

    if name == "hard" and MPI.COMM_WORLD.size > 1:
        _error_line(
            "dolfinx-mortar: error: bench hard: it runs each case in a serial process of "
            "its own; start it without mpirun"
        )
        return 2
    path = Path(__file__).resolve().parents[1] / "bench" / BENCH_SCRIPTS[name]
    if not path.is_file():
        _error_line(
            f"dolfinx-mortar: error: bench {name}: {path} not found; this command runs the "
            "script of a source checkout (git clone, then scripts/install.sh)"
        )
        return 2
    spec = importlib.util.spec_from_file_location(f"_dolfinx_mortar_bench_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    prog, sys.argv[0] = sys.argv[0], f"dolfinx-mortar bench {name}"  # argparse's usage line
    # the script's usage errors become one line too, as the command line's own
    # (_OneLineParser): argparse printed its whole usage block before the message
    error, argparse.ArgumentParser.error = argparse.ArgumentParser.error, _bench_error(name)
    try:
        module.main(argv)
    except SceneError as exc:  # e.g. --out on a file
        _error_line(f"dolfinx-mortar: error: {exc}")
        return 2
    finally:
        sys.argv[0] = prog
        argparse.ArgumentParser.error = error
    return 0


def _bench_error(name: str):
    """An ``argparse.ArgumentParser.error`` that exits with the one line
    ``dolfinx-mortar: error: bench NAME: MESSAGE``, status 2."""

    def error(parser: argparse.ArgumentParser, message: str):
        _usage_exit(f"dolfinx-mortar: error: bench {name}: {' '.join(message.split())}")

    return error


def _import_dolfinx(rank: int, verbose: int) -> None:
    """Import dolfinx with a command line it can take, then set up the logging again
    (local). Its import hands ``sys.argv`` to its C++ logging, which refuses an argument
    that is not valid UTF-8 (a scene file named in latin-1 bytes: a TypeError traceback
    before any check). Such bytes are replaced in the copy that dolfinx sees; the
    arguments keep them, so the file opens as named. The import puts a handler on the
    root logger where it has none (ffcx's ``logging.basicConfig()``); ``main`` sets up
    its logging before, for the scene's checks, and :func:`_setup_logging` runs again
    after this import, so that the format and levels are the same whatever the import
    did. Where dolfinx is imported already (a second call, or a program that calls
    ``main``), nothing is done: ``main``'s own set-up came after that import."""
    if "dolfinx" in sys.modules:
        return
    argv = sys.argv
    sys.argv = [a.encode("utf-8", "surrogateescape").decode("utf-8", "replace") for a in argv]
    try:
        import dolfinx  # noqa: F401
    finally:
        sys.argv = argv
    _setup_logging(rank, verbose)


def _subcommand_options(parser: argparse.ArgumentParser, command: str | None) -> set[str]:
    """The option strings (``-v``, ``--out``, …) of the subcommand ``command`` of the
    command line's ``parser`` (empty for none)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction) and command in action.choices:
            return set(action.choices[command]._option_string_actions)
    return set()


def _interrupted(args, exc: KeyboardInterrupt) -> str:
    """What a Ctrl-C of command ``args`` left behind, for its one line (local): a run's
    summary.json keeps the finished steps (once they had begun), a sweep's CSV its
    finished runs (it is rewritten after each; the run that was interrupted is not in
    it: it spoke of a load step before)."""
    if args.command == "bench":
        from .bench import CSV_FILE

        csv = Path(args.out) / CSV_FILE
        if csv.is_file():
            return f"interrupted: {csv} keeps the finished runs"
        return "interrupted before the first run finished"
    if getattr(exc, "summary_kept", False):  # set once the steps had begun
        return "interrupted: summary.json keeps the finished steps"
    return "interrupted before the first load step"


def main(argv=None) -> int:
    tokens = list(sys.argv[1:] if argv is None else argv)
    if len(tokens) >= 2 and tokens[0] == "bench" and tokens[1] in BENCH_SCRIPTS:
        return _bench_script(tokens[1], tokens[2:])
    parser = _parser()
    args, extra = parser.parse_known_args(argv)
    petsc = {}
    if extra:
        try:
            if args.command not in ("run", "check"):
                raise ValueError(extra[0])
            petsc = petsc_arguments(extra)
        except ValueError as exc:
            bad = str(exc)
            if bad in _subcommand_options(parser, args.command):
                hint = f"an option of `{args.command}`: put it after `{args.command}`"
            elif args.command not in ("run", "check"):  # the PETSc hint is theirs
                hint = (
                    f"an option of `run`, not of `{args.command}`"
                    if bad in _subcommand_options(parser, "run")
                    else f"`{args.command}` takes no such argument"
                )
            elif bad in _subcommand_options(parser, "run"):  # check ... --out
                hint = f"an option of `run`, not of `{args.command}`"
            else:
                hint = f"PETSc options of `{args.command}` take the prefix -dm_"
            _usage_exit(
                f"dolfinx-mortar: error: command line: unrecognized argument {bad} ({hint})"
            )
    if args.command == "generators":
        from mpi4py import MPI

        from .generators import describe

        if MPI.COMM_WORLD.rank > 0:  # the list once under mpirun
            return 0

        text = describe()  # with each generator's groups: it builds their geometries
        try:
            sys.stdout.write(text + "\n")
            sys.stdout.flush()
        except BrokenPipeError:  # e.g. `dolfinx-mortar generators | head`
            sys.stdout = None
        return 0

    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    verbose = getattr(args, "verbose", 0)
    _setup_logging(comm.rank, verbose)
    try:
        if args.command == "bench":
            _import_dolfinx(comm.rank, verbose)
            from .bench import INTEGRATIONS, OUTPUT_FILES, RECOVERIES, TINY_H0, run_bench
            from .output import check_out_dir

            check_out_dir(args.out, "--out", comm, files=OUTPUT_FILES)
            integ = INTEGRATIONS if args.integration == "both" else (args.integration,)
            h0 = TINY_H0 if args.tiny else None
            recs = RECOVERIES if args.recovery == "all" else (args.recovery,)
            run_bench(
                args.name,
                args.levels,
                Path(args.out),
                integ,
                comm=comm,
                h0=h0,
                recoveries=recs,
                progress=_bench_progress(comm),
            )
            return 0
        from .scene import load_scene

        # The scene and its command-line PETSc options are read and checked before
        # dolfinx (and gmsh, through the output module) is imported: a mistake in them
        # is answered in Python + mpi4py's start-up time (0.5 s, not 1.1 s). The --laws
        # files come first (the scene names their laws) and may import dolfinx or JIT
        # forms, so with them dolfinx is imported first, as before.
        if args.laws:
            _import_dolfinx(comm.rank, verbose)
        for path in dict.fromkeys(args.laws):  # a file named twice runs once
            _on_every_rank(comm, load_laws, path)
        # collective: a --laws file that registers a law on some ranks only leaves the
        # scene valid on those (rank 0 went on into the mesh's collectives and hung)
        scene = _on_every_rank(comm, load_scene, args.scene)
        if petsc:  # command-line PETSc options override the scene's
            import dataclasses

            from .scene import petsc_value

            # the scene's rules: an integer fits a C int, a number is finite
            petsc = {k: petsc_value(v, f"solver.petsc.{k}") for k, v in petsc.items()}
            solver = dataclasses.replace(scene.solver, petsc={**scene.solver.petsc, **petsc})
            scene = dataclasses.replace(scene, solver=solver)
        _import_dolfinx(comm.rank, verbose)
        from .output import check_out_dir

        if args.command == "check":
            from .runner import check_solver, prepare

            # the output directory as `run` checks it (created and removed where missing:
            # nothing is left), but not the lock: a run writing there now is no input error
            slaves = [pair.slave for pair in scene.contacts]
            check_out_dir(scene.output.dir, "output.dir", comm, slaves, lock=False)
            problem, mesh_data = prepare(scene, comm)
            check_solver(scene, problem)  # the PETSc options, as `run` checks them
            if comm.rank == 0:
                print(
                    f"{args.scene}: ok ({mesh_data.gdim}D, {mesh_data.info['cell_type']}, "
                    f"{problem.num_dofs} dofs, {len(problem.contacts)} contact pair(s))"
                )
                for c in problem.contacts:  # describe() is not collective
                    print(_pair_line(c.name, c.describe()))
            return 0
        slaves = [pair.slave for pair in scene.contacts]
        if args.out is not None:
            check_out_dir(args.out, "--out", comm, slaves)
        else:
            check_out_dir(scene.output.dir, "output.dir", comm, slaves)
        from .runner import run

        out = None if args.out is None else Path(args.out)
        summary = run(scene, comm, out_dir=out, progress=_progress(comm))
    except SceneError as exc:
        _error_line(f"dolfinx-mortar: error: {exc}")
        return 2
    except OutputError as exc:  # raised on every rank (before the first step: step 0)
        if comm.rank == 0:
            _error_line(f"dolfinx-mortar: run failed: {exc}")
        return _failed(comm)
    except KeyboardInterrupt as exc:  # Ctrl-C: one line, no traceback
        if comm.rank == 0:
            _error_line(f"dolfinx-mortar: {_interrupted(args, exc)}")
        return 130
    except Terminated as exc:  # SIGTERM, on every rank; summary.json says so
        if comm.rank == 0:
            _error_line(f"dolfinx-mortar: {exc.message}")
        return _failed(comm, exc.code)
    except Exception:
        traceback.print_exc()
        sys.stderr.flush()
        if comm.size > 1:
            comm.Abort(1)
        return 1
    if summary["status"] != "ok":
        if comm.rank == 0:
            _error_line(f"dolfinx-mortar: run failed: {summary['error']}")
        return _failed(comm)
    return 0


#: Seconds the ranks of a failed run wait for each other before it is aborted
#: (:func:`_failed`).
FAILED_RUN_WAIT = 30.0


def _failed(comm, status: int = 1) -> int:
    """Exit status ``status`` (1; 143 after SIGTERM) of a failed run, once every rank has
    got here; where some rank has not within FAILED_RUN_WAIT seconds (left in a
    collective: a parallel HDF5 write that failed differently on each rank, on a full
    disk), abort the job, which otherwise hung with its error line printed."""
    if comm.size > 1 and not every_rank_arrives(comm, FAILED_RUN_WAIT):
        sys.stderr.flush()
        comm.Abort(status)
    return status


if __name__ == "__main__":
    sys.exit(main())
