"""Run a validated scene: mesh → problem → contact terms → solver → output (collective).

Everything that can be wrong with the input is checked before the output
directory is touched; a run whose load stepping fails after its cutbacks stops
with ``status = "failed"`` and keeps every finished step. So does a run whose PETSc
options PETSc accepted at set-up but refuses in the solve (a MUMPS ICNTL out of range,
``mat_mumps_icntl_7 = 99``): PETSc checks those only there.
"""

from __future__ import annotations

import logging
from pathlib import Path
from time import perf_counter

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from . import compat
from .errors import (
    ConvergenceError,
    OutputError,
    SceneError,
    Terminated,
    every_rank_arrives,
    first_on_any_rank,
    stops_on_signals,
)
from .laws import registered_law
from .mesh import load_mesh
from .scene import Scene, check_components, check_groups, check_regions_covered, path_argument

log = logging.getLogger(__name__)


def software_versions() -> dict[str, str]:
    """The versions of this package and of the stack a run used (local): dolfinx_mortar,
    dolfinx, PETSc, the MPI library, numpy and Python. summary.json records them under
    ``versions``, so that a result can be traced to the software that produced it."""
    import platform

    import dolfinx

    from . import __version__

    mpi_name, mpi_version = MPI.get_vendor()
    return {
        "dolfinx_mortar": __version__,
        "dolfinx": dolfinx.__version__,
        "petsc": ".".join(str(v) for v in PETSc.Sys.getVersion()),
        "mpi": f"{mpi_name} {'.'.join(map(str, mpi_version))}",
        "numpy": np.__version__,
        "python": platform.python_version(),
    }


def _check_scene(scene, caller: str, comm, **callbacks) -> None:
    """TypeError unless ``scene`` is a Scene (a dict or a path failed deep inside, with
    "'dict' object has no attribute 'mesh'"), ``comm`` an mpi4py communicator and each of ``callbacks`` (name -> value) callable or None (local).
    ``run(scene, None)`` failed on ``None.rank``; ``run(..., progress=5)`` solved a step,
    then stopped "interrupted by TypeError" (QA, session 65)."""
    if not isinstance(scene, Scene):
        raise TypeError(
            f"{caller}() takes a Scene, not {type(scene).__name__}: build it with "
            "dolfinx_mortar.parse_scene(data, base_dir) from a dict, or "
            "dolfinx_mortar.load_scene(path) from a file"
        )
    if not isinstance(comm, MPI.Comm):
        raise TypeError(
            f"{caller}() takes an mpi4py communicator (MPI.COMM_WORLD, MPI.COMM_SELF, "
            f"mesh.comm), not {type(comm).__name__}"
        )
    for name, value in callbacks.items():
        if value is not None and not callable(value):
            raise TypeError(
                f"{caller}(): {name} must be a function or None, not {type(value).__name__}"
            )


def prepare(scene: Scene, comm, setup=None):
    """Load the mesh and build the problem with its contact terms; validates everything (collective).

    ``setup(problem)``, if given, is called before the contact terms are added (e.g. to
    :meth:`~dolfinx_mortar.problem.ContactProblem.add_dirichlet_field`).
    Returns ``(problem, mesh_data)``. Raises SceneError on every rank for bad input,
    TypeError when ``scene`` is not a :class:`~dolfinx_mortar.scene.Scene`, ``comm`` not
    an mpi4py communicator or ``setup`` neither callable nor None.
    """
    _check_scene(scene, "prepare", comm, setup=setup)
    parsed = dict(scene.laws)
    for i, mat in enumerate(scene.materials):
        if mat.model in parsed and registered_law(mat.model) is not parsed[mat.model]:
            raise SceneError(
                f"material[{i}].model",
                f"the law {mat.model!r} was registered again after the scene was parsed: "
                "parse the scene again to run the new one",
            )
    m = scene.mesh
    mesh_data = load_mesh(comm, file=m.file, generator=m.generator, params=m.params)
    check_groups(scene, mesh_data.cell_groups, mesh_data.facet_groups)
    check_components(scene, mesh_data.gdim)
    empty = set(mesh_data.info.get("empty_groups", ()))
    for key, names in (
        ("material", [m.region for m in scene.materials]),
        ("dirichlet", [d.boundary for d in scene.dirichlet]),
        ("traction", [t.boundary for t in scene.tractions]),
    ):
        for i, name in enumerate(names):
            if name in empty:
                field = "region" if key == "material" else "boundary"
                raise SceneError(
                    f"{key}[{i}].{field}", f"physical group {name!r} has no elements in the mesh"
                )
    from .bulk import check_law
    from .problem import ContactProblem

    for i, mat in enumerate(scene.materials):
        check_law(mat.model, mat.E, mat.nu, mesh_data.gdim, f"material[{i}].model", mat.region)
    check_regions_covered(
        [mat.region for mat in scene.materials],
        mesh_data.cell_groups,
        tuple(mesh_data.info.get("unnamed_groups", ())),
    )
    problem = ContactProblem(
        mesh_data,
        [(mat.region, mat.model, mat.E, mat.nu) for mat in scene.materials],
        [(d.boundary, d.components, d.path) for d in scene.dirichlet],
        [(t.boundary, t.path) for t in scene.tractions],
    )
    if setup is not None:
        setup(problem)
    if scene.contacts:
        from .contact import MortarContact

        for i, pair in enumerate(scene.contacts):
            problem.add_contact(MortarContact.from_pair(problem, pair, key=f"contact[{i}]"))
    warn_unheld_bodies(problem)
    warn_unwritten_fields(scene, problem)
    return problem, mesh_data


