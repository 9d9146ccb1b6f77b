"""Every dolfinx-0.5-specific call of the package, in one place.

A move to a newer dolfinx should only need this module changed. Functions here
are thin: they name the 0.5.2 API (``fem.VectorFunctionSpace``,
``gmshio.model_to_mesh``, ``MeshTags.find``, ``IndexMap.local_range``) and
return plain NumPy arrays.
"""

from __future__ import annotations

import ctypes
import ctypes.util

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc

# the gmsh session's helpers, here before session 54 (dolfinx-free now: gmsh_session.py)
from .gmsh_session import gmsh_initialize, keep_sigint_handler  # noqa: F401


def _import_gmshio():
    from .gmsh_session import import_gmsh

    import_gmsh()  # first: in any thread (gmsh 4.8's import sets SIGINT: main thread only)
    from dolfinx.io import gmshio

    return gmshio


def _gmshio():
    """``dolfinx.io.gmshio``, imported on first use with the SIGINT handler kept
    (:func:`keep_sigint_handler`): it imports gmsh (0.25–0.4 s), which only the mesh
    loading needs, so that importing this module (and the output and problem modules
    that import it) does not. Its ``model_to_mesh`` exists only where gmsh imports."""
    return keep_sigint_handler(_import_gmshio)


__all__ = [
    "vector_space",
    "facet_submesh",
    "model_to_mesh",
    "tagged_entities",
    "global_dof_numbers",
    "owned_dof_count",
    "create_form",
    "sparsity_pattern",
    "cell_geometry_nodes",
    "destroy_vector_wrapper",
    "set_lag_preconditioner",
    "lag_preconditioner_available",
    "option_used",
    "petsc_error_lines",
]


def vector_space(mesh, degree: int):
    """Vector Lagrange space of the given degree on ``mesh`` (block size = gdim)."""
    return fem.VectorFunctionSpace(mesh, ("CG", degree))


#: The cell type of a mesh's facets and their number of vertices, by the mesh's cell type
#: (dolfinx's names).
FACET_CELL = {
    "triangle": ("interval", 2),
    "quadrilateral": ("interval", 2),
    "tetrahedron": ("triangle", 3),
    "hexahedron": ("quadrilateral", 4),
}


