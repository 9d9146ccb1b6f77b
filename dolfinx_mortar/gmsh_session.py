"""The gmsh session of this package's own models (rank 0 or one rank: no MPI).

:func:`gmsh_model` gives a model of its own for the ``with`` block, in a session it
starts and ends or in a host program's, which it keeps; :func:`gmsh_initialize` and
:func:`keep_sigint_handler` are gmsh 4.8's workarounds that it needs. dolfinx-free (no
dolfinx, no PETSc, no MPI), so that ``dolfinx-mortar generators`` can build the
generators' geometries on rank 0 alone under mpirun (:func:`dolfinx_mortar.generators.
groups`): importing petsc4py there initializes PETSc, a collective that the other ranks,
which print nothing, never joined. Moved here from ``compat`` and ``mesh`` (session 54),
which still export the names.
"""

from __future__ import annotations

import contextlib
import ctypes
import signal
import sys
import threading

__all__ = ["GMSH_OPTIONS", "gmsh_initialize", "gmsh_model", "import_gmsh", "keep_sigint_handler"]


def keep_sigint_handler(action):
    """Call ``action()`` and put back the SIGINT handler it found (returns its result).
    gmsh 4.8 sets SIGINT to SIG_DFL when it is imported and, in ``gmsh.finalize``, to the
    handler it saw then: Ctrl-C killed the process outright (no KeyboardInterrupt, no
    ``finally``, summary.json left "running"), and a host program's own handler was
    replaced. Outside the main thread, where Python cannot set handlers, ``action()``
    alone."""
    handler = signal.getsignal(signal.SIGINT)
    try:
        return action()
    finally:
        if handler is not None and threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, handler)


def gmsh_initialize(gmsh) -> bool:
    """Initialize gmsh unless a session runs already (a host program's); returns whether
    one did. Local (the caller's rank only).

    gmsh 4.8 has no ``isInitialized`` (later versions have, and it is used where
    present), and every other call before ``initialize`` is undefined behaviour: its
    error path reads options that ``initialize`` has not set yet and, by chance, exits
    the process with status 1 and no message (``gmsh.model.list()`` did so in some runs
    of the demos, on rank 0). ``initialize`` in a running session only counts the
    warning "Gmsh has already been initialized" and returns: gmsh's warning count
    (``Msg::_warningCount``) tells, and the warning is kept off the host's terminal by a
    verbosity of 0 (``Msg::_verbosity``) during the call. Where these symbols are not
    found, no session is assumed."""
    is_initialized = getattr(gmsh, "isInitialized", None)
    if is_initialized is not None:
        if is_initialized():
            return True
        gmsh.initialize(["-noenv"], readConfigFiles=False)
        return False
    try:
        warnings = ctypes.c_int.in_dll(gmsh.lib, "_ZN3Msg13_warningCountE")
        verbosity = ctypes.c_int.in_dll(gmsh.lib, "_ZN3Msg10_verbosityE")
    except (AttributeError, ValueError):  # another build of gmsh: no such symbols
        gmsh.initialize(["-noenv"], readConfigFiles=False)
        return False
    before, level = warnings.value, verbosity.value
    verbosity.value = 0
    try:
        gmsh.initialize(["-noenv"], readConfigFiles=False)
    finally:
        verbosity.value = level
    return warnings.value > before


#: the gmsh options that :func:`~dolfinx_mortar.mesh.load_mesh` and the generators set
#: (``generators._baseline_options``), put back after a host program's gmsh session
GMSH_OPTIONS = (
    "General.Terminal",
    "General.Verbosity",
    "Mesh.MeshSizeFromPoints",
    "Mesh.MeshSizeExtendFromBoundary",
    "Mesh.MeshSizeFromCurvature",
    "Mesh.MeshSizeMin",
    "Mesh.MeshSizeMax",
    "Mesh.MeshSizeFactor",
    "Mesh.Algorithm",
    "Mesh.Algorithm3D",
    "Mesh.RecombineAll",
    "Mesh.Recombine3DAll",
    "Mesh.RecombinationAlgorithm",
    "Mesh.SubdivisionAlgorithm",
    "Mesh.ElementOrder",
    "Mesh.SecondOrderLinear",
    "Mesh.SecondOrderIncomplete",
)