def warn_unwritten_fields(scene: Scene, problem) -> None:
    """Log a warning for each field that ``[output] fields`` names and the run does not
    write (local): the contact fields without a ``[[contact]]`` pair, and
    ``"tangential_traction"`` (with ``slip``) where every pair is frictionless. Not where
    the list is the default, all of :data:`~dolfinx_mortar.scene.OUTPUT_FIELDS` (the
    fields that apply)."""
    from .scene import OUTPUT_FIELDS

    fields = scene.output.fields
    if tuple(fields) == OUTPUT_FIELDS:
        return
    for name in fields:
        if name != "displacement" and not problem.contacts:
            log.warning("output.fields: %r is not written: the scene has no [[contact]] pair", name)
        elif name == "tangential_traction" and not any(
            getattr(c, "frictional", False) for c in problem.contacts
        ):
            log.warning(
                "output.fields: 'tangential_traction' is not written: every [[contact]] pair "
                "is frictionless (friction = 0 models no tangential traction, nor slip)"
            )


def warn_unheld_bodies(problem) -> None:
    """Log one warning per body with rigid motions that neither its Dirichlet conditions
    nor its contact pairs can hold (:meth:`ContactProblem.unheld_motions`; collective at
    the first call). Not an error: where no load acts along such a motion the direct
    solver may still find one of the many solutions (docs/scenes.md), but a body that a
    load or a contact force pushes along it drifts, and the run stops. Then one warning
    per group of bodies joined by contact that nothing holds against a rigid motion of
    all of them together (:meth:`ContactProblem.unheld_joint_motions`: a shrink fit with
    no [[dirichlet]] at all stopped after 6 cutbacks, warned of nothing)."""
    element = {t.name for t in problem.contacts if getattr(t, "integration", "") == "element"}
    for body in problem.unheld_motions():
        pairs = [name for name in body.pairs if name in element]
        log.warning("%s", unheld_text(body, problem.gdim, pairs))
    for group in problem.unheld_joint_motions():
        log.warning("%s", joint_text(group, problem.gdim))
    for body in problem.stick_only_at_start():
        log.warning("%s", stick_only_text(body, problem.gdim))


def stick_only_text(body, gdim: int) -> str:
    """The one line that names a body of :meth:`ContactProblem.stick_only_motions` whose
    frictional pairs have no slave node in contact at t = 0 (local)."""
    from .tangential import HISTORY_GAP_TOL

    return (
        f"{body.describe(gdim)} but for stick: no [[dirichlet]] condition holds these "
        f"motions, nor the normal of its contact ({', '.join(body.pairs)}), and no slave "
        f"node of the pair is in contact at t = 0 (mixed gap <= {HISTORY_GAP_TOL:g} h); "
        "stick holds nothing at nodes that close within a step, so the step where the "
        "contact forms leaves the body free along them (it may escape, and the run stop): "
        "prescribe these components with [[dirichlet]], or start the bodies in contact"
    )


