"""Reading meshes: gmsh ``.msh`` files or built-in generators, with physical names.

gmsh runs on rank 0 only; the physical names and any error are broadcast, so a
bad mesh gives the same :class:`~dolfinx_mortar.errors.SceneError` on every rank
before any further collective call.
"""

from __future__ import annotations

import contextlib
import logging
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from . import compat
from .errors import SceneError, file_problem

# moved to gmsh_session (session 54: dolfinx-free, for `dolfinx-mortar generators`)
from .gmsh_session import GMSH_OPTIONS, gmsh_model, import_gmsh  # noqa: F401

log = logging.getLogger(__name__)

# gmsh element types accepted as cells: (topological dim, name)
_SUPPORTED_CELLS = {
    2: (2, "triangle P1"),
    9: (2, "triangle P2"),
    3: (2, "quadrilateral Q1"),
    10: (2, "quadrilateral Q2 (9 nodes)"),
    4: (3, "tetrahedron P1"),
    11: (3, "tetrahedron P2"),
    5: (3, "hexahedron Q1"),
    12: (3, "hexahedron Q2 (27 nodes)"),
}


@dataclass
class MeshData:
    """A distributed mesh with its tags and the physical names.

    Attributes
    ----------
    mesh: dolfinx mesh (gdim = tdim = 2 or 3).
    cell_tags, facet_tags: dolfinx MeshTags of the physical groups.
    cell_groups, facet_groups: physical name -> tag value.
    info: what rank 0 read (cell type, counts, the groups without elements or without a
        name), for the summary and the scene checks.
    """

    mesh: object
    cell_tags: object
    facet_tags: object
    cell_groups: dict[str, int]
    facet_groups: dict[str, int]
    info: dict = field(default_factory=dict)

    @property
    def gdim(self) -> int:
        return self.mesh.geometry.dim


def _element_name(gmsh, etype: int) -> str:
    """A gmsh element type for messages: ``triangle P1`` where supported, else gmsh's
    family with its node count and order (``10-node triangle (order 3)``)."""
    if etype in _SUPPORTED_CELLS:
        return _SUPPORTED_CELLS[etype][1]
    try:
        name, _dim, order, nodes = gmsh.model.mesh.getElementProperties(etype)[:4]
    except Exception:  # gmsh raises bare Exceptions for a type it does not know
        return f"gmsh element type {etype}"
    return f"{nodes}-node {name.split()[0].lower()} (order {order})"


def _outside_message(gmsh, name: str, dim: int, group_nodes, cell_nodes) -> str:
    """The error for a physical group of dimension ``dim`` < tdim whose elements use nodes
    (gmsh tags, ``group_nodes``) that no element of a physical group of cells uses
    (``cell_nodes``). Either a body has no physical group of cells, or the mesh is not
    conforming: the group's nodes duplicate cell nodes at the same positions (a surface
    meshed or extruded apart from its volume; gmsh's ``removeDuplicateNodes`` merges
    them). Rank 0 only."""
    loose = np.setdiff1d(group_nodes, cell_nodes)
    tags, coords, _ = gmsh.model.mesh.getNodes()
    tags = np.asarray(tags, np.int64)
    coords = np.asarray(coords).reshape(-1, 3)
    order = np.argsort(tags)
    x_loose = coords[order[np.searchsorted(tags, loose, sorter=order)]]
    x_cells = coords[order[np.searchsorted(tags, np.unique(cell_nodes), sorter=order)]]
    twins = 0
    if x_cells.size:
        tol = 1e-12 * max(float(np.ptp(coords, axis=0).max()), 1e-300)
        twins = int(np.sum(cKDTree(x_cells).query(x_loose)[0] <= tol))
    where = ", ".join(f"{v:.6g}" for v in x_loose[0])
    head = (
        f"the physical group {name!r} (dimension {dim}) uses {loose.size} node(s) that no "
        f"element of a physical group of cells uses (node {loose[0]} at ({where}))"
    )
    if twins:
        return (
            f"{head}; {twins} of them lie where a cell's node lies: the mesh is not "
            "conforming there (duplicate nodes; gmsh.model.mesh.removeDuplicateNodes() "
            "merges them)"
        )
    return f"{head}: it lies outside every physical group of cells; give every body a physical group of cells"