@contextlib.contextmanager
def gmsh_model(gmsh):
    """Rank 0: a gmsh model of this package's own, current for the ``with`` block.

    Without a gmsh session, gmsh is initialized here and finalized after (with the
    SIGINT handler put back: :func:`keep_sigint_handler`). In a
    host program's session (a Python caller that uses gmsh itself) the session stays:
    the model is removed after, the host's current model is current again, and the
    options in :data:`GMSH_OPTIONS` get their values back. It finalized the host's
    session before (a helper's probe: its next gmsh call raised). ``gmsh.open`` in the
    block (a mesh file) renames the model after the file: the model removed then is the
    current one, which the block must leave current (``load_mesh`` of a file in a host's
    session raised "Could find model 'dolfinx_mortar'" until session 58). No gmsh call comes
    before ``initialize`` (:func:`gmsh_initialize`): in gmsh 4.8
    that exited the process now and then."""
    hosted = gmsh_initialize(gmsh)
    if hosted:
        current = gmsh.model.getCurrent()
        saved = {key: gmsh.option.getNumber(key) for key in GMSH_OPTIONS}
        name, k = "dolfinx_mortar", 0
        while name in gmsh.model.list():
            k += 1
            name = f"dolfinx_mortar_{k}"
    else:
        name = "dolfinx_mortar"
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.Verbosity", 0)
    gmsh.model.add(name)
    try:
        yield
    finally:
        if hosted:
            # gmsh.open (a mesh file) reads into the current model where it is empty, and
            # names it after the file: the model is ours still, and still current
            if name in gmsh.model.list():
                gmsh.model.setCurrent(name)
            gmsh.model.remove()
            if current in gmsh.model.list():
                gmsh.model.setCurrent(current)
            for key, value in saved.items():
                gmsh.option.setNumber(key, value)
        else:
            keep_sigint_handler(lambda: _finalize(gmsh))


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _finalize(gmsh) -> None:
    """``gmsh.finalize()``, also outside the main thread: gmsh 4.8's ``finalize`` puts
    back the SIGINT handler it saw at its import (``gmsh.oldsig``) with ``signal.signal``,
    which raises ValueError outside the main thread ("signal only works in main thread
    of the main interpreter", after the session had ended). There it is called with
    ``oldsig`` None, which ``finalize`` skips; the handler is not gmsh's to set there."""
    if _in_main_thread() or getattr(gmsh, "oldsig", None) is None:
        gmsh.finalize()
        return
    oldsig, gmsh.oldsig = gmsh.oldsig, None
    try:
        gmsh.finalize()
    finally:
        gmsh.oldsig = oldsig


def _import_gmsh_module():
    """``import gmsh``, also outside the main thread (local). gmsh 4.8's module sets SIGINT
    to SIG_DFL when it is imported (``oldsig = signal.signal(...)``), which raises ValueError
    outside the main thread: a host program that ran the library in a worker thread (a
    thread pool, a GUI) could not load a mesh. There the import runs with
    ``signal.signal`` answering the handler in force without setting it (gmsh records
    it as ``oldsig``; a call of the main thread meanwhile goes through unchanged), and
    ``signal.signal`` is put back after."""
    if _in_main_thread() or "gmsh" in sys.modules:
        import gmsh

        return gmsh
    setter = signal.signal

    def outside_main_thread(signum, handler):
        if _in_main_thread():
            return setter(signum, handler)
        return signal.getsignal(signum)

    signal.signal = outside_main_thread
    try:
        import gmsh
    finally:
        signal.signal = setter
    return gmsh


def import_gmsh():
    """``import gmsh`` with the SIGINT handler kept (:func:`keep_sigint_handler`), in any
    thread (:func:`_import_gmsh_module`)."""
    return keep_sigint_handler(_import_gmsh_module)