def unheld_text(body, gdim: int, element_pairs=()) -> str:
    """The one line that names an :class:`~dolfinx_mortar.problem.UnheldBody` and why
    nothing holds it (local). ``element_pairs``: those of the body's pairs that take
    element integration, whose quadrature error on non-matching meshes leaves a small
    force along the free motions (the contact forces' patch-test error, a few %: a
    probe's frictionless stack of three blocks, the middle one held by contact alone and
    pressed normal to it, stopped after 6 cutbacks with the middle block drifted, and
    completed with segment integration); the line then says so and offers segments."""
    if body.pairs:
        contact = (
            f"and its frictionless contact ({', '.join(body.pairs)}) cannot: they keep "
            "every gap of the pair"
        )
    else:
        contact = "and it is in no contact pair"
    small_load, segments = "", ""
    if element_pairs:
        names = ", ".join(element_pairs)
        small_load = (
            "; element integration's quadrature error on non-matching meshes is such a "
            "load, a small one"
        )
        segments = f', or, where no load acts along them, integration = "segment" for {names}'
    return (
        f"{body.describe(gdim)}: no [[dirichlet]] condition holds these motions, {contact}; "
        "the Jacobian is singular along them, and the run may fail (it does where a load "
        f"pushes the body along them{small_load}): hold them with [[dirichlet]] "
        f"components{segments}"
    )


def joint_text(group, gdim: int) -> str:
    """The one line that names an :class:`~dolfinx_mortar.problem.UnheldGroup`, bodies
    joined by contact with rigid motions that nothing holds when they make them together
    (local)."""
    return (
        f"{group.describe(gdim)}: no [[dirichlet]] condition holds these motions of the "
        f"bodies moving as one, and their contact ({', '.join(group.pairs)}) cannot, "
        "frictionless or not: moving every body alike keeps every gap; the Jacobian is "
        "singular along them, and the run may fail (it does where a load or the contact's "
        "forces push the bodies along them): hold one of the bodies with [[dirichlet]] "
        "components"
    )


def solver_settings(scene: Scene):
    """The :class:`~dolfinx_mortar.solver.SolverSettings` of the scene's ``[solver]``
    (its ``[solver.petsc]`` with the command line's options merged in by the caller)."""
    from .solver import SolverSettings

    so = scene.solver
    return SolverSettings(
        so.rtol,
        so.atol,
        so.max_it,
        so.linear,
        so.line_search,
        dict(so.petsc),
        step_depth_limit=so.step_depth_limit,
    )


def check_solver(scene: Scene, problem) -> None:
    """Set up the Newton solver that :func:`run` would use on ``problem`` and free it
    again, without solving (collective): raises SceneError on every rank where PETSc
    rejects the scene's PETSc options or the solver refuses one (the same checks as
    :func:`run`'s, :class:`~dolfinx_mortar.solver.NewtonSolver`; for ``check``)."""
    from .solver import NewtonSolver

    NewtonSolver(problem, solver_settings(scene)).destroy()


def _law_origin(name: str) -> str:
    """``module.qualname (file)`` of the psi registered under ``name``."""
    import inspect

    psi = registered_law(name)
    where = f"{getattr(psi, '__module__', '?')}.{getattr(psi, '__qualname__', repr(psi))}"
    try:
        return f"{where} ({inspect.getsourcefile(psi)})"
    except TypeError:  # not a Python function (a builtin, a C callable)
        return where


def modelled(scene: Scene, problem) -> dict:
    """What the run models (summary.json ``modelled``)."""
    from .solver import FIRST_CONTACT_DEPTH_LIMIT

    return {
        "dimension": problem.gdim,
        "kinematics": scene.kinematics,
        "materials": {m.region: m.model for m in scene.materials},
        # the registered laws the materials name: where their psi is defined
        "laws": {m.model: _law_origin(m.model) for m in scene.materials if registered_law(m.model)},
        # linear: every region linear-elastic, stiffness assembled once (problem.LinearBulk)
        "bulk": "linear" if problem.linear_bulk is not None else "nonlinear",
        "displacement_degree": problem.degree,
        "cell_type": problem.mesh_data.info.get("cell_type"),
        "contact_pairs": {c.name: c.describe() for c in problem.contacts},
        "friction": any(getattr(c, "frictional", False) for c in problem.contacts),
        # every Jacobian symmetric: MUMPS factorizes LDLᵀ instead of LU (solver docs)
        "jacobian_symmetric": problem.symmetric_jacobian,
        "step_depth_limit": scene.solver.step_depth_limit,
        # the limit of first-contact solves, where step_depth_limit is 0 (solver docs)
        "first_contact_depth_limit": (
            0.0 if scene.solver.step_depth_limit > 0.0 else FIRST_CONTACT_DEPTH_LIMIT
        ),
    }