def _inspect_model(gmsh) -> dict:
    """Rank 0: physical names and cell type of the current gmsh model; raise SceneError if unusable."""
    groups = gmsh.model.getPhysicalGroups()
    if not groups:
        raise SceneError("mesh", "the mesh has no physical groups (name the bodies and surfaces)")
    dims = [d for d, _ in groups]
    tdim = max(dims)
    if tdim not in (2, 3):
        raise SceneError("mesh", f"no 2D or 3D physical group of cells (highest dimension {tdim})")
    cell_types = set()
    for d, tag in groups:
        if d != tdim:
            continue
        for ent in gmsh.model.getEntitiesForPhysicalGroup(d, tag):
            types, _, _ = gmsh.model.mesh.getElements(d, ent)
            cell_types.update(int(t) for t in types)
    if not cell_types:
        raise SceneError(
            "mesh", "the physical groups of cells contain no elements (mesh not generated?)"
        )
    if len(cell_types) > 1:
        names = ", ".join(_element_name(gmsh, t) for t in sorted(cell_types))
        raise SceneError(
            "mesh", f"mixed cell types ({names}) are not supported: one cell type per mesh"
        )
    ctype = cell_types.pop()
    if ctype not in _SUPPORTED_CELLS:
        supported = ", ".join(name for _, name in _SUPPORTED_CELLS.values())
        raise SceneError(
            "mesh",
            f"unsupported cells: {_element_name(gmsh, ctype)} (gmsh element type {ctype}); "
            f"supported: {supported}",
        )
    # a physical group without elements (e.g. a discrete entity that was never meshed)
    # breaks dolfinx's model_to_mesh; load_mesh drops it from the model but keeps its
    # name, so that using it gives a clear error later (e.g. "contact surface is empty")
    empty = []
    for d, tag in groups:
        count = 0
        for ent in gmsh.model.getEntitiesForPhysicalGroup(d, tag):
            _, elem_tags, _ = gmsh.model.mesh.getElements(d, ent)
            count += sum(len(t) for t in elem_tags)
        if count == 0:
            empty.append((d, tag))
    # dolfinx 0.5.2's model_to_mesh crashes (SIGSEGV on every rank) on a physical group
    # of facets whose elements are not on any cell of a physical group of cells (a body
    # left without a physical group, its boundary named)
    nodes = {}
    for d, tag in groups:
        for ent in gmsh.model.getEntitiesForPhysicalGroup(d, tag):
            found = [np.asarray(n, np.int64) for n in gmsh.model.mesh.getElements(d, ent)[2]]
            nodes.setdefault((d, tag), []).extend(found)
    cell_nodes = np.concatenate(
        [np.zeros(0, np.int64)] + [n for (d, _), ns in nodes.items() if d == tdim for n in ns]
    )
    for (d, tag), ns in nodes.items():
        if d < tdim and ns and not np.isin(np.concatenate(ns), cell_nodes).all():
            name = gmsh.model.getPhysicalName(d, tag) or str(tag)
            raise SceneError(
                "mesh", _outside_message(gmsh, name, d, np.concatenate(ns), cell_nodes)
            )
    names: dict[tuple[int, int], str] = {}
    unnamed = []  # groups without a physical name: known by their tag
    for d, tag in groups:
        name = gmsh.model.getPhysicalName(d, tag)
        if not name:
            name = str(tag)
            unnamed.append(name)
        twin = next((dt for dt, n in names.items() if n == name and dt[0] == d), None)
        if twin is not None:
            raise SceneError(
                "mesh",
                f"the physical name {name!r} is given to two groups of dimension {d} "
                f"(tags {twin[1]} and {tag}): names must be unique",
            )
        names[(d, tag)] = name
    # dolfinx keeps one tag per cell and per facet: a cell in two groups of cells broke
    # model_to_mesh (heap corruption, a crash or a hang, in `check` too), and a facet in
    # two groups of facets was silently left in one of them (a traction on the other
    # acted on nothing)
    owner: dict[tuple[int, int], str] = {}
    for (d, tag), name in names.items():
        if d < tdim - 1:
            continue
        for ent in gmsh.model.getEntitiesForPhysicalGroup(d, tag):
            other = owner.setdefault((d, int(ent)), name)
            if other != name:
                what = "cells" if d == tdim else "facets"
                raise SceneError(
                    "mesh",
                    f"the physical groups {other!r} and {name!r} share {what} (entity "
                    f"{ent} of dimension {d}): a mesh can give each of its {what} one "
                    f"physical group only (drop the overlapping group, e.g. a whole-domain "
                    "group, or split the entity)",
                )
    cell_groups = {n: t for (d, t), n in names.items() if d == tdim}
    facet_groups = {n: t for (d, t), n in names.items() if d == tdim - 1}
    _, coords, _ = gmsh.model.mesh.getNodes()
    coords = np.asarray(coords).reshape(-1, 3)
    if coords.size == 0:
        raise SceneError("mesh", "the mesh has no nodes")
    gdim = 3 if tdim == 3 else 2
    if tdim == 2 and np.abs(coords[:, 2]).max() > 1e-12 * max(1.0, np.abs(coords).max()):
        raise SceneError("mesh", "a 2D mesh must lie in the plane z = 0")
    return {
        "tdim": tdim,
        "gdim": gdim,
        "cell_type": _SUPPORTED_CELLS[ctype][1],
        "cell_groups": cell_groups,
        "facet_groups": facet_groups,
        "num_nodes": int(coords.shape[0]),
        "all_groups": {f"{d}:{t}": n for (d, t), n in names.items()},
        "empty_groups": [names[dt] for dt in empty],
        "unnamed_groups": unnamed,
        "empty_dimtags": empty,
    }