def facet_submesh(mesh, facets: np.ndarray):
    """The facets ``facets`` (local indices; ghost facets are skipped, their owners give
    them) of ``mesh`` as a mesh of their own (collective; affine geometry, degree 1), in
    the volume mesh's coordinates (gdim columns): each surface cell stays on the rank
    that owns its facet, with no ghost cells, and each surface vertex is owned by a rank
    that holds one of its surface cells. The surface's input node indices
    (``geometry.input_global_indices``) are the volume mesh's global geometry nodes.

    dolfinx 0.5.2's ``create_submesh`` gave each surface vertex the owner it has in the
    volume mesh, a rank that may hold none of the surface cells around it (a 3-rank
    tetrahedral patch): the XDMF writer takes a node's values from the rank's own cells
    and wrote 0 there. Here ``create_mesh`` builds the surface from each rank's owned
    facets (their nodes as the volume's global geometry indices, the coordinates as each
    rank's owned volume nodes), with a partitioner that keeps every cell on the rank that
    gives it. dolfinx 0.5.2 finds the ranks that share a vertex through the ghost cells
    that the partitioner names (it asks for a layer by facet, and drops it afterwards
    with ``GhostMode.none``; a partitioner that named none left every rank owning its
    own copy of the shared vertices): each cell is named a ghost on every other rank
    whose cells hold one of its vertices (:func:`_ghost_destinations`), a layer by vertex,
    so that vertices shared at a corner only are found as well. No cell moves.

    On a second-order mesh (geometry degree 2: 6-node triangles, 9-node quadrilaterals,
    10-node tetrahedra, 27-node hexahedra) the surface has the facets' own second-order
    geometry (3-node intervals, 6-node triangles, 9-node quadrilaterals): each cell lists
    every geometry node of its facet, the midside (and face-centre) nodes included, in the
    layout ``create_mesh`` takes (:func:`_facet_geometry_nodes`), and the ghost
    destinations account for all of them. Raises RuntimeError (on every rank: the degree
    is the same there) for a geometry degree above 2."""
    from dolfinx.cpp.graph import AdjacencyList_int32
    from dolfinx.cpp.mesh import GhostMode, entities_to_geometry
    from dolfinx.mesh import create_mesh

    comm = mesh.comm
    tdim, gdim = mesh.topology.dim, mesh.geometry.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    owned = np.asarray(facets, dtype=np.int32)
    owned = owned[owned < mesh.topology.index_map(tdim - 1).size_local]
    facet, per_facet = FACET_CELL[mesh.topology.cell_name()]
    degree = mesh.geometry.cmap.degree
    if degree == 1:
        cpp_mesh = getattr(mesh, "_mesh", mesh)  # Debian's 0.5.2 wraps the C++ mesh
        nodes = entities_to_geometry(cpp_mesh, tdim - 1, owned, False)  # local geometry nodes
        nodes = np.asarray(nodes, dtype=np.int32).reshape(owned.size, per_facet)
    elif degree == 2:  # entities_to_geometry gives the vertices' nodes only
        nodes = _facet_geometry_nodes(mesh, owned)
        per_facet = nodes.shape[1]
    else:
        raise RuntimeError(f"facet_submesh: geometry degree {degree} (only 1 and 2)")
    gmap = mesh.geometry.index_map()
    cells = np.asarray(gmap.local_to_global(nodes.reshape(-1)), dtype=np.int64)
    cells = cells.reshape(owned.size, per_facet)
    data, offsets = _ghost_destinations(comm, gmap, nodes)

    def stay(comm_, nparts, dim, cells_, ghost_mode):
        if cells_.num_nodes != owned.size:
            raise RuntimeError("facet_submesh: the partitioner got other cells than given")
        return AdjacencyList_int32(data, offsets)

    x = np.ascontiguousarray(mesh.geometry.x[: gmap.size_local, :gdim])  # in global order
    cell = ufl.Cell(facet, geometric_dimension=gdim)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", cell, degree))
    return create_mesh(comm, cells, x, domain, GhostMode.none, stay)


def _facet_geometry_nodes(mesh, facets: np.ndarray) -> np.ndarray:
    """Every local geometry node of each facet of ``facets`` (local indices), shape
    (n_facets, nodes per facet; int32), in the layout of the facet's own coordinate
    element, which is the order dolfinx 0.5.2's ``create_mesh`` takes (basix's: the
    vertices, then one node per edge in the reference cell's edge order, then the
    interior node: what ``gmshio.cell_perm_gmsh`` turns gmsh's order into). Not
    collective; for a geometry of degree 2 (one node per edge and per quadrilateral face,
    so that no node needs a permutation).

    Each facet's nodes are read from the first cell that holds it (its geometry dofmap,
    whose layout is the coordinate element's, ``create_dof_layout``): its vertices in the
    order of the cell's reference facet (a quadrilateral's in tensor order, as a
    quadrilateral cell has them), then the node of the cell edge that joins each pair of
    them that the facet's reference cell names an edge, then (a quadrilateral facet of a
    27-node hexahedron) the node of the face itself."""
    import basix

    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    mesh.topology.create_connectivity(tdim, tdim - 1)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    c2f = mesh.topology.connectivity(tdim, tdim - 1)
    layout = mesh.geometry.cmap.create_dof_layout()
    name = mesh.topology.cell_name()
    cell_topology = basix.topology(getattr(basix.CellType, name))
    facet_topology = basix.topology(getattr(basix.CellType, FACET_CELL[name][0]))
    table = []  # for each local facet of the cell: its nodes' places in the cell's layout
    for verts in cell_topology[tdim - 1]:
        row = [layout.entity_dofs(0, v)[0] for v in verts]
        for d in range(1, tdim):  # the facet's edges (by its own vertices), then its face
            for sub in facet_topology[d]:
                joined = sorted(verts[i] for i in sub)
                entity = next(e for e, vs in enumerate(cell_topology[d]) if sorted(vs) == joined)
                row += list(layout.entity_dofs(d, entity))
        table.append(row)
    table = np.asarray(table, dtype=np.int32)
    facets = np.asarray(facets, dtype=np.int32)
    cells = np.asarray(f2c.array, dtype=np.int32)[np.asarray(f2c.offsets)[facets]]
    per_cell = len(cell_topology[tdim - 1])
    cell_facets = np.asarray(c2f.array, dtype=np.int32).reshape(-1, per_cell)[cells]
    local = np.argmax(cell_facets == facets[:, None], axis=1)  # each facet's place in its cell
    x_dofs = cell_geometry_nodes(mesh)
    return np.ascontiguousarray(x_dofs[cells[:, None], table[local]], dtype=np.int32)