def run(
    scene: Scene,
    comm,
    out_dir: Path | None = None,
    progress=None,
    setup=None,
    round_off: bool = False,
) -> dict:
    """Run ``scene`` (collective). Returns the summary dictionary (also written to summary.json).

    ``progress(step, record)`` is called on every rank after each converged step (the
    problem holds the converged state); ``setup(problem)`` see :func:`prepare`. The
    problem's PETSc objects are freed at the end (:meth:`ContactProblem.destroy`),
    except where ``setup`` was given: the caller then holds the problem (to read it
    after the run) and frees it with ``problem.destroy()``.
    ``round_off``: each step's record also holds ``residual_round_off``, the round-off
    level of the residual at the converged state
    (:meth:`~dolfinx_mortar.problem.ContactProblem.residual_round_off`: three more
    residual evaluations per step), against which the demos read ``residual_norms``.
    Raises SceneError before writing anything when the input is bad (the output
    directory too: checked before the set-up; an ``out_dir`` that is neither a string
    nor a ``pathlib.Path`` a SceneTypeError keyed ``out_dir``), TypeError when ``scene``
    is not a :class:`~dolfinx_mortar.scene.Scene`, ``comm`` not an mpi4py communicator,
    or ``progress`` or ``setup`` neither callable nor None, and OutputError on every rank where the
    initial state cannot be written (a full disk, a surface file that cannot be set up,
    an OSError of rank 0's): summary.json then says "failed" and the error with
    :data:`SETUP_FAILURE`, and nothing else of the run is left
    (:meth:`OutputWriter.fail_start`); the exception's message is that error, plus why
    where summary.json could not be written either, and its ``summary`` attribute the
    summary. A Ctrl-C there: summary.json says "interrupted by …", as in the steps. A
    run that stops (a step that fails after its cutbacks, an option PETSc refuses in the
    solve, output that cannot be written after a step: OutputError on every rank)
    raises nothing: the summary's
    ``status`` is then "failed" and ``error`` says why (logged at INFO only: the caller
    reports it, as the command line does in one line). Any other exception in the steps
    (one that ``progress`` raises, KeyboardInterrupt) goes on to the caller after
    summary.json has said "failed" and "interrupted by …" (:meth:`OutputWriter.abandon`);
    where ``progress`` raises on some ranks only, the others raise a RuntimeError that
    names the rank and the exception (:func:`_progress_on_every_rank`). SIGTERM from the
    first write on (where its handler is the default, SIG_DFL: the host's own stays in
    force) stops the run at the next Newton iteration on every rank; the unfinished step
    is abandoned, the finished ones kept, summary.json says "failed" and
    :func:`terminated_text`, and :class:`~dolfinx_mortar.errors.Terminated` (a
    SystemExit, code 143) goes on to the caller (the handler put back first).

    While it runs, the run holds ``<out_dir>/.dolfinx_mortar.lock``
    (:class:`~dolfinx_mortar.output.OutputLock`; removed when ``run`` returns or raises):
    a run into a directory that another live run holds raises SceneError on every rank,
    before it writes anything ("another run is writing there"). Runs at the same time,
    a parameter sweep on ``MPI.COMM_SELF`` too, each need an output directory of their
    own (a dict scene's default is ``<base_dir>/results/scene`` for every one); the lock
    is removed also when SIGTERM stops the run.
    """
    from .output import OutputLock, OutputWriter, check_out_dir
    from .solver import NewtonSolver

    _check_scene(scene, "run", comm, progress=progress, setup=setup)
    t_setup = perf_counter()
    key = "out_dir" if out_dir is not None else "output.dir"
    out_dir = path_argument(out_dir, key) if out_dir is not None else scene.output.dir
    check_out_dir(out_dir, key, comm, [pair.slave for pair in scene.contacts])
    problem, _ = prepare(scene, comm, setup)
    settings = solver_settings(scene)
    summary = {
        "scene": scene.title,
        "source": str(scene.source),
        "modelled": modelled(scene, problem),
        "ranks": comm.size,
        "dofs": problem.num_dofs,
        "versions": software_versions(),
        "steps": [],
    }
    writer = OutputWriter(out_dir, problem, summary, scene.output.fields)
    newton = NewtonSolver(problem, settings)
    summary["modelled"]["linear_solver"] = newton.linear_solver
    # the lock once the set-up has found no error: a refused run touches nothing there
    try:  # SceneError on every rank where another run writes there (it started meanwhile)
        lock = OutputLock(comm, out_dir, key)
    except SceneError:
        newton.destroy()
        if setup is None:
            problem.destroy()
        raise
    writer.lock = lock  # its file holds the reserve of room for the final summary.json
    try:
        return _run_steps(scene, comm, problem, writer, newton, progress, setup, round_off, t_setup)
    finally:  # also after an exception, Ctrl-C, SIGTERM (Terminated): rank 0 releases it
        lock.release()