def _contiguous_node_tags(gmsh) -> None:
    """Renumber the nodes of the current gmsh model 1 … N where their tags are not so
    (rank 0). A .msh file may number its nodes with gaps (another mesher, a file edited
    by hand), which gmsh reads; dolfinx 0.5.2's model_to_mesh asserts tags 1 … N and
    such a mesh stopped the run with an AssertionError traceback."""
    tags = np.asarray(gmsh.model.mesh.getNodes()[0], np.int64)
    if tags.size and not np.array_equal(np.sort(tags), np.arange(1, tags.size + 1)):
        log.info("mesh: node tags renumbered 1 … %d (the file's had gaps)", tags.size)
        gmsh.model.mesh.renumberNodes()


#: A cell is degenerate where its measure (area, volume) is at most this fraction of
#: d-th power of its size (its nodes' bounding box diagonal): collinear or coincident
#: nodes, up to round-off. A well-shaped triangle has 0.2 to 0.4 (0.43 equilateral).
DEGENERATE_CELL_RATIO = 1e-10


def _check_geometry(gmsh, info: dict, key: str) -> None:
    """Rank 0: raise SceneError (``key``) where a node of the current gmsh model has a
    non-finite coordinate, or a cell of a physical group of cells has zero measure
    (:data:`DEGENERATE_CELL_RATIO`): both passed ``check`` and failed in the run, with a
    traceback (LinAlgError) or a misleading hint. The measure is gmsh's |det J| summed over
    a Gauss rule, O(cells) (whatever the orientation of the cells' nodes)."""
    tags, coords, _ = gmsh.model.mesh.getNodes()
    coords = np.asarray(coords).reshape(-1, 3)
    bad = ~np.isfinite(coords).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        x = ", ".join(f"{v:g}" for v in coords[i])
        raise SceneError(
            key,
            f"{int(bad.sum())} node(s) with a non-finite coordinate, e.g. node {int(tags[i])} ({x})",
        )
    # node tag -> row of coords by a sorted search (tags may be sparse: a dense index
    # sized by the largest tag asked for 80 GB at tags of 1e10)
    tags = np.asarray(tags, np.int64)
    order = np.argsort(tags, kind="stable")
    sorted_tags = tags[order]
    tdim = info["tdim"]
    measure = "area" if tdim == 2 else "volume"
    for name, tag in info["cell_groups"].items():
        for ent in gmsh.model.getEntitiesForPhysicalGroup(tdim, tag):
            types, elems, nodes = gmsh.model.mesh.getElements(tdim, ent)
            for etype, etags, enodes in zip(types, elems, nodes, strict=True):
                if len(etags) == 0:
                    continue
                points, weights = gmsh.model.mesh.getIntegrationPoints(etype, "Gauss2")
                _, det, _ = gmsh.model.mesh.getJacobians(etype, points, tag=ent)
                det = np.abs(np.asarray(det).reshape(len(etags), len(weights)))
                vol = det @ np.asarray(weights)
                rows = order[np.searchsorted(sorted_tags, np.asarray(enodes, np.int64))]
                x = coords[rows].reshape(len(etags), -1, 3)
                size = np.linalg.norm(x.max(axis=1) - x.min(axis=1), axis=1)
                degenerate = ~(vol > DEGENERATE_CELL_RATIO * size**tdim)
                if degenerate.any():
                    e = int(etags[int(np.flatnonzero(degenerate)[0])])
                    raise SceneError(
                        key,
                        f"{int(degenerate.sum())} cell(s) of group {name!r} with zero "
                        f"{measure} (nodes collinear{'' if tdim == 2 else ' or coplanar'} "
                        f"or coincident), e.g. element {e}",
                    )