def _ranges(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """The indices ``starts[i] .. starts[i] + counts[i] - 1`` for each i, concatenated."""
    total = int(counts.sum())
    first = np.repeat(np.cumsum(counts) - counts, counts)
    return np.repeat(starts, counts) + np.arange(total) - first


def _ghost_destinations(comm, gmap, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The destinations of each of this rank's surface cells, whose local geometry nodes
    are the rows of ``nodes`` (n_cells, nodes per cell), as an adjacency list (``data``,
    ``offsets``; int32): this rank, then, sorted, every other rank whose cells hold one of
    the cell's nodes (collective: two ``alltoall``, through each node's owner in ``gmap``,
    the volume mesh's geometry index map, where every rank whose cells hold a node has
    it, owned or ghost)."""
    rank, size = comm.rank, comm.size
    local = np.unique(nodes)
    owners = np.full(local.size, rank, dtype=np.int64)
    ghost = local >= gmap.size_local
    owners[ghost] = np.asarray(gmap.owners)[local[ghost] - gmap.size_local]
    glob = np.asarray(gmap.local_to_global(local.astype(np.int32)), dtype=np.int64)
    order = np.argsort(owners, kind="stable")
    bounds = np.searchsorted(owners[order], np.arange(size + 1))
    asked = comm.alltoall([glob[order[bounds[r] : bounds[r + 1]]] for r in range(size)])
    # at each node's owner: the ranks that asked about it, sorted by node then rank
    g = np.concatenate([np.asarray(a, dtype=np.int64) for a in asked])
    by = np.repeat(np.arange(size), [len(a) for a in asked])
    key = np.lexsort((by, g))
    g, by = g[key], by[key]
    known, first, count = np.unique(g, return_index=True, return_counts=True)
    answers = []
    for a in asked:  # for each node asked: how many ranks, then the ranks
        k = np.searchsorted(known, np.asarray(a, dtype=np.int64))
        answers.append((count[k], by[_ranges(first[k], count[k])]))
    answers = comm.alltoall(answers)
    # (local node, rank holding it) for every node of this rank's cells
    pair_node = np.concatenate(
        [np.repeat(local[order[bounds[r] : bounds[r + 1]]], answers[r][0]) for r in range(size)]
    )
    pair_rank = np.concatenate([answers[r][1] for r in range(size)]).astype(np.int64)
    key = np.argsort(pair_node, kind="stable")
    pair_node, pair_rank = pair_node[key], pair_rank[key]
    # (cell, rank) for every node of every cell, then each other rank once per cell
    n_cells, per_cell = nodes.shape
    flat = nodes.reshape(-1)
    lo = np.searchsorted(pair_node, flat, side="left")
    hi = np.searchsorted(pair_node, flat, side="right")
    cell = np.repeat(np.repeat(np.arange(n_cells), per_cell), hi - lo)
    other = pair_rank[_ranges(lo, hi - lo)]
    pairs = np.unique(cell[other != rank] * size + other[other != rank])
    cell, other = pairs // size, pairs % size
    per = np.bincount(cell, minlength=n_cells) + 1  # this rank first
    offsets = np.concatenate([[0], np.cumsum(per)]).astype(np.int32)
    data = np.full(int(offsets[-1]), rank, dtype=np.int32)
    within = np.arange(cell.size) - np.searchsorted(cell, cell, side="left")
    data[offsets[cell] + 1 + within] = other
    return data, offsets


def model_to_mesh(model, comm, gdim: int):
    """Distribute the gmsh model held by rank 0 (collective).

    dolfinx 0.5.2's ``gmshio.read_from_msh`` is broken (it returns an undefined
    name), so the caller opens the file with gmsh on rank 0 and calls this.
    Returns ``(mesh, cell_tags, facet_tags)``.
    """
    return _gmshio().model_to_mesh(model, comm, 0, gdim=gdim)


def tagged_entities(tags, value: int) -> np.ndarray:
    """Local indices (int32) of the entities of ``tags`` carrying ``value``."""
    return np.asarray(tags.find(value), dtype=np.int32)


def global_dof_numbers(V) -> np.ndarray:
    """Global PETSc index of every local scalar dof (owned then ghost), shape (n_local*bs,).

    The numbering is the one of dolfinx's PETSc vectors and matrices for ``V``:
    dof ``i*bs + c`` of block ``i`` has global index ``global_block(i)*bs + c``.
    """
    imap = V.dofmap.index_map
    bs = V.dofmap.index_map_bs
    nblocks = imap.size_local + imap.num_ghosts
    gblocks = imap.local_to_global(np.arange(nblocks, dtype=np.int32))
    return (
        np.repeat(np.asarray(gblocks, dtype=np.int64) * bs, bs) + np.tile(np.arange(bs), nblocks)
    ).astype(PETSc.IntType)


def owned_dof_count(V) -> int:
    """Number of scalar dofs owned by this rank."""
    return V.dofmap.index_map.size_local * V.dofmap.index_map_bs


def sparsity_pattern(form):
    """Assembled dolfinx SparsityPattern of a bilinear form (collective)."""
    sp = fem.create_sparsity_pattern(form)
    sp.assemble()
    return sp


def create_form(form: ufl.Form, jit_params: dict | None = None):
    """Compile a UFL form (collective)."""
    return fem.form(form, jit_params=jit_params or {})


def reference_points(cell_name: str, quadrature_degree: int) -> np.ndarray:
    """The points of FFCx's default quadrature rule of ``quadrature_degree`` on the
    reference cell ``cell_name`` ("triangle", "quadrilateral", "tetrahedron",
    "hexahedron"), then the cell's vertices: (num_points + num_vertices, tdim) float
    (local). The default rule is the one a form without a ``quadrature_rule`` metadata
    integrates with (``ffcx.element_interface.create_quadrature``)."""
    import basix

    cell = basix.cell.string_to_type(cell_name)
    points, _ = basix.make_quadrature(cell, quadrature_degree)
    return np.vstack([points, basix.geometry(cell)])


def point_expression(expr, points: np.ndarray):
    """A compiled UFL expression ``expr`` at the reference ``points`` (n, tdim) of each
    cell (``fem.Expression``; collective: FFCx compiles on the mesh's communicator)."""
    return fem.Expression(expr, points)


def evaluate_expression(expression, cells: np.ndarray) -> np.ndarray:
    """The values of :func:`point_expression`'s ``expression`` in the local ``cells``
    (int32): (len(cells), num_points × value size) float (local; the coefficients'
    ghost values must be up to date)."""
    return expression.eval(np.asarray(cells, dtype=np.int32))


def push_forward(mesh, points: np.ndarray, cell_nodes: np.ndarray) -> np.ndarray:
    """The physical coordinates (n, gdim) of the reference ``points`` (n, tdim) in the
    cell whose geometry nodes are ``cell_nodes`` (nodes, gdim), in the order of the
    geometry dofmap (local)."""
    return np.asarray(mesh.geometry.cmap.push_forward(points, cell_nodes))


def owned_cell_count(mesh) -> int:
    """Number of cells this rank owns (they come first in the local numbering)."""
    return mesh.topology.index_map(mesh.topology.dim).size_local


def cell_geometry_nodes(mesh) -> np.ndarray:
    """Geometry dofmap as an array (num_cells, nodes_per_cell) of indices into
    ``mesh.geometry.x`` ((0, nodes_per_cell) on a rank that holds no cell: the node count
    comes from the coordinate element, as reshape(0, -1) cannot infer it)."""
    nodes = mesh.geometry.cmap.create_dof_layout().num_dofs
    return np.asarray(mesh.geometry.dofmap.array, dtype=np.int32).reshape(-1, nodes)


def set_lag_preconditioner(snes: PETSc.SNES, lag: int) -> None:
    """``SNESSetLagPreconditioner`` (lag 1: a new preconditioner for every Jacobian; −1:
    keep the last one). petsc4py 3.18 does not wrap it, so the C function of the PETSc
    library that petsc4py itself has loaded is called through ctypes. Not collective."""
    if hasattr(snes, "setLagPreconditioner"):
        snes.setLagPreconditioner(lag)
        return
    fn = _petsc_c_library().SNESSetLagPreconditioner
    if fn(ctypes.c_void_p(snes.handle), lag) != 0:
        raise RuntimeError(f"SNESSetLagPreconditioner({lag}) failed")


def set_line_search_max_it(snes: PETSc.SNES, max_it: int) -> bool:
    """The iterations of the SNES's line search (``SNESLineSearchSetTolerances`` with its
    other tolerances unchanged: PETSC_DEFAULT); for "l2", the secant steps. petsc4py 3.18
    wraps neither this nor ``SNESGetLineSearch``: ctypes as in :func:`
    set_lag_preconditioner`. Returns False where the C functions are not found (nothing
    set). Not collective."""
    return _set_line_search_tolerances(snes, max_it=max_it)


def set_line_search_max_step(snes: PETSc.SNES, max_step: float) -> bool:
    """The ``maxstep`` tolerance of the SNES's line search (``SNESLineSearchSetTolerances``,
    the others unchanged; PETSc's default 1e8): the largest λ that "l2" and "cp" take, the
    largest ‖λ y‖ for "bt". ctypes as in :func:`set_line_search_max_it`; returns False
    where the C functions are not found (nothing set). Not collective."""
    return _set_line_search_tolerances(snes, max_step=max_step)


def _set_line_search_tolerances(
    snes: PETSc.SNES, max_step: float | None = None, max_it: int | None = None
) -> bool:
    """``SNESLineSearchSetTolerances`` with the given values, PETSC_DEFAULT (keep) for the
    rest; False without the C functions."""
    ls = _line_search(snes)
    if ls is None:
        return False
    keep = ctypes.c_double(-2.0)  # PETSC_DEFAULT
    step = keep if max_step is None else ctypes.c_double(max_step)
    its = -2 if max_it is None else max_it
    if _petsc_c_library().SNESLineSearchSetTolerances(ls, keep, step, keep, keep, keep, its):
        raise RuntimeError(
            f"SNESLineSearchSetTolerances(maxstep={max_step}, max_its={max_it}) failed"
        )
    return True


def set_line_search_type(snes: PETSc.SNES, line_search: str) -> bool:
    """The type of the SNES's line search (``SNESLineSearchSetType``; its pre-check and
    monitor stay), inside a solve too; petsc4py 3.18 cannot reach the line search
    (ctypes as in :func:`set_line_search_max_it`). Returns False where the C functions
    are not found (nothing set). Not collective."""
    ls = _line_search(snes)
    if ls is None:
        return False
    if _petsc_c_library().SNESLineSearchSetType(ls, line_search.encode()) != 0:
        raise RuntimeError(f"SNESLineSearchSetType({line_search!r}) failed")
    return True


def line_search_lambda(snes: PETSc.SNES) -> float | None:
    """The step length λ that the SNES's line search took last (``SNESLineSearchGetLambda``
    through ctypes), or None without the C library. Not collective."""
    ls = _line_search(snes)
    if ls is None:
        return None
    lam = ctypes.c_double()
    if _petsc_c_library().SNESLineSearchGetLambda(ls, ctypes.byref(lam)) != 0:
        raise RuntimeError("SNESLineSearchGetLambda failed")
    return lam.value


def _c_function(name: str):
    """The PETSc C function ``name`` (ctypes), or None without the C library or it."""
    try:
        lib = _petsc_c_library()
    except OSError:
        return None
    return getattr(lib, name) if hasattr(lib, name) else None


def _line_search(snes: PETSc.SNES):
    """The SNES's SNESLineSearch as a ctypes pointer, or None without the C library."""
    if _c_function("SNESLineSearchSetTolerances") is None:
        return None
    ls = ctypes.c_void_p()
    if _petsc_c_library().SNESGetLineSearch(ctypes.c_void_p(snes.handle), ctypes.byref(ls)):
        raise RuntimeError("SNESGetLineSearch failed")
    return ls


def lag_preconditioner_available() -> bool:
    """Whether :func:`set_lag_preconditioner` works here (petsc4py wraps it, or the PETSc
    library with its C function can be found). Not collective."""
    if hasattr(PETSc.SNES, "setLagPreconditioner"):
        return True
    try:
        return hasattr(_petsc_c_library(), "SNESSetLagPreconditioner")
    except OSError:
        return False


def _petsc_c_library():
    """The PETSc shared library (the one already mapped into the process by petsc4py),
    with the argument types of the functions called here set once."""
    if not hasattr(_petsc_c_library, "lib"):
        name = next((n for n in ("petsc_real", "petsc") if ctypes.util.find_library(n)), "petsc")
        lib = ctypes.CDLL(ctypes.util.find_library(name) or name)
        int_t = ctypes.c_int64 if np.dtype(PETSc.IntType).itemsize == 8 else ctypes.c_int32
        if hasattr(lib, "SNESSetLagPreconditioner"):
            lib.SNESSetLagPreconditioner.argtypes = [ctypes.c_void_p, int_t]
            lib.SNESSetLagPreconditioner.restype = ctypes.c_int
        if hasattr(lib, "SNESLineSearchSetTolerances"):
            lib.SNESGetLineSearch.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_void_p)]
            lib.SNESGetLineSearch.restype = ctypes.c_int
            lib.SNESLineSearchSetTolerances.argtypes = (
                [ctypes.c_void_p] + [ctypes.c_double] * 5 + [int_t]
            )
            lib.SNESLineSearchSetTolerances.restype = ctypes.c_int
            lib.SNESLineSearchSetType.argtypes = [ctypes.c_void_p, ctypes.c_char_p]
            lib.SNESLineSearchSetType.restype = ctypes.c_int
            lib.SNESLineSearchGetLambda.argtypes = [
                ctypes.c_void_p,
                ctypes.POINTER(ctypes.c_double),
            ]
            lib.SNESLineSearchGetLambda.restype = ctypes.c_int
        if hasattr(lib, "PetscOptionsUsed"):
            lib.PetscOptionsUsed.argtypes = [
                ctypes.c_void_p,
                ctypes.c_char_p,
                ctypes.POINTER(ctypes.c_int),
            ]
            lib.PetscOptionsUsed.restype = ctypes.c_int
        _petsc_c_library.lib = lib
    return _petsc_c_library.lib