def _run_steps(scene, comm, problem, writer, newton, progress, setup, round_off, t_setup):
    """:func:`run` from its writer and solver on (collective), the output directory held;
    returns the summary."""
    from .solver import LoadStepper

    totals = {
        "search": 0.0,
        "contact_assembly": 0.0,
        "bulk_assembly": 0.0,
        "linear_solve": 0.0,
        "total": 0.0,
    }
    problem.set_time(0.0)
    problem.warm_up()
    # from the first write on, SIGTERM stops the run at the next Newton iteration on
    # every rank (errors.stops_on_signals); the handler in force before is put back
    # the set-up ends where the output starts (the writer times its own: timings.output)
    totals["setup"] = perf_counter() - t_setup
    with stops_on_signals(comm):
        try:
            writer.start()
        except OutputError as exc:  # on every rank: summary.json says so, the caller is told
            try:  # (the CLI: one line, exit status 1)
                error = writer.fail_start(f"{exc} {SETUP_FAILURE}", totals)
            finally:
                newton.destroy()
                if setup is None:
                    problem.destroy()
            failed = OutputError(error)
            failed.summary = writer.summary
            raise failed from None
        except BaseException as exc:  # Ctrl-C, an error of some ranks: as in the steps
            try:
                writer.abandon(f"interrupted by {type(exc).__name__}: {exc}")
            finally:
                newton.destroy()
                if setup is None:
                    problem.destroy()
            raise

        mark = [0.0]  # when the set-up or the last converged step ended

        def on_step(step, res):
            record = step_record(problem, res)
            if round_off:
                record["residual_round_off"] = problem.residual_round_off()
            for k in ("search", "contact_assembly", "bulk_assembly", "linear_solve", "total"):
                totals[k] += res.timings.get(k, 0.0)
            writer.write_step(step, res.t, record)
            if progress is not None:
                _progress_on_every_rank(comm, progress, step, record)
            mark[0] = perf_counter()

        stepper = LoadStepper(
            problem,
            newton,
            scene.steps.t_end,
            scene.steps.n,
            scene.steps.max_cutbacks,
            scene.steps.output_times,
            on_step=on_step,
        )
        status, error, terminated = "ok", None, None
        mark[0] = perf_counter()
        try:
            stepper.run()
        except ConvergenceError as exc:
            status, error = "failed", str(exc)
            # the step that stopped the run (its failed attempts and cutbacks): not in a step
            totals["unfinished"] = perf_counter() - mark[0]
            log.info("run stopped: %s", exc)
        except PETSc.Error as exc:
            # an option PETSc accepted when the solver was set up but refuses in the solve
            # (a MUMPS ICNTL out of range: mat_mumps_icntl_7 = 99): a clean stop where every rank
            # failed alike, otherwise the exception (the command line then aborts every rank)
            if not every_rank_arrives(comm, PETSC_ERROR_WAIT):
                raise
            lines = compat.petsc_error_lines(exc)
            status = "failed"
            totals["unfinished"] = perf_counter() - mark[0]
            error = (
                f"PETSc failed in the solve ({lines[0]}: {lines[-1]}); check the PETSc "
                "options of [solver.petsc] and the command line"
            )
            log.info("run stopped: %s", error)
        except OutputError as exc:  # on every rank: a full disk, a quota
            status, error = "failed", str(exc)
            totals["unfinished"] = perf_counter() - mark[0]
            log.info("run stopped: %s", exc)
        except Terminated as exc:  # SIGTERM, on every rank at the same Newton iteration
            status, terminated = "failed", exc
            error = exc.message = terminated_text(exc.signum, writer.summary["steps"])
            totals["unfinished"] = perf_counter() - mark[0]
            log.info("run stopped: %s", error)
        except BaseException as exc:  # a progress callback's exception, KeyboardInterrupt
            writer.abandon(f"interrupted by {type(exc).__name__}: {exc}")
            exc.summary_kept = True  # for the command line's message
            raise
        finally:
            newton.destroy()
            if setup is None:  # otherwise the caller holds the problem (and frees it)
                problem.destroy()
        try:
            writer.finish(status, error, totals)
        except OutputError as exc:  # summary.json could not say so: the caller is told
            if status == "ok":
                writer.summary["status"], writer.summary["error"] = "failed", str(exc)
        if terminated is not None:  # summary.json says so: the caller ends (exit status 143)
            terminated.summary_kept = True
            raise terminated
        return writer.summary