class _HideGroups:
    """A gmsh model whose ``getPhysicalGroups`` leaves out the given (dim, tag) pairs."""

    def __init__(self, model, hidden):
        self._model = model
        self._hidden = {tuple(dt) for dt in hidden}

    def getPhysicalGroups(self, dim=-1):
        return [dt for dt in self._model.getPhysicalGroups(dim) if tuple(dt) not in self._hidden]

    def __getattr__(self, name):
        return getattr(self._model, name)


def _descriptors_on(file) -> set[int] | None:
    """The file descriptors of this process open on ``file`` (the same device and
    inode: another path or a hard link to it counts); None where the process's
    descriptors cannot be listed (no ``/proc/self/fd``: not Linux)."""
    try:
        target = os.stat(file)
        names = os.listdir("/proc/self/fd")
    except OSError:
        return None
    fds = set()
    for name in names:
        try:
            st = os.fstat(int(name))
        except (OSError, ValueError):  # closed since the listing (the listing's own)
            continue
        if (st.st_dev, st.st_ino) == (target.st_dev, target.st_ino):
            fds.add(int(name))
    return fds


def _close_left_open(file, before: set[int] | None) -> None:
    """Close the descriptors on ``file`` that a failed ``gmsh.open`` left open: those
    open on it now and not in ``before`` (:func:`_descriptors_on` before the call).

    gmsh 4.8 (Debian bookworm's 4.8.4) throws out of its readers before their
    ``fclose``: its .msh reader at a corrupt section (``$Nodes`` that it cannot read),
    and its .geo parser (``ParseFile``), which reads any file it does not recognise, at
    the first syntax error (such files are refused before gmsh since, by
    :func:`_msh_problem`). Every failed ``gmsh.open`` of a corrupt or truncated .msh
    left one descriptor on that file open in the calling process (a sweep over many
    files, a GUI, ran out of descriptors). Descriptors open before the
    call (a host's own handle on the same file) are left alone. The leaked ``FILE``
    keeps its (small) buffer; by gmsh 4.8's source its parser neither reads nor closes
    it again (it reads through ``gmsh_yyin``, which each parse sets). Does nothing
    where the descriptors cannot be listed (``before`` None: no /proc). Rank 0, local."""
    if before is None:
        return
    for fd in sorted((_descriptors_on(file) or set()) - before):
        with contextlib.suppress(OSError):
            os.close(fd)
        log.debug("closed descriptor %d on %s that gmsh left open", fd, file)


#: how many bytes of a mesh file :func:`_msh_problem` reads to find its first line
MSH_HEAD_BYTES = 256


def _msh_problem(file) -> str | None:
    """Why ``file`` is not a gmsh .msh file, or None: a .msh file (format 2.2 or 4.1,
    ASCII or binary) begins with a section line, ``$MeshFormat`` (or ``$Comments``), at
    its first byte (gmsh reads one with white space before it as a .geo script too, and
    fails at the ``$``). gmsh reads any other file as a .geo script and runs it:
    its option assignments (in a host's gmsh session they outlived the run), ``Mesh``
    commands, ``SystemCall`` (a shell command) and ``Exit`` (the process ended). Reads
    the first :data:`MSH_HEAD_BYTES` bytes. Local."""
    with open(file, "rb") as fh:
        head = fh.read(MSH_HEAD_BYTES)
    if head.startswith(b"$"):
        return None
    first = head.splitlines()[0] if head.strip() else b""
    if Path(file).suffix.lower() != ".msh":
        return "only gmsh .msh files are read"
    try:
        text = first.decode("utf-8")[:40]
    except UnicodeDecodeError:  # binary: its bytes, escaped (it echoed raw garbage)
        text = None
    shown = repr(text) if text is not None and text.isprintable() else f"with bytes {first[:16]!r}"
    return (
        f"not a gmsh .msh file: it begins {shown}, where a .msh file begins with "
        "$MeshFormat (gmsh would run it as a .geo script)"
    )