def petsc_error_lines(exc: Exception) -> list[str]:
    """The lines of a petsc4py ``PETSc.Error``'s message without their ``[rank]``
    prefixes: the first is "error code N", the last PETSc's reason (local)."""
    return [ln.split("]", 1)[-1].strip() for ln in str(exc).strip().splitlines()] or [""]


def option_used(name: str) -> bool | None:
    """Whether PETSc has read the option ``name`` (without the leading "-") of the global
    options database (``PetscOptionsUsed`` through ctypes; petsc4py 3.18 does not wrap
    it), or None where the C function is not found. Not collective."""
    options_used = _c_function("PetscOptionsUsed")
    if options_used is None:
        return None
    used = ctypes.c_int()
    if options_used(None, name.encode(), ctypes.byref(used)) != 0:
        raise RuntimeError(f"PetscOptionsUsed({name!r}) failed")
    return bool(used.value)


def destroy_vector_wrapper(f: fem.Function) -> None:
    """Free the PETSc vector that ``f.vector`` created and caches (dolfinx 0.5.2 keeps it
    in ``f._petsc_x`` and never frees it; the values stay in ``f.x``). Collective where
    ``f`` is distributed; a later ``f.vector`` makes a new one."""
    if f._petsc_x is not None:
        f._petsc_x.destroy()
        f._petsc_x = None