#: What summary.json's ``error`` (and the caller's OutputError) adds to the reason where
#: the output failed before the initial state was written (:meth:`OutputWriter.fail_start`).
SETUP_FAILURE = "(at set-up, before the initial state was written)"


def terminated_text(signum: int, steps: list) -> str:
    """summary.json's ``error`` of a run that the signal ``signum`` stopped, given the
    records of its finished steps (local)."""
    import signal

    name = signal.Signals(signum).name
    k = len(steps) + 1
    kept = f"steps 1..{k - 1} kept (to t = {steps[-1]['t']:g})" if steps else "no step finished"
    return f"terminated by {name} during step {k}; {kept}"


def _progress_on_every_rank(comm, callback, *args) -> None:
    """``callback(*args)`` on every rank; where it raises on some ranks (any exception,
    KeyboardInterrupt and SystemExit too), it goes on there and every other rank raises
    RuntimeError naming the first such rank and its exception (collective: one gather). A
    callback that raised on one rank left the others in the next step's collectives and
    the job hung, with no traceback."""
    try:
        callback(*args)
    except BaseException as exc:
        first_on_any_rank(comm, f"{type(exc).__name__}: {exc}")
        raise
    found, rank, _ = first_on_any_rank(comm, None)
    if found is not None:
        raise RuntimeError(f"the progress callback raised on rank {rank}: {found}")


#: Seconds the ranks wait for each other after a PETSc error in the solve before the
#: exception goes on (a rank-local error would otherwise leave the others waiting).
PETSC_ERROR_WAIT = 30.0


def step_record(problem, res) -> dict:
    """The summary.json entry of a converged step (collective: reactions and contact sums)."""
    rec = {
        "t": res.t,
        "converged": True,
        "newton_iterations": res.newton_iterations,
        "residual_norms": res.residual_norms,
        "uzawa_rounds": res.uzawa_rounds,
        "uzawa": res.uzawa,
        "cutbacks": res.cutbacks,
        "full_step_solves": res.full_step_solves,
        "full_step_restarts": res.full_step_restarts,
        "backtracked_solves": res.backtracked_solves,
        "predictor_failures": res.predictor_failures,
        "carried_retries": res.carried_retries,
        "failed_attempt_iterations": res.all_iterations - int(np.sum(res.newton_iterations)),
        "reused_factorizations": res.reused_factorizations,
        "failed_reuses": res.failed_reuses,
        "ldlt_fallbacks": res.ldlt_fallbacks,
        "limited_steps": res.limited_steps,
        "state_predictions": res.state_predictions,
        "linear_iterations": res.linear_iterations,
        "reactions": problem.reactions(),
        "contact_force": {},
        "max_penetration": 0.0,
        "active_nodes": 0,
        "stick_nodes": 0,
        "slip_nodes": 0,
    }
    for term in problem.contacts:
        s = term.statistics()
        rec["contact_force"][term.name] = s["force"]
        rec["max_penetration"] = max(rec["max_penetration"], s["max_penetration"])
        for k in ("active_nodes", "stick_nodes", "slip_nodes"):
            rec[k] += s[k]
        if "dissipation" in s:
            rec.setdefault("dissipation", 0.0)
            rec["dissipation"] += s["dissipation"]
    rec["wall_time"] = res.timings["total"]
    rec["timings"] = {
        k: res.timings.get(k, 0.0)
        for k in ("search", "contact_assembly", "bulk_assembly", "linear_solve", "total")
    }
    return rec