@contextlib.contextmanager
def _alone(file):
    """A path to ``file`` in a directory of its own (a symbolic link in a temporary
    directory, removed after), or ``file`` itself where no link can be made. gmsh's
    ``open`` also merges an options file beside the mesh (``<file>.opt``, .geo syntax:
    any command, ``SystemCall`` included), whose settings outlived the run in a host's
    gmsh session; through the link, gmsh finds none. Local."""
    with tempfile.TemporaryDirectory(prefix="dolfinx_mortar_mesh_") as tmp:
        link = Path(tmp) / Path(file).name
        try:
            link.symlink_to(Path(file).resolve())
        except OSError:
            link = Path(file)
        yield link


def load_mesh(
    comm, file: Path | None = None, generator: str | None = None, params=None
) -> MeshData:
    """Read ``file`` (gmsh .msh 2.2/4.1) or build ``generator`` on rank 0 and distribute it.

    Collective on ``comm``. Raises SceneError (on every rank) for a missing,
    unreadable or unusable mesh.
    """
    info = None
    error = None
    session = contextlib.ExitStack()  # rank 0: the gmsh model (gmsh_model), closed after
    if comm.rank == 0:
        gmsh = import_gmsh()  # with the SIGINT handler kept (gmsh 4.8 resets it)

        try:
            session.enter_context(gmsh_model(gmsh))
            if file is not None:
                problem = file_problem(file, "a mesh file")
                if problem is not None:
                    raise SceneError("mesh.file", problem)
                if Path(file).stat().st_size == 0:
                    raise SceneError("mesh.file", f"{file} is empty")
                problem = _msh_problem(file)
                if problem is not None:  # checked first: gmsh runs anything else
                    raise SceneError("mesh.file", f"cannot read {file}: {problem}")
                before = _descriptors_on(file)
                with _alone(file) as path:
                    try:
                        gmsh.open(str(path))
                    except Exception as exc:  # gmsh raises bare Exceptions
                        _close_left_open(file, before)  # gmsh 4.8 leaves the file open
                        if Path(file).suffix.lower() != ".msh":
                            raise SceneError(
                                "mesh.file",
                                f"cannot read {file}: only gmsh .msh files are read",
                            ) from None
                        why = str(exc).replace(str(path), str(file))
                        raise SceneError("mesh.file", f"cannot read {file}: {why}") from None
                _contiguous_node_tags(gmsh)
            else:
                from . import generators

                generators.build(generator, dict(params or {}))
            info = _inspect_model(gmsh)
            _check_geometry(gmsh, info, "mesh.file" if file is not None else "mesh")
        except SceneError as exc:
            error = (exc.key, exc.reason)
        except Exception as exc:  # a generator or gmsh failing: still one clean message
            error = ("mesh", f"{type(exc).__name__}: {exc}")
    error, info = comm.bcast((error, info), root=0)
    if error is not None:
        session.close()
        raise SceneError(*error)
    model = None
    if comm.rank == 0:
        model = gmsh.model
        if info["empty_dimtags"]:
            # gmsh cannot remove physical groups read from a .msh file: hide them instead
            log.info("physical group(s) without elements: %s", ", ".join(info["empty_groups"]))
            model = _HideGroups(gmsh.model, info["empty_dimtags"])
    try:
        mesh, cell_tags, facet_tags = compat.model_to_mesh(model, comm, info["gdim"])
    finally:
        session.close()
    log.info(
        "mesh: %s, %d nodes, cell groups %s, facet groups %s",
        info["cell_type"],
        info["num_nodes"],
        sorted(info["cell_groups"]),
        sorted(info["facet_groups"]),
    )
    return MeshData(mesh, cell_tags, facet_tags, info["cell_groups"], info["facet_groups"], info)
