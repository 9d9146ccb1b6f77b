"""ContactProblem: the "what" of a simulation (forms, boundary data, contact terms).

The problem knows how to evaluate the residual R(u) and its Jacobian at a
given time t; it knows nothing about Newton, load stepping or Uzawa rounds,
which belong to :mod:`dolfinx_mortar.solver`. Contact terms
(:class:`dolfinx_mortar.contact.MortarContact`, added with :meth:`ContactProblem.add_contact`)
are updated before every residual evaluation (``update``: search and pairing), add their
residual and Jacobian contributions with global PETSc indices (``add_residual``,
``add_jacobian``), report the dof couplings for the sparsity pattern
(``block_couplings``, ``coupling_cover``), and update their multipliers in the solver's
Uzawa loop (``uzawa_update``); the other hooks ContactProblem calls follow the step's
life cycle (``begin_step``, ``begin_solve``, ``commit_step``, ``restore_step``).

Sign convention: R(u) = F_int(u) − F_ext(t) − F_contact(u), F_contact the nodal forces
of the contact tractions on the bodies; the reaction of a
Dirichlet boundary (the force it exerts on the body) is the sum of R over that
boundary's dofs, per component.
"""

from __future__ import annotations

import logging
import weakref
from contextlib import contextmanager
from dataclasses import dataclass
from time import perf_counter

import numpy as np
import ufl
from dolfinx import fem, la
from dolfinx.fem.petsc import (
    apply_lifting,
    assemble_matrix,
    assemble_vector,
    create_vector,
    set_bc,
)
from mpi4py import MPI
from petsc4py import PETSc
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from . import compat
from .assembly import MatrixPattern, RecordedValues, sorted_contains, unique_runs
from .bulk import LINEAR_MODELS, internal_residual, inversion_points
from .errors import SceneError, SceneTypeError
from .scene import check_facet_group, problem_inputs

log = logging.getLogger(__name__)


def interpolate_path(path, t: float) -> np.ndarray:
    """Piecewise-linear value of ``path`` (rows [t, v0, v1, ...]) at time t, constant beyond the ends."""
    arr = np.asarray(path, dtype=float)
    return np.array([np.interp(t, arr[:, 0], arr[:, j]) for j in range(1, arr.shape[1])])


def warn_dropped_tractions(tractions, dirichlet, gdim: int) -> None:
    """Log a warning for each component of a traction that a Dirichlet condition of the
    same boundary prescribes, where the traction's path is not zero in it (local; every
    rank logs it, the command line shows rank 0's). The prescribed displacement holds
    those dofs: the traction there moves nothing, and the boundary's reaction takes it
    (``reactions``). ``tractions`` (name, path) and ``dirichlet`` (name, components or
    None, path) as :class:`ContactProblem` takes them."""
    for name, path in tractions:
        values = np.asarray(path, float)[:, 1:]
        for dname, comps, _ in dirichlet:
            if dname != name:
                continue
            held = range(gdim) if comps is None else comps
            dropped = [int(c) for c in held if np.any(values[:, c] != 0.0)]
            if dropped:
                which = ", ".join(f"{c} ({'xyz'[c]})" for c in dropped)
                log.warning(
                    "[[traction]] on %r: a [[dirichlet]] condition prescribes component(s) "
                    "%s of the same boundary, so the traction's part in them moves nothing "
                    "(it goes into the boundary's reaction, not into the body)",
                    name,
                    which,
                )


@dataclass
class _Dirichlet:
    name: str
    components: tuple[int, ...]
    path: np.ndarray
    constants: list
    bcs: list
    dofs_by_component: list  # owned local dofs of the boundary, per component (all gdim components)


@dataclass
class DetF:
    """The smallest det F of a state over the points :meth:`ContactProblem.min_det_F`
    checks, with where it is (the same on every rank)."""

    #: the smallest det F (dimensionless; +inf where no rank holds a cell)
    value: float
    #: the point's coordinates X in the reference configuration (gdim,); empty with no cell
    point: tuple[float, ...]
    #: the region (cell group) of its cell ("" with no cell)
    region: str
    #: the number of points checked with det F <= 0, and of points checked, over all ranks
    inverted: int
    checked: int

    def describe(self) -> str:
        """``det F = -1 at X = (0.5, -0.25) in region 'lower'; 6 of 96 points checked
        have det F <= 0`` (for messages)."""
        where = ", ".join(f"{c:.4g}" for c in self.point)
        return (
            f"det F = {self.value:.3g} at X = ({where}) in region {self.region!r}; "
            f"{self.inverted} of {self.checked} points checked have det F <= 0"
        )


class LinearBulk:
    """The bulk of a problem whose every region is linear-elastic (local construction,
    collective assembly).

    The bulk residual is then linear in u: R_bulk(x) = K₀ x + f(t), with K₀ = ∂R_bulk/∂u
    constant and f(t) = R_bulk(0) the prescribed tractions' part (−∫ t̄·v dA). K₀, and the
    Jacobian's bulk K_D (K₀ with the rows and columns of constrained dofs zero, a zero
    diagonal there included, which the problem then fills with
    :meth:`~ContactProblem.dirichlet_scale`), are assembled on first use; f(t) when the
    time has changed (:meth:`loads_changed`). A residual is then one product and a
    Jacobian's bulk one CSR insertion instead of a finite element assembly each: the
    same values to round-off. Owns K₀, f and a work vector (freed by :meth:`destroy`);
    K_D is kept as the CSR arrays of its owned rows only.
    """

    def __init__(self, J_form, load_form):
        self._J_form = J_form
        self._load_form = load_form
        self._bcs = []
        self._K0 = None
        self._KD_csr = None  # (row offsets, global columns, values) of K_D's owned rows
        self._f = None
        self._f_current = False
        self._x = None  # x with the prescribed values on constrained dofs

    def set_bcs(self, bcs) -> None:
        """The Dirichlet conditions (their dofs; values are read at each residual)."""
        self._bcs = list(bcs)
        self._KD_csr = None

    def loads_changed(self) -> None:
        """The traction values changed (a new time): f is assembled again at next use."""
        self._f_current = False

    def residual(self, x: PETSc.Vec, b: PETSc.Vec, apply_bcs: bool) -> None:
        """b = K₀ x̃ + f(t) (collective; owned entries). With ``apply_bcs`` x̃ is x with the
        prescribed values ū on constrained dofs: this equals dolfinx's assembly of R(x)
        followed by the lifting b += K₀[:, D](ū − x)_D; without, x̃ = x."""
        self.stiffness()
        if apply_bcs:
            x.copy(self._x)
            set_bc(self._x, self._bcs)
            x = self._x
        self._K0.mult(x, b)
        if self._load_form is not None:
            if not self._f_current:
                if self._f is None:
                    self._f = create_vector(self._load_form)
                with self._f.localForm() as fl:
                    fl.set(0.0)
                assemble_vector(self._f, self._load_form)
                self._f.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
                self._f_current = True
            b.axpy(1.0, self._f)

    def stiffness(self) -> PETSc.Mat:
        """K₀ (collective on first use, when it is assembled; this object owns it)."""
        if self._K0 is None:
            self._K0 = assemble_matrix(self._J_form)
            self._K0.assemble()
            self._x = self._K0.createVecRight()
        return self._K0

    def destroy(self) -> None:
        """Free K₀, f and the work vector (collective; assembled again at next use)."""
        for obj in (self._K0, self._x, self._f):
            if obj is not None:
                obj.destroy()
        self._K0 = self._x = self._f = None
        self._f_current = False

    def add_jacobian(self, A: PETSc.Mat) -> None:
        """A += K_D on the owned rows, 0 on the diagonal of constrained dofs (collective
        on first use: K_D is assembled then); A is left unassembled for the caller, so the
        slots of its pattern that K_D does not fill are kept
        (:meth:`~dolfinx_mortar.assembly.MatrixPattern.create`)."""
        if self._KD_csr is None:
            KD = assemble_matrix(self._J_form, self._bcs, diagonal=0.0)
            KD.assemble()
            self._KD_csr = KD.getValuesCSR()
            KD.destroy()
        A.setValuesCSR(*self._KD_csr, addv=PETSc.InsertMode.ADD_VALUES)


def body_labels(V) -> tuple[np.ndarray, np.ndarray]:
    """The bodies of the mesh: its connected parts, cells joined by shared dofs.

    Returns a body number per local cell (num_cells,) and per local dof block, owned and
    ghost (num_blocks,); the numbers run from 0 to the number of bodies − 1 and are the
    same on every rank. Each rank labels its own cells' components (scipy), then joins
    the components that meet at a ghost block across ranks (one ghost scatter and one
    allgather of the joining pairs). Collective."""
    comm = V.mesh.comm
    imap = V.dofmap.index_map
    n_own, n_blocks = imap.size_local, imap.size_local + imap.num_ghosts
    cells = V.dofmap.list
    n_cells = cells.num_nodes
    cell_blocks = cells.array.reshape(n_cells, -1) if n_cells else np.empty((0, 1), np.int32)
    rows = np.repeat(np.arange(n_cells), cell_blocks.shape[1])
    cols = n_cells + cell_blocks.ravel()
    n = n_cells + n_blocks
    graph = coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n))
    n_local, labels = connected_components(graph, directed=False) if n else (0, np.empty(0))
    labels = labels.astype(np.int64) + (comm.exscan(n_local) or 0)
    # the owner's component of each ghost block
    vec = la.create_petsc_vector(imap, 1)
    vec.array[:] = labels[n_cells : n_cells + n_own]
    vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    with vec.localForm() as loc:
        owner = np.rint(loc.array[n_own:n_blocks]).astype(np.int64)
    vec.destroy()
    mine = labels[n_cells + n_own :]
    pairs = np.unique(np.stack([mine, owner], axis=1)[mine != owner], axis=0)
    pairs = np.concatenate(comm.allgather(pairs.reshape(-1, 2)))
    total = comm.allreduce(n_local)
    joined = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(total, total))
    _, body = connected_components(joined, directed=False)
    labels = body[labels]
    return labels[:n_cells], labels[n_cells:]


def rigid_modes(r: np.ndarray, comps: np.ndarray, gdim: int) -> np.ndarray:
    """The rigid motions' values at dofs: (ndofs, 3) in 2D (translations x, y; the
    rotation r ↦ (−r_y, r_x)), (ndofs, 6) in 3D (translations; rotations e_a × r about the
    three axes). ``r`` (ndofs, gdim) the dofs' positions about a centre (length, scaled
    as the caller likes), ``comps`` (ndofs,) their displacement components."""
    n = len(comps)
    trans = (comps[:, None] == np.arange(gdim)).astype(float)
    if gdim == 2:
        rot = np.where(comps == 0, -r[:, 1], r[:, 0]).reshape(n, 1)
    else:
        # (e_a × r)_c = ε_{c a b} r_b
        eps = np.zeros((3, 3, 3))
        eps[0, 1, 2] = eps[1, 2, 0] = eps[2, 0, 1] = 1.0
        eps[0, 2, 1] = eps[2, 1, 0] = eps[1, 0, 2] = -1.0
        rot = np.einsum("nab,nb->na", eps[comps], r[:, :3]) if n else np.zeros((0, 3))
    return np.concatenate([trans, rot], axis=1)


#: The rigid motions' names, in :func:`rigid_modes`' order, by dimension.
RIGID_MODE_NAMES = {
    2: ("translation along x", "translation along y", "rotation in the plane"),
    3: (
        "translation along x",
        "translation along y",
        "translation along z",
        "rotation about x",
        "rotation about y",
        "rotation about z",
    ),
}


@dataclass
class UnheldBody:
    """A body with rigid motions that nothing holds (:meth:`ContactProblem.unheld_motions`).

    ``name``: its material regions ("'block'"); ``modes``: (k, nmodes) orthonormal
    coefficients over :func:`rigid_modes`' basis; ``pairs``: the names of its contact
    pairs ("SLAVE:MASTER"), all frictionless."""

    name: str
    modes: np.ndarray
    pairs: list[str]

    def motions(self, gdim: int) -> list[str]:
        """The motions in words: the axis-aligned ones (translations, rotations about the
        axes through the mesh's centre) that lie in the span of ``modes``, then, for
        what they leave, "k other rigid motion(s)"."""
        names = RIGID_MODE_NAMES[gdim]
        basis = self.modes
        inside = [j for j in range(len(names)) if np.linalg.norm(basis[:, j]) ** 2 > 1 - 1e-6]
        words = [names[j] for j in inside]
        rest = basis.shape[0] - len(inside)
        if rest > 0:
            words.append(f"{rest} other rigid motion{'s' if rest > 1 else ''}")
        return words

    def describe(self, gdim: int) -> str:
        """The body and its motions in words: "body 'block' is free in translation along x,
        ... and rotation about z"."""
        return f"body {self.name} is free in {_and(self.motions(gdim))}"


def _and(words: list[str]) -> str:
    """ "a", "a and b", "a, b and c"."""
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


@dataclass
class UnheldGroup(UnheldBody):
    """Bodies joined by contact with rigid motions that nothing holds when they all make
    the same one (:meth:`ContactProblem.unheld_joint_motions`): such a motion changes no
    gap, so no contact pair, frictionless or not, holds it.

    ``name``: the bodies' names joined ("'ring' and 'shaft'"); ``bodies``: each body's
    name (its material regions, as :class:`UnheldBody` names one), sorted; ``modes``: (k, nmodes)
    orthonormal coefficients over :func:`rigid_modes`' basis, the same on every body of
    the group; ``pairs``: the names of the contact pairs that join them."""

    bodies: list[str]

    def describe(self, gdim: int) -> str:
        """The bodies and their joint motions in words: "bodies 'ring' and 'shaft' are free
        together in translation along x, ... and rotation in the plane"."""
        return f"bodies {self.name} are free together in {_and(self.motions(gdim))}"


#: A body counts as held by its Dirichlet conditions when the smallest eigenvalue of the
#: Gram matrix of its rigid motions at the constrained dofs (positions scaled by the mesh
#: extent) exceeds this times the largest: a body held at a single node (free to rotate
#: about it) gives 0 to round-off.
RIGID_MODE_TOL = 1e-10

#: a node lies on the plane x_k = c when |x_k − c| ≤ this times the mesh extent (plus 64
#: ulp of c: a model far from the origin): the nodes of one plane differ by round-off
#: (:meth:`ContactProblem.mirrored_planes`)
PLANE_TOL = 1e-8


def _field_components(components, gdim: int) -> tuple[int, ...]:
    """The components of :meth:`ContactProblem.add_dirichlet_field` (local): all where
    None, else distinct integers in [0, gdim); SceneTypeError / SceneError naming
    ``add_dirichlet_field.components`` (``[7]`` was a bare AssertionError from UFL)."""
    key = "add_dirichlet_field.components"
    if components is None:
        return tuple(range(gdim))
    if isinstance(components, str | bytes) or not hasattr(components, "__iter__"):
        raise SceneTypeError(
            key, f"expected a sequence of integers, got {type(components).__name__}"
        )
    comps = list(components)
    for c in comps:
        if isinstance(c, bool | np.bool_) or not isinstance(c, int | np.integer):
            raise SceneTypeError(key, f"expected integers, got {type(c).__name__} {c!r}")
    comps = [int(c) for c in comps]
    if not comps:
        raise SceneError(key, "empty: name at least one component (None: all)")
    bad = [c for c in comps if not 0 <= c < gdim]
    if bad:
        raise SceneError(key, f"component {bad[0]} out of range [0, {gdim}) for a {gdim}D mesh")
    if len(set(comps)) != len(comps):
        raise SceneError(key, f"a component is named twice: {comps}")
    return tuple(comps)


class ContactProblem:
    """Bulk forms plus contact terms (collective construction).

    Parameters
    ----------
    mesh_data: :class:`dolfinx_mortar.mesh.MeshData`.
    materials: sequence of ``(region_name, model, E, nu)``, one per cell group.
    dirichlet: sequence of ``(boundary_name, components or None, path)``; path rows
        [t, one value per component] (all components: [t, u_x, u_y(, u_z)]).
    tractions: sequence of ``(boundary_name, path)``; path rows [t, t_x, t_y(, t_z)],
        reference traction vector (force per unit reference area).
    degree: displacement degree (defaults to the mesh's geometric degree).

    The arguments are checked first, by the scene's rules for ``[[material]]``,
    ``[[dirichlet]]`` and ``[[traction]]`` (:func:`dolfinx_mortar.scene.problem_inputs`:
    existing groups, every cell group a material, E > 0, ν in (−1, 0.5), known models,
    rows of the right length, strictly increasing t, components in [0, gdim), degree
    >= 1). Raises :class:`~dolfinx_mortar.errors.SceneError` (a ValueError) or
    SceneTypeError (a TypeError) naming the argument (``materials[1].nu: Poisson's
    ratio must lie in (-1, 0.5), got 0.5``), on every rank, before any collective.
    """

    def __init__(self, mesh_data, materials, dirichlet=(), tractions=(), degree: int | None = None):
        inputs = problem_inputs(
            materials,
            dirichlet,
            tractions,
            mesh_data.cell_groups,
            mesh_data.facet_groups,
            mesh_data.mesh.geometry.dim,
            tuple(mesh_data.info.get("unnamed_groups", ())),
            degree,
        )
        materials = [(m.region, m.model, m.E, m.nu) for m in inputs.materials]
        dirichlet = [(d.boundary, d.components, d.path) for d in inputs.dirichlet]
        tractions = [(t.boundary, t.path) for t in inputs.tractions]
        degree = inputs.degree
        self.mesh_data = mesh_data
        mesh = mesh_data.mesh
        self.mesh = mesh
        self.comm = mesh.comm
        gdim = mesh.geometry.dim
        self.gdim = gdim
        if degree is None:
            degree = mesh.geometry.cmap.degree
        self.degree = degree
        self.V = compat.vector_space(mesh, degree)
        self.u = fem.Function(self.V, name="displacement")
        v = ufl.TestFunction(self.V)
        du = ufl.TrialFunction(self.V)
        simplex = mesh.topology.cell_name() in ("triangle", "tetrahedron")
        regions = [(mesh_data.cell_groups[r], model, E, nu) for r, model, E, nu in materials]
        self.materials = list(materials)
        F = internal_residual(self.u, v, regions, mesh_data.cell_tags, simplex)
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=mesh_data.facet_tags)
        self._tractions = []
        loads = 0
        for name, path in tractions:
            c = fem.Constant(mesh, np.zeros(gdim, dtype=PETSc.ScalarType))
            loads -= ufl.inner(c, v) * ds(mesh_data.facet_groups[name])
            self._tractions.append((name, np.asarray(path, float), c))
        warn_dropped_tractions(tractions, dirichlet, gdim)
        self.F_form = compat.create_form(F + loads)
        self.J_form = compat.create_form(ufl.derivative(F, self.u, du))
        self._dirichlet_rows = None  # see dirichlet_scale()
        self._destroyed = False  # destroy() was called (_check_alive)
        #: every region linear-elastic: the bulk residual is linear in u and is evaluated
        #: as K₀ x + f(t) with K₀ assembled once (:class:`LinearBulk`); None otherwise
        self.linear_bulk = None
        if self.small_strain:
            self.linear_bulk = LinearBulk(
                self.J_form, compat.create_form(loads) if self._tractions else None
            )
        fdim = mesh.topology.dim - 1
        mesh.topology.create_connectivity(fdim, mesh.topology.dim)
        nowned = compat.owned_dof_count(self.V)
        self._dirichlet: list[_Dirichlet] = []
        for name, comps, path in dirichlet:
            facets = compat.tagged_entities(mesh_data.facet_tags, mesh_data.facet_groups[name])
            comps = tuple(range(gdim)) if comps is None else tuple(comps)
            consts, bcs = [], []
            for c in comps:
                dofs = fem.locate_dofs_topological(self.V.sub(c), fdim, facets)
                const = fem.Constant(mesh, PETSc.ScalarType(0.0))
                bcs.append(fem.dirichletbc(const, dofs, self.V.sub(c)))
                consts.append(const)
            by_comp = []
            for c in range(gdim):
                dofs = np.asarray(fem.locate_dofs_topological(self.V.sub(c), fdim, facets))
                by_comp.append(dofs[dofs < nowned])
            self._dirichlet.append(
                _Dirichlet(name, comps, np.asarray(path, float), consts, bcs, by_comp)
            )
        self._fields = []  # (function, field, component, name) of add_dirichlet_field
        self._field_points = None  # field_values(): per call, (field, comps, x, held)
        x = mesh.geometry.x[:, :gdim]
        box = (
            np.concatenate([-x.min(axis=0), x.max(axis=0)])
            if x.size
            else np.full(2 * gdim, -np.inf)
        )
        self.comm.Allreduce(MPI.IN_PLACE, box, op=MPI.MAX)
        #: the diagonal of the mesh's bounding box (length; the same on every rank)
        self.extent = float(np.linalg.norm(box[gdim:] + box[:gdim]))
        self._centre = 0.5 * (box[gdim:] - box[:gdim])
        self.global_dofs_all = compat.global_dof_numbers(self.V).astype(np.int64)
        self._labels = None  # body_labels(V) (cell_body, block_body), once asked
        self._collect_bcs()
        self.contacts: list = []
        #: whether the last :meth:`uzawa_update` moved u with the multipliers (the exact
        #: update): the next round needs no forced Newton iteration
        self.moved_with_multipliers = False
        #: ``(b, x) -> bool``: x = J⁻¹ b with the solver's last factorized Jacobian
        #: (collective; False when there is none), for the exact multiplier update
        #: (``uzawa_acceleration = "newton"``); set by the Newton solver, else None
        self.linear_inverse = None
        #: ``() -> bool``: assemble the Jacobian at the current u and factorize it for
        #: :attr:`linear_inverse` (collective); set by the Newton solver, else None. The
        #: exact update asks for it where the last factorization belongs to other contact
        #: states (:meth:`note_factorization`)
        self.factorize_jacobian = None
        #: ``(ksp) -> None``: the options prefix and options of the exact multiplier
        #: update's GMRES under the solver's prefix (``NewtonSolver.configure_uzawa_ksp``);
        #: set by the Newton solver with :attr:`linear_inverse`, else None
        self.configure_uzawa_ksp = None
        #: the live Newton solvers of this problem (they register themselves;
        #: :meth:`add_contact` refuses a term while there is one)
        self.solvers = weakref.WeakSet()
        self._contact_x = None  # local part of the x the contact state was computed at
        self._pattern = MatrixPattern(self.J_form, self.V)
        self._pattern_keys = None
        #: per contact term, a coupling_cover() whose couplings the matrix holds
        self._pattern_cover = None
        #: the terms' block_couplings() and the (rows, cols, keys) made of them last time
        self._couplings_last = None
        #: the last Jacobian's recorded contact indices (RecordedValues.indices) and the
        #: block couplings they fill: the next Jacobian with the same indices reuses them
        self._recorded_last = None
        self.t = 0.0
        #: the answer of :meth:`stick_only_at_start` (None before it is asked)
        self.stick_free_at_start = None
        self.timings = {"search": 0.0, "contact_assembly": 0.0, "bulk_assembly": 0.0}
        #: per region, (name, det F compiled at its points X, X, its owned cells); built
        #: at the first :meth:`min_det_F` (:meth:`_inversion_checks`)
        self._det_checks = None

    @property
    def small_strain(self) -> bool:
        """Whether every region is linear-elastic (``kinematics = "small"``): the bulk is
        linear (:class:`LinearBulk`), and frictional pairs take the dual tangential weights
        by default (:func:`~dolfinx_mortar.contact.resolve_tangential_weights`)."""
        return all(model in LINEAR_MODELS for _, model, _, _ in self.materials)

    def dofs_held_at_zero(self) -> np.ndarray:
        """The owned local dofs that a ``[[dirichlet]]`` condition holds at zero for the
        whole load path (every prescribed value of their component is 0: a symmetry
        plane, a clamp; not those of :meth:`add_dirichlet_field`), sorted (local). The
        frictional nodal frames of symmetry planes use them
        (:class:`~dolfinx_mortar.friction.NodalFrames`, with :meth:`mirrored_planes`)."""
        held = [np.empty(0, np.int32)]
        for d in self._dirichlet:
            if not d.constants:  # add_dirichlet_field: a field, not a uniform path
                continue
            for j, c in enumerate(d.components):
                if not np.any(d.path[:, 1 + j]):
                    held.append(np.asarray(d.dofs_by_component[c], np.int32))
        return np.unique(np.concatenate(held))

    def body_cells(self, cells: np.ndarray) -> np.ndarray:
        """The local cells (owned and ghost, sorted indices) of every body
        (:func:`body_labels`) that holds one of the local ``cells`` on some rank
        (collective: one allreduce over the bodies; the labels are computed once)."""
        cell_body, _ = self._body_labels()
        nbodies = 1 + self.comm.allreduce(int(cell_body.max(initial=-1)), MPI.MAX)
        mine = np.zeros(nbodies, np.int32)
        mine[cell_body[np.asarray(cells, np.int64)]] = 1
        self.comm.Allreduce(MPI.IN_PLACE, mine, op=MPI.MAX)
        return np.flatnonzero(mine[cell_body] > 0).astype(np.int32)

    def mirrored_planes(self, cells: np.ndarray, planes: np.ndarray) -> np.ndarray:
        """Which of the planes x_k = c, ``planes`` (n, 2) rows [k, c] (the same on every
        rank; c a length), a body of the local ``cells`` (on some rank; :func:`body_labels`)
        is held on: whether the plane carries a node of such a body whose component k
        :meth:`dofs_held_at_zero` holds (|x_k − c| ≤ PLANE_TOL × extent + 64 ulp(c), the
        reference coordinates). (n,) bool, the same on every rank (one reduction over the
        planes, one over the bodies). Collective.

        A frictional pair asks it of its master's body for the planes on which its slave
        nodes are held (:class:`~dolfinx_mortar.friction.NodalFrames`, symmetry planes):
        a half model cuts both bodies there, a roller wall only the slave's."""
        cell_body, block_body = self._body_labels()
        nbodies = 1 + self.comm.allreduce(int(cell_body.max(initial=-1)), MPI.MAX)
        mine = np.zeros(nbodies, np.int8)
        mine[cell_body[np.asarray(cells, np.int64)]] = 1
        self.comm.Allreduce(MPI.IN_PLACE, mine, op=MPI.MAX)
        planes = np.asarray(planes, float).reshape(-1, 2)
        found = np.zeros(len(planes), np.int8)
        if len(planes):
            bs = self.V.dofmap.index_map_bs
            blocks, comps = np.divmod(self.dofs_held_at_zero(), bs)
            keep = mine[block_body[blocks]] > 0
            blocks, comps = blocks[keep], comps[keep]
            x = self.V.tabulate_dof_coordinates()[blocks, comps]  # x_k of each held dof
            k, c = planes[:, 0].astype(np.int64), planes[:, 1]
            tol = PLANE_TOL * self.extent + 64.0 * np.spacing(np.abs(c))
            for comp in np.unique(k):  # per component: a sorted search, not a double loop
                xs = np.sort(x[comps == comp])
                j = np.flatnonzero(k == comp)
                lo = np.searchsorted(xs, c[j] - tol[j], side="left")
                hi = np.searchsorted(xs, c[j] + tol[j], side="right")
                found[j] = hi > lo
            self.comm.Allreduce(MPI.IN_PLACE, found, op=MPI.MAX)
        return found > 0

    def _body_labels(self) -> tuple[np.ndarray, np.ndarray]:
        """:func:`body_labels` of the space, computed once (collective at the first call)."""
        if self._labels is None:
            self._labels = body_labels(self.V)
        return self._labels

    def _collect_bcs(self) -> None:
        # dolfinx applies a list of conditions in order (set_bc, the lifting's values), so
        # that the last one written holds a dof that several prescribe: the list runs from
        # the last declared entry to the first, and the first prescription wins, as the
        # reactions count it (it was the last: a probe's corner node took the later
        # boundary's value, its reaction the earlier one's)
        self.bcs = [bc for d in reversed(self._dirichlet) for bc in d.bcs]
        self._dirichlet_rows = None  # dirichlet_scale(): the constrained rows changed
        self._bodies = None  # (cell_body, held, gram) of bodies_held(): the conditions changed
        self._unheld = None  # unheld_motions(): the conditions changed
        self._free_fit = None  # free_rigid_motion(): the conditions changed
        self._field_points = None  # field_values(): the claimed dofs changed
        if self.linear_bulk is not None:
            self.linear_bulk.set_bcs(self.bcs)
        # global index of each local dof, -1 where a Dirichlet condition holds (PETSc ignores
        # negative indices, so contact terms never touch constrained rows or columns)
        gdofs = self.global_dofs_all.copy()
        for bc in self.bcs:
            gdofs[np.asarray(bc.dof_indices()[0])] = -1
        self.global_dofs = gdofs
        # per boundary name and component, the owned dofs whose reaction it reports: those
        # of the components it prescribes that no earlier entry prescribes (:meth:`reactions`)
        claimed = np.zeros(self.global_dofs_all.size, bool)
        self._reaction_dofs: dict[str, list[np.ndarray]] = {}
        for d in self._dirichlet:
            per_comp = self._reaction_dofs.setdefault(
                d.name, [np.empty(0, np.int32) for _ in d.dofs_by_component]
            )
            for c in d.components:
                dofs = d.dofs_by_component[c]
                mine = dofs[~claimed[dofs]]
                claimed[mine] = True
                per_comp[c] = np.concatenate([per_comp[c], mine])

    # ---------------------------------------------------------------- set-up
    def add_dirichlet_field(self, name: str, field, components=None) -> None:
        """Prescribe a displacement FIELD on the facet group ``name`` (collective).

        ``field(t, x)`` returns the displacement (gdim, npts) at the points x (3, npts)
        (reference coordinates) at time t; ``components`` (default: all) selects the
        constrained components. Use it for what a uniform ``[[dirichlet]]`` path cannot
        express (a rigid rotation of a face, say). Call it before adding contact terms
        (they record which dofs are constrained). The boundary's reaction appears in
        :meth:`reactions` under ``name``. Where earlier conditions (the scene's, earlier
        fields) prescribe nodes of this group on other boundaries, theirs hold (the first
        prescription wins). SceneError (a ValueError) where one prescribes a component of
        ``name`` itself, where ``name`` is not a facet group or a component is out of range
        [0, gdim) or repeated, SceneTypeError (a TypeError) where ``name`` is not a string
        or a component not an integer: each names the argument (``add_dirichlet_field.name``,
        ``add_dirichlet_field.components``), before any collective.
        """
        if self.contacts:
            raise RuntimeError("add_dirichlet_field must be called before add_contact")
        mesh, md, gdim = self.mesh, self.mesh_data, self.gdim
        fdim = mesh.topology.dim - 1
        check_facet_group("add_dirichlet_field.name", name, md.facet_groups, md.cell_groups)
        comps = _field_components(components, gdim)
        facets = compat.tagged_entities(md.facet_tags, md.facet_groups[name])
        taken = sorted({c for d in self._dirichlet if d.name == name for c in d.components})
        if set(taken) & set(comps):
            raise SceneError(
                "add_dirichlet_field.components",
                f"components {taken} of {name!r} are already prescribed "
                "(a [[dirichlet]] entry or an earlier field)",
            )
        bcs = []
        for c in comps:
            Vc, _ = self.V.sub(c).collapse()
            dofs = fem.locate_dofs_topological((self.V.sub(c), Vc), fdim, facets)
            gc = fem.Function(Vc)
            bcs.append(fem.dirichletbc(gc, dofs, self.V.sub(c)))
            self._fields.append((gc, field, c, name))
        nowned = compat.owned_dof_count(self.V)
        by_comp = []
        for c in range(gdim):
            dofs = np.asarray(fem.locate_dofs_topological(self.V.sub(c), fdim, facets))
            by_comp.append(dofs[dofs < nowned])
        self._dirichlet.append(_Dirichlet(name, comps, np.zeros((1, 1)), [], bcs, by_comp))
        self._collect_bcs()
        self._set_fields(getattr(self, "t", 0.0))

    def bodies_held(self, cells: np.ndarray) -> bool:
        """Whether every body (:func:`body_labels`) holding one of the local ``cells`` on
        some rank is held against all rigid motions by the Dirichlet conditions
        (collective). A body is held where the rigid motions (:func:`rigid_modes`) take
        values of full rank at its constrained dofs: a clamped face holds a body, a
        symmetry plane alone (u_x = 0) leaves it free to move along the plane. Contact
        terms ask it of their two surfaces' bodies: a pair whose bodies are all held needs
        the contact predictor at a solve's first Jacobian only
        (:class:`~dolfinx_mortar.contact.MortarContact`). Computed once (one ghost scatter
        and a few reductions), then cached."""
        if self._bodies is None:
            cell_body, block_body = self._body_labels()
            nbodies = 1 + self.comm.allreduce(int(cell_body.max(initial=-1)), MPI.MAX)
            bs = self.V.dofmap.index_map_bs
            n_own = self.V.dofmap.index_map.size_local * bs
            dofs = np.flatnonzero(self.global_dofs[:n_own] < 0)  # owned, constrained
            blocks, comps = np.divmod(dofs, bs)
            x = self.V.tabulate_dof_coordinates()[blocks, : self.gdim]
            m = rigid_modes((x - self._centre) / max(self.extent, 1e-300), comps, self.gdim)
            gram = np.zeros((nbodies, m.shape[1], m.shape[1]))
            np.add.at(gram, block_body[blocks], m[:, :, None] * m[:, None, :])
            self.comm.Allreduce(MPI.IN_PLACE, gram, op=MPI.SUM)
            eig = np.linalg.eigvalsh(gram) if nbodies else np.zeros((0, 1))
            held = eig[:, 0] > RIGID_MODE_TOL * eig[:, -1]
            self._bodies = (cell_body, held, gram)
        cell_body, held, _ = self._bodies
        free = bool(np.any(~held[cell_body[np.asarray(cells, np.int64)]]))
        return not self.comm.allreduce(free, op=MPI.LOR)

    def unheld_motions(self) -> list[UnheldBody]:
        """The bodies with a rigid motion that neither the Dirichlet conditions nor their
        contact pairs can hold (collective: a few reductions at the first call, then
        cached; empty where there is none). The motions the Dirichlet conditions leave
        free are those of :meth:`bodies_held`. A frictionless pair holds a motion of either
        of its bodies only where the motion moves a node of its master surface along the
        surface's normal: a rigid motion with m·n = 0 over the whole master surface (a
        translation along a flat or cylindrical surface, a rotation about the axis of a
        surface of revolution) maps the surface onto itself and leaves every gap of the
        pair unchanged, so the pair's forces do no work along it and the Jacobian is
        singular there. A frictional pair can hold any motion of its bodies by stick: they
        are left out (:meth:`stick_only_motions` lists them), as are the motions that a
        frictionless pair's normal holds (a body pressed by a force onto another, held by
        contact alone, is a sound scene). The motions that bodies joined by contact can make
        together, which no pair holds, are :meth:`unheld_joint_motions`'. Each
        :class:`UnheldBody` names the body by its material regions and gives the motions
        as an orthonormal basis over :func:`rigid_modes`' (positions about the mesh's
        bounding-box centre over its extent)."""
        if self._unheld is None:
            self._motions()
        return self._unheld[0]

    def stick_only_motions(self) -> list[UnheldBody]:
        """The bodies of frictional pairs with rigid motions that only stick can hold
        (collective at the first call, then cached with :meth:`unheld_motions`): those
        that neither the Dirichlet conditions nor the normal part of their contact pairs
        hold (the motions that :meth:`unheld_motions` names for frictionless pairs). Stick
        holds nothing at a node that closes within a step (it enters frictionless,
        docs/method-notes.md), so in the step where the contact forms such a body is free
        along them. ``pairs``: the body's frictional pairs."""
        if self._unheld is None:
            self._motions()
        return self._unheld[1]

    def unheld_joint_motions(self) -> list[UnheldGroup]:
        """The groups of bodies joined by contact (connected through the pairs' surfaces)
        with a joint rigid motion that no Dirichlet condition holds: the same rigid motion
        of every body of the group, a ∈ null(Σ_b G_b), G_b the Gram matrix of body b's
        rigid motions at its constrained dofs (:meth:`bodies_held`), over the shared basis
        of :func:`rigid_modes` about the mesh's bounding-box centre. Such a motion moves
        both surfaces of every pair alike and changes no gap, so no pair holds it,
        frictionless or frictional (stick acts between the bodies): two bodies pressed into
        each other with no [[dirichlet]] at all (a shrink fit) are free in all of them,
        though each body alone is held by the other's surface (:meth:`unheld_motions`
        names none). A group is left out where each of its joint motions is a motion that
        :meth:`unheld_motions` already names for every body of the group (two blocks
        each held in u_y only, both free along a flat contact: the body warnings say it);
        otherwise all its joint motions are given. Collective at the first call (the
        reductions of :meth:`unheld_motions`, computed with it), then cached; the same on
        every rank; empty where there is none."""
        if self._unheld is None:
            self._motions()
        return self._unheld[2]

    def stick_only_at_start(self) -> list[UnheldBody]:
        """The bodies of :meth:`stick_only_motions` none of whose frictional pairs has a
        slave node in contact at the current state (mixed gap γ ≤ tangential.HISTORY_GAP_TOL h:
        ``MortarContact.node_touching``), asked before the first step: there the first
        step has no friction at all, and nothing holds the body along those motions
        (collective: one contact update at u, where there is such a body). The answer is
        kept (:attr:`stick_free_at_start`) for the error of a run that stops."""
        bodies = self.stick_only_motions()
        if bodies:
            self.ensure_contact_at(self.u.vector)
            closed = {
                t.name: self.comm.allreduce(bool(np.any(t.node_touching)), op=MPI.LOR)
                for t in self.contacts
                if t.frictional
            }
            bodies = [b for b in bodies if not any(closed[name] for name in b.pairs)]
        self.stick_free_at_start = bodies
        return bodies

    def _motions(self) -> None:
        """Compute :meth:`unheld_motions`, :meth:`stick_only_motions` and
        :meth:`unheld_joint_motions` (collective)."""
        self.bodies_held(np.empty(0, np.int64))  # the Dirichlet Gram matrices, cached
        cell_body, _, gram = self._bodies
        nbodies, nm = gram.shape[0], gram.shape[1] if gram.ndim == 3 else 0
        gdim, scale = self.gdim, max(self.extent, 1e-300)
        # the bodies each pair touches, and the normal Gram matrix of its master surface
        touches = np.zeros((len(self.contacts), nbodies), np.int64)
        normal = np.zeros((len(self.contacts), nm, nm))
        points = np.zeros(len(self.contacts))
        for k, term in enumerate(self.contacts):
            touches[k, cell_body[np.asarray(term.body_cells, np.int64)]] = 1
            x, n = term.master_normals()
            r = (x - self._centre) / scale
            mn = sum(
                rigid_modes(r, np.full(len(r), c), gdim) * n[:, c : c + 1] for c in range(gdim)
            )
            normal[k] = mn.T @ mn if len(r) else 0.0
            points[k] = len(r)
        for a in (touches, normal, points):
            self.comm.Allreduce(MPI.IN_PLACE, a, op=MPI.SUM)
        # the material regions of each body
        md = self.mesh_data
        regions = [m[0] for m in self.materials]
        in_body = np.zeros((len(regions), nbodies), np.int64)
        for j, name in enumerate(regions):
            cells = compat.tagged_entities(md.cell_tags, md.cell_groups[name])
            in_body[j, cell_body[np.asarray(cells, np.int64)]] = 1
        self.comm.Allreduce(MPI.IN_PLACE, in_body, op=MPI.SUM)
        unheld, stick = [], []
        self._tangential = {}  # body -> the motions of unheld or stick (modes.T)
        named = {}  # body -> the motions that its own warning names (unheld)
        body_name = {}  # body -> its name (material regions)
        for b in range(nbodies):
            names = [regions[j] for j in range(len(regions)) if in_body[j, b]]
            part = any(np.count_nonzero(in_body[regions.index(r)]) > 1 for r in names)
            name = " + ".join(repr(r) for r in names)
            body_name[b] = f"a connected part of {name}" if part else name
        for b in range(nbodies):
            w, v = np.linalg.eigh(gram[b])
            free = v[:, w <= RIGID_MODE_TOL * max(w[-1], 0.0)]
            pairs = [k for k in range(len(self.contacts)) if touches[k, b]]
            if not free.shape[1]:
                continue
            frictional = [k for k in pairs if self.contacts[k].frictional]
            held = sum((normal[k] / max(points[k], 1.0) for k in pairs), np.zeros((nm, nm)))
            w, v = np.linalg.eigh(free.T @ held @ free)
            modes = free @ v[:, w <= RIGID_MODE_TOL]
            if not modes.shape[1]:
                continue
            self._tangential[b] = modes
            if not frictional:
                named[b] = modes.T
            (stick if frictional else unheld).append(
                UnheldBody(
                    body_name[b], modes.T, [self.contacts[k].name for k in frictional or pairs]
                )
            )
        self._unheld = (unheld, stick, self._joint(gram, touches > 0, named, body_name))

    def _joint(self, gram, touches, named, body_name) -> list[UnheldGroup]:
        """:meth:`unheld_joint_motions` from the bodies' Dirichlet Gram matrices ``gram``
        (nbodies, nm, nm), the bodies each pair touches ``touches`` (npairs, nbodies), the
        motions each body's own warning names ``named`` (body -> (k, nm) orthonormal rows)
        and the bodies' names (local: the arguments are the same on every rank)."""
        nbodies, npairs = gram.shape[0], touches.shape[0]
        nm = gram.shape[1] if gram.ndim == 3 else 0
        group = list(range(nbodies))  # union-find over the bodies, joined by each pair

        def root(b: int) -> int:
            while group[b] != b:
                group[b] = group[group[b]]
                b = group[b]
            return b

        for k in range(npairs):
            bodies = np.flatnonzero(touches[k])
            for b in bodies[1:]:
                group[root(int(b))] = root(int(bodies[0]))
        out = []
        for r in sorted({root(b) for b in range(nbodies)}):
            members = [b for b in range(nbodies) if root(b) == r]
            pairs = [k for k in range(npairs) if touches[k, members].any()]
            if not pairs:
                continue  # a body in no pair: unheld_motions names it
            total = gram[members].sum(axis=0)
            w, v = np.linalg.eigh(total)
            joint = v[:, w <= RIGID_MODE_TOL * max(w[-1], 0.0)]
            if not joint.shape[1]:
                continue
            # the joint motions that every member's own warning names already
            apart = sum(
                (np.eye(nm) - named[b].T @ named[b] if b in named else np.eye(nm)) for b in members
            )
            w = np.linalg.eigvalsh(apart)
            if joint.shape[1] <= np.count_nonzero(w <= 1e-8 * len(members)):
                continue
            names = sorted(body_name[b] for b in members)  # not by label: the partition's
            out.append(
                UnheldGroup(_and(names), joint.T, [self.contacts[k].name for k in pairs], names)
            )
        return out

    def _free_fit_data(self) -> tuple:
        """The cached data of :meth:`free_rigid_motion` and :meth:`floating` (collective at
        the first call: a few reductions): the rigid modes at the owned dofs, the body of
        each owned dof, each body's Gram matrix of the modes over all its dofs, each body's
        motions that its Dirichlet conditions leave free (columns), and which bodies each
        contact term's surfaces belong to (n_terms, n_bodies)."""
        self.bodies_held(np.empty(0, np.int64))
        cell_body, held, gram = self._bodies
        nbodies = gram.shape[0]
        if self._free_fit is None:
            bs = self.V.dofmap.index_map_bs
            n_own = self.V.dofmap.index_map.size_local * bs
            _, block_body = body_labels(self.V)
            blocks, comps = np.divmod(np.arange(n_own), bs)
            x = self.V.tabulate_dof_coordinates()[blocks, : self.gdim]
            scale = max(self.extent, 1e-300)
            m = rigid_modes((x - self._centre) / scale, comps, self.gdim)
            body = block_body[blocks]
            full = np.zeros_like(gram)
            np.add.at(full, body, m[:, :, None] * m[:, None, :])
            self.comm.Allreduce(MPI.IN_PLACE, full, op=MPI.SUM)
            free = []
            for b in range(nbodies):
                w, v = np.linalg.eigh(gram[b])
                free.append(v[:, w <= RIGID_MODE_TOL * max(w[-1], 0.0)])
            touches = np.zeros((len(self.contacts), nbodies), np.int64)
            for k, term in enumerate(self.contacts):
                touches[k, cell_body[np.asarray(term.body_cells, np.int64)]] = 1
            self.comm.Allreduce(MPI.IN_PLACE, touches, op=MPI.SUM)
            self._free_fit = (m, body, full, free, touches > 0)
        return self._free_fit

    def floating(self, closed: list[bool]) -> np.ndarray:
        """Per contact term (bool, (n_terms,)), whether a body that its surfaces belong to
        has rigid motions that its Dirichlet conditions leave free (:meth:`bodies_held`) and
        is in no pair in contact: ``closed`` says, per term, whether the pair has a node in
        contact (``touching``, the same on every rank). Nothing then holds the body along
        those motions: the Jacobian is singular along them, and how far a solve moves it
        there is the linear solver's round-off (hertz2d's cylinder free in x,
        ``stick_only_scene``: 2.07 or 0.30 in the same step, as the bulk kernels' last
        digits changed). Collective at the first call (:meth:`_free_fit_data`), then local."""
        closed = np.asarray(closed, bool)
        self.bodies_held(np.empty(0, np.int64))
        _, held, _ = self._bodies
        out = np.zeros(len(self.contacts), bool)
        if np.all(held) or not self.contacts:
            return out
        _, _, _, free, touches = self._free_fit_data()
        loose = np.array([f.shape[1] > 0 for f in free], bool)  # per body
        loose &= ~touches[closed].any(axis=0)
        return touches[:, loose].any(axis=1)

    def free_rigid_motion(self, du: np.ndarray, tangential: bool = False) -> np.ndarray:
        """Per contact term, how far ``du`` moves the bodies of its pair along the rigid
        motions that their Dirichlet conditions leave free (:meth:`bodies_held`): per body,
        the least-squares fit of ``du`` over the body's owned dofs by those motions, and the
        largest nodal length of the fitted rigid motion over the body's nodes; per term, the
        largest over the bodies its surfaces belong to (length; 0 where the conditions hold
        them). ``du`` is the owned part of a displacement increment (the solve's step,
        x − x_start), (n_owned_dofs,). A motion that the conditions prescribe (a pushed
        face's approach) is no free motion and counts nothing; a deformation's fit is of
        the order of its own asymmetry. With ``tangential``, only the fitted motion's part
        along the motions that the normal of the bodies' contact cannot hold either (those
        of :meth:`unheld_motions` and :meth:`stick_only_motions`) counts: a force-driven
        approach along the normal counts nothing then. Collective (a few reductions; the
        body matrices are computed at the first call, then cached)."""
        if tangential and self._unheld is None:
            self._motions()
        self.bodies_held(np.empty(0, np.int64))
        cell_body, held, gram = self._bodies
        nbodies = gram.shape[0]
        out = np.zeros(len(self.contacts))
        if np.all(held) or not self.contacts:
            return out
        m, body, full, free, touches = self._free_fit_data()
        mdu = np.zeros((nbodies, m.shape[1]))
        np.add.at(mdu, body, m * np.asarray(du)[: len(body), None])
        self.comm.Allreduce(MPI.IN_PLACE, mdu, op=MPI.SUM)
        amp = np.zeros(nbodies)
        gdim = self.gdim
        for b in range(nbodies):
            F = free[b]
            if not F.shape[1]:
                continue
            a = F @ np.linalg.lstsq(F.T @ full[b] @ F, F.T @ mdu[b], rcond=None)[0]
            if tangential:  # its part along the motions that no normal holds
                T = self._tangential.get(b, np.zeros((len(a), 0)))
                a = T @ (T.T @ a)
            mine = body == b
            fit = (m[mine] @ a).reshape(-1, gdim)  # owned blocks of body b, whole
            amp[b] = np.sqrt((fit**2).sum(axis=1)).max(initial=0.0)
        self.comm.Allreduce(MPI.IN_PLACE, amp, op=MPI.MAX)
        for k in range(len(self.contacts)):
            out[k] = amp[touches[k]].max(initial=0.0)
        return out

    def _set_fields(self, t: float) -> None:
        for gc, field, c, _ in self._fields:
            gc.interpolate(lambda x, field=field, c=c: field(t, x)[c])

    def add_contact(self, term) -> None:
        """Register a contact term (see :class:`dolfinx_mortar.contact.MortarContact`),
        before the Newton solver is created (local: the same decision on every rank).

        Raises TypeError for an object that is not a contact term built on a problem
        (no ``problem`` attribute); ValueError for a term built on another problem (its
        dofs, communicator and solver hooks are the other problem's: it ran with that
        problem's factorization, and on another communicator the job hung), or where
        another term has the same slave surface (the contact output is per slave surface;
        a scene says so as ``contact[i].slave``); RuntimeError while a
        :class:`~dolfinx_mortar.solver.NewtonSolver` of this problem is alive (its matrix
        pattern, line search and factorization were set up for the terms it found:
        destroy it first)."""
        if not hasattr(term, "problem"):
            raise TypeError(
                "add_contact takes a contact term built on this problem "
                f"(MortarContact(problem, slave, master, ...)), got {type(term).__name__}"
            )
        if term.problem is not self:
            raise ValueError(
                f"add_contact: the contact term {getattr(term, 'name', '')!r} was built on "
                "another ContactProblem: build it on this one (MortarContact(problem, ...))"
            )
        if self.solvers:
            raise RuntimeError(
                "add_contact: add contact terms before creating the NewtonSolver (destroy "
                "the solver first: its matrix and options were set up for the terms it found)"
            )
        slave = getattr(term, "slave_name", None)
        if slave is not None and any(t.slave_name == slave for t in self.contacts):
            raise ValueError(f"{slave!r} is already the slave surface of a contact term")
        self.contacts.append(term)
        self._unheld = None  # unheld_motions(): the pairs changed
        self._free_fit = None  # free_rigid_motion(): the pairs changed

    @property
    def num_dofs(self) -> int:
        """The global number of scalar displacement dofs: the blocks (nodes) of the vector
        space over all ranks, each counted once (ghosts not again), times the block size
        ``gdim``; the constrained (Dirichlet) dofs included. The contact terms add no
        unknowns (their mixed variables are recovered), so it is the size of the global
        system. Local: the same on every rank, no communication."""
        return self.V.dofmap.index_map.size_global * self.V.dofmap.index_map_bs

    def destroy(self) -> None:
        """Free the PETSc objects the problem owns (collective): the linear bulk's K₀ and
        vectors, the contact terms' scatters and slip histories, and the PETSc wrappers
        of its functions' vectors. dolfinx 0.5.2 frees the PETSc objects its C++ layer
        creates only on an explicit destroy: a run left K₀ and about five vectors behind
        (0.87 MB a run of hertz2d's 3.3k dofs; a helper's parameter-sweep probe). The
        problem cannot solve afterwards, nor give what needs a residual (:meth:`reactions`,
        :meth:`nodal_reactions`): those raise RuntimeError (they crashed the process,
        SIGSEGV in the freed scatters); the contact terms' tables and statistics of the
        last state can still be read. :func:`~dolfinx_mortar.runner.run` calls it on the
        problem it built, unless ``setup`` handed the problem to the caller."""
        if self._destroyed:
            return
        self._destroyed = True
        if self.linear_bulk is not None:
            self.linear_bulk.destroy()
        for term in self.contacts:
            term.destroy()
        for f in [self.u, *(gc for gc, *_ in self._fields)]:
            compat.destroy_vector_wrapper(f)

    def set_time(self, t: float) -> None:
        """Set the Dirichlet values and tractions of time ``t`` (local, no communication)."""
        self.t = t
        for d in self._dirichlet:
            if not d.constants:
                continue  # a field: see _set_fields
            vals = interpolate_path(d.path, t)
            for const, val in zip(d.constants, vals, strict=True):
                const.value = val
        self._set_fields(t)
        for _, path, const in self._tractions:
            const.value = interpolate_path(path, t)
        if self.linear_bulk is not None:
            self.linear_bulk.loads_changed()

    def load_values(self, t: float) -> np.ndarray:
        """The prescribed data of time ``t``: the values of every Dirichlet path (not of
        Dirichlet fields) and every traction path, concatenated (local)."""
        vals = [interpolate_path(d.path, t) for d in self._dirichlet if d.constants]
        vals += [interpolate_path(path, t) for _, path, _ in self._tractions]
        return np.concatenate(vals) if vals else np.zeros(0)

    @property
    def has_dirichlet_fields(self) -> bool:
        """Whether some condition is a field of :meth:`add_dirichlet_field` (local: the
        same on every rank, add_dirichlet_field being collective)."""
        return bool(self._fields)

    def field_values(self, t: float) -> np.ndarray:
        """The displacements (length) that the :meth:`add_dirichlet_field` fields prescribe
        at time ``t`` at this rank's owned nodes, shape (n, gdim): one row per node and
        field (the nodes of each call's boundary whose dofs it holds: those that no earlier
        condition claims, as :meth:`reactions` counts them), 0 in the components the field
        does not hold there (local, no communication: each rank evaluates its own nodes;
        (0, gdim) without fields). Each field is called at these nodes' points only
        (reference coordinates, shape (3, n)), not interpolated over the mesh as
        :meth:`set_time` does: the predictor's corner check (``solver._path_bends``) calls
        it at three times a step."""
        gdim = self.gdim
        if self._field_points is None:
            bs = self.V.dofmap.index_map_bs
            xyz = self.V.tabulate_dof_coordinates()
            calls: dict = {}  # (name, field) -> the components it holds
            for _, field, c, name in self._fields:
                calls.setdefault((name, id(field)), (name, field, []))[2].append(c)
            self._field_points = []
            for name, field, comps in calls.values():
                dofs = [np.asarray(self._reaction_dofs[name][c], np.int64) for c in comps]
                nodes = np.unique(np.concatenate(dofs) // bs)
                held = np.zeros((gdim, nodes.size), bool)
                for c, d in zip(comps, dofs, strict=True):
                    held[c, np.searchsorted(nodes, d // bs)] = True
                x = np.ascontiguousarray(xyz[nodes].T)
                self._field_points.append((field, comps, x, held))
        vals = [np.zeros((0, gdim))]
        for field, comps, x, held in self._field_points:
            if not x.shape[1]:
                continue
            u = field(t, x)
            v = np.zeros((gdim, x.shape[1]))
            for c in comps:
                v[c] = np.broadcast_to(np.asarray(u[c], float), x.shape[1:])
            vals.append(np.where(held, v, 0.0).T)
        return np.concatenate(vals)

    def increment_norm(self, u_old: np.ndarray) -> float:
        """‖u − u_old‖₂ over the owned dofs (collective); u_old is an array like
        ``u.x.array`` (owned and ghost dofs)."""
        V = self.u.function_space
        n = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        d = self.u.x.array[:n] - u_old[:n]
        return float(np.sqrt(self.comm.allreduce(float(d @ d))))

    def min_det_F(self, x: PETSc.Vec | None = None) -> DetF:
        """The smallest det F, F = I + ∇u, over the owned cells at the points of
        :func:`~dolfinx_mortar.bulk.inversion_points` (the bulk forms' quadrature points
        and the cell vertices), at ``x`` (u ← x first) or at the current u (collective;
        one evaluation of a compiled expression per region, compiled at the first call,
        and one allgather). det F <= 0 is an inverted element: no deformation, though a
        law finite there (saint-venant-kirchhoff: ψ(F) = ψ(RF) with R a reflection)
        gives finite stresses, and Newton can converge to it (the solver refuses such a
        state in finite kinematics: docs/method-notes.md, "Inverted elements")."""
        if x is not None:
            self._set_state(x)
        else:
            self._check_alive()
        if self._det_checks is None:
            self._det_checks = self._inversion_checks()
        best = (np.inf, None, -1, -1)  # value, region index, cell, point
        inverted = checked = 0
        for i, (_, expr, X, cells) in enumerate(self._det_checks):
            if cells.size == 0:
                continue
            vals = compat.evaluate_expression(expr, cells)  # (cells, points)
            inverted += int(np.count_nonzero(vals <= 0.0))
            checked += vals.size
            k = int(np.argmin(vals))
            if vals.flat[k] < best[0]:
                best = (float(vals.flat[k]), i, int(cells[k // len(X)]), k % len(X))
        point, region = (), ""
        if best[1] is not None:
            region, _, X, _ = self._det_checks[best[1]]
            nodes = compat.cell_geometry_nodes(self.mesh)[best[2]]
            coords = self.mesh.geometry.x[nodes, : self.gdim]
            at = compat.push_forward(self.mesh, X[best[3] : best[3] + 1], coords)[0]
            # a coordinate at round-off of the mesh's size is 0 (not "-4.163e-17")
            point = tuple(float(c) if abs(c) > 1e-12 * self.extent else 0.0 for c in at)
        found = self.comm.allgather((best[0], point, region, inverted, checked))
        value, point, region, _, _ = min(found, key=lambda f: f[0])
        return DetF(value, point, region, sum(f[3] for f in found), sum(f[4] for f in found))

    def _inversion_checks(self) -> list:
        """Per region, (name, det F compiled at its points X, X (n, tdim), its owned
        cells) (:func:`~dolfinx_mortar.bulk.inversion_points`; collective: the expressions
        are compiled on the mesh's communicator, one per distinct set of points)."""
        mesh = self.mesh
        affine = mesh.ufl_domain().ufl_coordinate_element().degree() == 1
        detF = ufl.det(ufl.Identity(self.gdim) + ufl.grad(self.u))
        owned = compat.owned_cell_count(mesh)
        checks, compiled = [], {}
        for name, model, _, _ in self.materials:
            X = inversion_points(model, self.degree, mesh.topology.cell_name(), affine)
            key = X.tobytes()
            if key not in compiled:
                compiled[key] = compat.point_expression(detF, X)
            tag = self.mesh_data.cell_groups[name]
            cells = compat.tagged_entities(self.mesh_data.cell_tags, tag)
            checks.append((name, compiled[key], X, cells[cells < owned]))
        return checks

    # ---------------------------------------------------------------- assembly
    def _check_alive(self) -> None:
        """Raise RuntimeError after :meth:`destroy` (local; destroy is collective, so every
        rank raises alike)."""
        if self._destroyed:
            raise RuntimeError(
                "ContactProblem.destroy() has freed this problem's PETSc objects: it cannot "
                "evaluate a residual or Jacobian any more (read reactions before destroying it)"
            )

    def _set_state(self, x: PETSc.Vec) -> None:
        self._check_alive()
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        if x.handle != self.u.vector.handle:
            x.copy(self.u.vector)
            self.u.x.scatter_forward()

    def update_contact(self, x: PETSc.Vec) -> None:
        """Per-iteration hook: search and pairing of every contact term at state ``x`` (collective)."""
        self._set_state(x)
        for term in self.contacts:
            term.update(self.u)
        self._contact_x = x.array_r.copy() if self.contacts else None

    def ensure_contact_at(self, x: PETSc.Vec) -> None:
        """Bring the state to ``x``: u ← x and the contact terms updated at x, unless both
        already are, the contact state also for the current multipliers (collective:
        every rank takes the same decision). Where they are, it costs two comparisons of
        the owned entries and one reduction: :meth:`residual` and :meth:`jacobian` call it,
        and the solver's callbacks, which update first, pay no second search."""
        if not self.contacts:
            self._set_state(x)
            return
        self._check_alive()
        xa = x.array_r
        same = self._contact_x is not None and np.array_equal(self._contact_x, xa)
        if same and x.handle != self.u.vector.handle:
            # u set since the update (a load step's predictor, say): the bulk reads u
            same = np.array_equal(self.u.x.array[: xa.size], xa)
        if not self.comm.allreduce(int(same), op=MPI.MIN):
            self.update_contact(x)

    def dirichlet_scale(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The rows of the owned constrained dofs and their scales s_i: local indices
        (k,) int32, global indices (k,) PETSc.IntType and s_i (k,) float (collective on
        first use after the conditions change; local then). The rows hold s_i (x_i − ū_i)
        in the residual and s_i on the Jacobian's diagonal.

        s_i = |K_ii|, the dof's own diagonal of the bulk stiffness ∂R_bulk/∂u without the
        conditions, at the state of first use (the initial state of a run; K₀ itself with
        a linear bulk), and where that is not positive the mean |K_jj| over the free dofs
        (1 where there is none). Every row of R is then a force of its own body, and
        ‖R‖ does not depend on the units: with unit rows ‖R‖ mixed the displacement
        increment prescribed on a boundary (a length) with forces, and the relative
        tolerance, the line searches and ``atol = "auto"`` (the first residual's norm)
        saw another problem in other units (BENCHMARKS.md §44). A single mean over every
        body (tried first) gave a soft body's rows the stiff body's scale where the two
        differ by 1e6: the first norm, and with it rtol, grew 1e3-fold."""
        if self._dirichlet_rows is None:
            if self.linear_bulk is not None:
                K, owned = self.linear_bulk.stiffness(), None
            else:
                K = owned = assemble_matrix(self.J_form)
                K.assemble()
            diag = K.getDiagonal()
            n = self.V.dofmap.index_map.size_local * self.V.dofmap.index_map_bs
            d = np.abs(diag.array_r[:n])
            diag.destroy()
            if owned is not None:
                owned.destroy()
            free = self.global_dofs[:n] >= 0
            count = self.comm.allreduce(int(free.sum()))
            mean = self.comm.allreduce(float(d[free].sum())) / count if count else 1.0
            if not (np.isfinite(mean) and mean > 0.0):
                mean = 1.0
            local = np.flatnonzero(~free).astype(np.int32)
            s = d[local]
            s[~(np.isfinite(s) & (s > 0.0))] = mean
            rows = self.global_dofs_all[local].astype(PETSc.IntType)
            self._dirichlet_rows = (local, rows, s)
        return self._dirichlet_rows

    def residual(self, x: PETSc.Vec, b: PETSc.Vec, apply_bcs: bool = True) -> None:
        """Assemble R(x) into ``b`` (collective; x, b of the layout of ``u.vector``). With
        ``apply_bcs``, rows of constrained dofs hold s_i (x_i − ū_i) instead of the
        residual (:meth:`dirichlet_scale`). The bulk and the contact terms are evaluated
        at x: u becomes x and the contact terms are updated there unless their state
        already is x's (:meth:`ensure_contact_at`; the solver's callbacks update first,
        so they pay no second search). Raises RuntimeError after :meth:`destroy`."""
        self._check_alive()
        t0 = perf_counter()
        self.ensure_contact_at(x)
        self.timings["search"] += perf_counter() - t0
        t0 = perf_counter()
        self._bulk_residual(x, b, apply_bcs)
        self.timings["bulk_assembly"] += perf_counter() - t0
        t0 = perf_counter()
        for term in self.contacts:
            term.add_residual(b, masked=apply_bcs)
        b.assemble()
        self.timings["contact_assembly"] += perf_counter() - t0
        if apply_bcs:
            set_bc(b, self.bcs, x, -1.0)
            local, _, s = self.dirichlet_scale()
            b.array_w[local] *= s
        if any(getattr(term, "degenerate", False) for term in self.contacts):
            # a facet of zero size in the deformed state (MortarContact.update): no
            # residual here; NaN on this rank's rows makes the norm NaN on every rank
            b.array_w[:] = np.nan

    def _bulk_residual(self, x: PETSc.Vec, b: PETSc.Vec, apply_bcs: bool) -> None:
        """The bulk part of R(x) into ``b`` (overwritten, ghosts summed; collective): the
        linear bulk's evaluation or the assembled UFL form, with ``apply_bcs`` the lifting
        of the Dirichlet conditions (their rows are :meth:`residual`'s to set)."""
        if self.linear_bulk is not None:
            self.linear_bulk.residual(x, b, apply_bcs)
            return
        with b.localForm() as bl:
            bl.set(0.0)
        assemble_vector(b, self.F_form)
        if apply_bcs:
            apply_lifting(b, [self.J_form], bcs=[self.bcs], x0=[x], scale=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)

    def nonfinite_cause(self, x: PETSc.Vec) -> str:
        """What makes R(x) non-finite, for messages (collective; u becomes x and the
        contact terms are updated there): "the Newton iterate itself", "a contact facet of
        zero size" (:attr:`~dolfinx_mortar.contact.MortarContact.degenerate`), "the bulk
        residual at inverted elements (det F = … at X = … in region …)" (finite
        kinematics; :meth:`min_det_F`), "the bulk residual", "the contact residual of
        pair …", or "" where every part is finite. The bulk part without the Dirichlet
        conditions and each contact term's part are assembled apart (one assembly each).
        A neo-Hookean region has ln J and J^(−2/3) in its stress: a line search's trial
        point that inverts an element (det F <= 0) makes its rows NaN, which the solver
        answers with its "bt" restart (:data:`~dolfinx_mortar.solver._NONFINITE`)."""
        self._check_alive()
        comm = self.comm

        def any_rank(flag: bool) -> bool:
            return bool(comm.allreduce(int(flag), op=MPI.MAX))

        if any_rank(not np.all(np.isfinite(x.array_r))):
            return "the Newton iterate itself"
        self.ensure_contact_at(x)
        # ``degenerate`` is this rank's own: reduced, so that every rank returns here or
        # none does (the bulk assembly below is collective)
        if any_rank(any(getattr(term, "degenerate", False) for term in self.contacts)):
            return "a contact facet of zero size in the deformed state"
        b = self.u.vector.duplicate()
        try:
            self._bulk_residual(x, b, False)
            if any_rank(not np.all(np.isfinite(b.array_r))):
                if not self.small_strain:
                    det = self.min_det_F()
                    if det.value <= 0.0:
                        return f"the bulk residual at inverted elements ({det.describe()})"
                return "the bulk residual"
            for term in self.contacts:
                b.zeroEntries()
                term.add_residual(b, masked=False)
                b.assemble()
                if any_rank(not np.all(np.isfinite(b.array_r))):
                    return f"the contact residual of pair {getattr(term, 'name', '?')}"
        finally:
            b.destroy()
        return ""

    def residual_round_off(self) -> float:
        """The round-off level f of the assembled residual at the current state u: the norm
        below which no iterate's ‖R‖ can go (force units, the norm of ``residual_norms``;
        collective, the same on every rank).

        Every dof moves by one unit in the last place of the current coordinate,
        δ_i = ε_mach (|X_i| + |u_i|) ξ_i with ξ_i = ±1 fixed by the global dof number, and

            f = ‖R̃(u + δ) + R̃(u − δ) − 2 R̃(u)‖ / √6,

        R̃ the residual as assembled (Dirichlet rows included). The terms linear in δ
        cancel and the quadratic ones are of order ε_mach², so what is left is the
        rounding of the three assemblies, independent with equal variance (hence √6).
        The bulk forms see the mesh's coordinates, not the displacement, so δ is scaled
        by |X| + |u| (the contact terms see coordinates relative to their pair's origin,
        ``surface.pair_origin``: a smaller δ would do for them; the linear terms cancel
        either way). Three residual evaluations; the contact state is that of u
        again afterwards (one more search at u). BENCHMARKS.md §24 compares f with the
        plateau that extra exact Newton steps reach."""
        u = self.u.vector
        n = self.V.dofmap.index_map.size_local * self.V.dofmap.index_map_bs
        bs = self.V.dofmap.index_map_bs
        coords = self.V.tabulate_dof_coordinates()
        X = np.abs(coords[np.arange(n) // bs, np.arange(n) % bs])
        g = self.global_dofs_all[:n].astype(np.uint64)
        xi = 1.0 - 2.0 * (((g * np.uint64(2654435761)) >> np.uint64(13)) & np.uint64(1))
        u0 = u.copy()
        delta = u.duplicate()
        delta.array_w[:] = np.finfo(float).eps * (X + np.abs(u0.array_r[:n])) * xi
        out, work, x = u.duplicate(), u.duplicate(), u.duplicate()
        out.set(0.0)
        timings = dict(self.timings)
        try:
            for sign, weight in ((1.0, 1.0), (-1.0, 1.0), (0.0, -2.0)):
                u0.copy(x)
                x.axpy(sign, delta)
                self.update_contact(x)
                self.residual(x, work)
                out.axpy(weight, work)
            f = out.norm() / np.sqrt(6.0)
        finally:
            self.timings.update(timings)
            for v in (u0, delta, out, work, x):
                v.destroy()
        return float(f)

    def jacobian(self, x: PETSc.Vec, A: PETSc.Mat) -> None:
        """Assemble the Jacobian dR/du at ``x`` into ``A`` (collective; ``A`` from
        :meth:`create_matrix`). Like :meth:`residual`, u becomes x and the contact terms
        are updated there unless their state already is x's (:meth:`ensure_contact_at`).
        The contact terms' part is computed first and the pattern of A grown to hold it,
        so that a growth (which drops A's values) comes before the bulk is assembled, not
        after. Raises RuntimeError after :meth:`destroy`."""
        self._check_alive()
        t0 = perf_counter()
        self.ensure_contact_at(x)
        self.timings["search"] += perf_counter() - t0
        values, keys = self._contact_values(A)
        self._assemble_bulk_jacobian(A)
        self._add_contact_values(A, values, keys, bulk=True)

    def contact_jacobian(self, A: PETSc.Mat) -> None:
        """A = the contact terms' part of the Jacobian alone, at the state of their last
        update (collective; ``A`` from :meth:`create_matrix`). For checks against finite
        differences of the contact residual."""
        values, keys = self._contact_values(A)
        A.zeroEntries()
        self._add_contact_values(A, values, keys, bulk=False)

    def _contact_values(self, A: PETSc.Mat) -> tuple[RecordedValues, np.ndarray]:
        """The contact terms' tangent, recorded, and its block couplings; the pattern of A
        grown to hold them (collective). The values are kept until the pattern of A
        covers their couplings (:meth:`MatrixPattern.grow`: those the mixed recoveries
        learn, which the facets do not give, and those of a contact zone that has grown
        since A's slots were squeezed): a coupling new to the pattern would otherwise make
        PETSc reallocate the matrix inside MatSetValues. A growth drops A's values."""
        t0 = perf_counter()
        values = RecordedValues()
        for term in self.contacts:
            term.add_jacobian(values)
        keys = self._recorded_couplings(values)
        self._pattern.grow(A, keys)
        self.timings["contact_assembly"] += perf_counter() - t0
        return values, keys

    def _recorded_couplings(self, values: RecordedValues) -> np.ndarray:
        """``values.block_couplings``, or the last Jacobian's when ``values`` holds the
        same row and column indices (local). Between two iterations with the same pairing
        and active set the indices repeat, and comparing them costs a fraction of the
        sort that finds the couplings (hertz3d at 94k dofs: 4.6 ms per Jacobian, 11 % of
        the contact assembly; docs/method-notes.md, "Batched insertion")."""
        index = values.indices()
        last = self._recorded_last
        if (
            last is not None
            and len(last[0]) == len(index)
            and all(np.array_equal(a, b) for a, b in zip(last[0], index, strict=True))
        ):
            return last[1]
        keys = values.block_couplings(self._pattern.bs, self._pattern.nblocks)
        # copies: the terms may reuse the recorded arrays after the replay
        self._recorded_last = [a.copy() for a in index], keys
        return keys

    def _add_contact_values(self, A, values: RecordedValues, keys: np.ndarray, bulk: bool):
        """A += the recorded contact values; assembles A (collective). ``bulk``: whether A
        holds the bulk part (:meth:`MatrixPattern.filled`)."""
        t0 = perf_counter()
        values.replay(A)
        A.assemble()
        self._pattern.filled(A, keys, bulk)
        self.timings["contact_assembly"] += perf_counter() - t0

    def _assemble_bulk_jacobian(self, A: PETSc.Mat) -> None:
        """A = the bulk Jacobian with the Dirichlet rows (collective): flush-assembled,
        then the constrained rows' diagonal added, left to the caller's final assembly."""
        t0 = perf_counter()
        A.zeroEntries()
        _, rows, s = self.dirichlet_scale()
        if self.linear_bulk is not None:
            self.linear_bulk.add_jacobian(A)
        else:
            assemble_matrix(A, self.J_form, self.bcs, diagonal=0.0)
        A.assemblyBegin(PETSc.Mat.AssemblyType.FLUSH)
        A.assemblyEnd(PETSc.Mat.AssemblyType.FLUSH)
        # the constrained rows' diagonal s_i, added like the contact values after it (no
        # flush between); none on a rank without constrained dofs (petsc4py divides by
        # the row count)
        if rows.size:
            A.setValuesRCV(rows.reshape(-1, 1), rows.reshape(-1, 1), s.reshape(-1, 1), addv=True)
        self.timings["bulk_assembly"] += perf_counter() - t0

    # ---------------------------------------------------------------- matrix
    def _contact_couplings(self) -> np.ndarray:
        """The sorted unique global block couplings (block row × N_blocks + block column)
        of all contact terms (local)."""
        parts = [term.block_couplings() for term in self.contacts]
        last = self._couplings_last
        if last is not None and len(last[0]) == len(parts):
            if all(a is b for a, b in zip(last[0], parts, strict=True)):
                return last[1]  # the terms' memos: the same couplings as last time
        r = np.concatenate([np.empty(0, np.int64), *(p[0] for p in parts)])
        c = np.concatenate([np.empty(0, np.int64), *(p[1] for p in parts)])
        # each term gives its couplings as sorted runs (contact._block_couplings: one)
        keys = unique_runs(r * self._pattern.nblocks + c)
        self._couplings_last = parts, keys
        return keys

    def create_matrix(self) -> PETSc.Mat:
        """A new Jacobian matrix whose pattern covers the bulk and every contact coupling
        currently possible (collective). The caller owns (and destroys) it."""
        keys = self._contact_couplings()
        self._pattern_keys = keys
        self._pattern_cover = [term.coupling_cover() for term in self.contacts]
        return self._pattern.create(keys)

    def pattern_outdated(self) -> bool:
        """True when the contact terms can now fill entries the last matrix did not
        preallocate (collective).

        First the cheap test: every term's :meth:`~dolfinx_mortar.contact.MortarContact.
        coupling_cover` is a subset of one whose couplings the matrix holds (no slave
        facet sees a master node it did not see, no new learned coupling). Only where
        that fails are the couplings themselves compared (3D ironing: 36 ms per solve
        for 1.5 × 10⁶ per-node pairs, against about 3 ms for the cover)."""
        if not self.contacts:
            return False
        if self._pattern_keys is None:
            return True
        covers = [term.coupling_cover() for term in self.contacts]
        local = not all(
            sorted_contains(old[0], new[0]).all() and sorted_contains(old[1], new[1]).all()
            for old, new in zip(self._pattern_cover, covers, strict=True)
        )
        if local:
            keys = self._contact_couplings()
            # the very couplings the matrix was made for (the terms' memos): nothing to check
            local = keys is not self._pattern_keys and not (
                sorted_contains(self._pattern_keys, keys).all()
            )
            if not local:  # covered: the later tests start from these covers
                self._pattern_cover = covers
        return bool(self.comm.allreduce(int(local), op=MPI.MAX))

    # ---------------------------------------------------------------- steps
    def uzawa_update(self) -> tuple[bool, dict]:
        """Update the multipliers of every contact term; True when all have converged
        (collective). A term that updated its multipliers exactly (``uzawa_acceleration =
        "newton"``) also gives the displacement change they imply
        (``MortarContact.displacement_update``, owned dofs), which is added to u: the next
        round starts near its solution."""
        done, info = True, {}
        for term in self.contacts:
            ok, i = term.uzawa_update()
            done = done and ok
            info[term.name] = i
        # the multipliers changed: the contact state is stale (set after the updates: the
        # exact update evaluates the contact state at trial points on the way)
        self._contact_x = None
        # the exact update decides collectively whether it gives a displacement, so
        # ``moved`` is the same on every rank
        moved = False
        for term in self.contacts:
            if term.displacement_update is not None:
                self.u.vector.array[:] += term.displacement_update
                term.displacement_update = None
                moved = True
        self.moved_with_multipliers = moved
        if moved:
            self.u.x.scatter_forward()
        return done, info

    def note_factorization(self) -> None:
        """The Newton solver factorizes the Jacobian just assembled (local): every
        contact term notes the contact states it was assembled with
        (``MortarContact.note_factorization``), for the exact update to tell whether
        :attr:`linear_inverse` still inverts the Jacobian of the converged state."""
        for term in self.contacts:
            note = getattr(term, "note_factorization", None)
            if note is not None:
                note()

    def state_prediction_wanted(self) -> bool:
        """Whether the next Jacobian is a load step's first and a frictional contact term
        may get the state predictor there (collective: the same answer on every rank;
        ``MortarContact.state_prediction_wanted``)."""
        if not self.contacts:
            return False
        local = any(getattr(t, "state_prediction_wanted", lambda: False)() for t in self.contacts)
        return bool(self.comm.allreduce(local, op=MPI.LOR))

    def predict_states(self, x: PETSc.Vec, trial: PETSc.Vec, before: list, after: list) -> bool:
        """The state predictor of a load step's first Jacobian (collective): the contact
        terms are updated at ``trial`` (the end of the Newton step from ``x`` with the
        Jacobian just assembled there), their trial tractions read, and updated at ``x``
        again; every term whose sticking nodes go into gross slip at ``trial`` gets their
        slip tangent in the next Jacobian (``MortarContact.guess_slip``). ``before`` and
        ``after``: the :meth:`jacobian_watch` from before and after that Jacobian. Returns
        whether any term got it (the same on every rank): the per-solve state is then
        ``before`` and the caller assembles the Jacobian at x again; else it is ``after``,
        as though no trial had been made."""
        self.update_contact(trial)
        trials = [
            t.trial_traction() if getattr(t, "frictional", False) else None for t in self.contacts
        ]
        self.update_contact(x)
        self.restore_jacobian_watch(before)
        local = False
        for term, tr in zip(self.contacts, trials, strict=True):
            if tr is not None:
                local = term.guess_slip(tr) or local
        guessed = bool(self.comm.allreduce(local, op=MPI.LOR))
        if not guessed:
            self.restore_jacobian_watch(after)
        return guessed

    def jacobian_watch(self) -> list:
        """The per-solve state that a Jacobian changes in each contact term (local;
        ``MortarContact._jacobian_watch``)."""
        return [
            t._jacobian_watch() if hasattr(t, "_jacobian_watch") else None for t in self.contacts
        ]

    def restore_jacobian_watch(self, watch: list) -> None:
        """Put back a :meth:`jacobian_watch` (local)."""
        for term, w in zip(self.contacts, watch, strict=True):
            if w is not None:
                term._restore_jacobian_watch(w)

    @property
    def exact_multiplier_update(self) -> bool:
        """Whether a contact term updates its multipliers exactly (``uzawa_acceleration =
        "newton"``): its Uzawa rounds then need fully converged solves (local)."""
        return any(t.uzawa_acceleration.method == "newton" for t in self.contacts)

    def warm_up(self) -> None:
        """Run the contact terms' search, residual, Jacobian and step limit once at the
        current state (collective), so that numba loads their compiled kernels from its
        cache (20–70 ms each) at set-up instead of inside the first Newton iterations
        (the runner calls it; a script that drives :class:`~dolfinx_mortar.solver.
        LoadStepper` itself may). Leaves no state behind: the terms forget their search
        and learned couplings (``MortarContact.forget_search``), the problem keeps the
        matrix pattern it had, and every solve starts with :meth:`begin_solve` and a
        contact update, every step with :meth:`begin_step`."""
        if not self.contacts:
            return
        keys, cover = self._pattern_keys, self._pattern_cover
        x = self.u.vector
        self.update_contact(x)
        b = x.duplicate()
        self.residual(x, b)
        A = self.create_matrix()
        self.jacobian(x, A)
        for term in self.contacts:
            term.step_limit(x, 1.0)
            term.forget_search()
        A.destroy()
        b.destroy()
        self._contact_x = None
        self._pattern_keys, self._pattern_cover = keys, cover

    def begin_solve(self) -> None:
        """A Newton solve starts (contact terms reset their per-solve state)."""
        for term in self.contacts:
            if hasattr(term, "begin_solve"):
                term.begin_solve()

    def begin_step(self) -> None:
        """Start a load step (contact terms reset their per-step counters)."""
        self._contact_x = None
        for term in self.contacts:
            term.begin_step()

    def carry_states(self, on: bool) -> None:
        """Carry the stick/slip states between the Uzawa rounds of the next attempts
        (``on``) or not (the default) in every frictional contact term (local;
        :meth:`MortarContact.uzawa_update <dolfinx_mortar.contact.MortarContact.uzawa_update>`)."""
        for term in self.contacts:
            if getattr(term, "frictional", False):
                term.carry_states = bool(on)

    @property
    def carrying_states(self) -> bool:
        """Whether a frictional contact term carries its stick/slip states between Uzawa
        rounds (:meth:`carry_states`; local)."""
        return any(getattr(term, "carry_states", False) for term in self.contacts)

    @property
    def soft_start(self) -> bool:
        """Whether a load step first goes through its Uzawa rounds under the soft
        penalties (a contact term whose :attr:`soft_start
        <dolfinx_mortar.contact.MortarContact.soft_start>` holds; the same on every rank)."""
        return any(getattr(term, "soft_start", False) for term in self.contacts)

    @contextmanager
    def soft_penalties(self):
        """Within the block, every stiff contact term uses ε_soft = min(ε, ε_auto) and
        ε_T,soft (:meth:`MortarContact.soft_penalty
        <dolfinx_mortar.contact.MortarContact.soft_penalty>`); its own penalties
        afterwards, also when the block raises (local; the next contact update recomputes
        the state). Yields the names of those terms."""
        stiff = [term for term in self.contacts if getattr(term, "soft_start", False)]
        for term in stiff:
            term.soft_penalty(True)
        self._contact_x = None
        try:
            yield [term.name for term in stiff]
        finally:
            for term in stiff:
                term.soft_penalty(False)
            self._contact_x = None

    @property
    def symmetric_jacobian(self) -> bool:
        """Whether every Jacobian is a symmetric matrix (the same on every rank): the bulk
        of a hyperelastic law is (dead tractions add nothing; Dirichlet rows and columns
        are zeroed together), so this holds when every contact term's tangent is
        symmetric (:attr:`MortarContact.symmetric_tangent
        <dolfinx_mortar.contact.MortarContact.symmetric_tangent>`). The solver then
        factorizes LDLᵀ instead of LU (``solver.NewtonSolver``)."""
        return all(getattr(t, "symmetric_tangent", False) for t in self.contacts)

    @property
    def round_off_scale(self) -> float:
        """Factor ≥ 1 on the absolute Newton tolerance: the largest
        :attr:`round_off_scale <dolfinx_mortar.contact.MortarContact.round_off_scale>` of
        the contact terms (1 without contact; the same on every rank)."""
        return max((getattr(t, "round_off_scale", 1.0) for t in self.contacts), default=1.0)

    def round_state(self) -> dict | None:
        """The state an Uzawa round of the current step starts from (local copies): u and
        each contact term's :meth:`round_state
        <dolfinx_mortar.contact.MortarContact.round_state>`; None without a frictional
        term (no stick/slip states to carry, so nothing to resume: the copies are not
        made)."""
        if not any(getattr(term, "frictional", False) for term in self.contacts):
            return None
        return {
            "u": self.u.x.array.copy(),
            "terms": [term.round_state() for term in self.contacts],
        }

    def resume_round(self, state: dict) -> None:
        """Go back to a :meth:`round_state` of the current step (after :meth:`begin_step`;
        local)."""
        self.u.x.array[:] = state["u"]
        self._contact_x = None
        for term, ts in zip(self.contacts, state["terms"], strict=True):
            term.resume_round(ts)

    def unseen_overlaps(self) -> str | None:
        """After the first converged step (the load stepper asks): the contact terms'
        :meth:`~dolfinx_mortar.contact.MortarContact.unseen_overlap` texts, joined, or
        None where no term has slave nodes that started inside the master's body beyond
        the pairing's reach and are still unpaired (collective)."""
        texts = []
        for term in self.contacts:
            check = getattr(term, "unseen_overlap", None)
            if check is not None and (text := check()) is not None:
                texts.append(text)
        return "; ".join(texts) if texts else None

    def commit_step(self) -> None:
        """Accept the converged step: contact history and multipliers become the new reference."""
        for term in self.contacts:
            term.commit_step()

    def restore_step(self) -> None:
        """Undo a failed step: contact multipliers and history go back to the last commit.
        The next solve rebuilds the Jacobian pattern (a diverged attempt may have grown it
        far beyond what the converged state needs)."""
        self._contact_x = None
        self._pattern_keys = None
        for term in self.contacts:
            term.restore_step()

    def open_pairs(self) -> list[str]:
        """Names ("SLAVE:MASTER") of the contact pairs with no slave node in contact (mixed
        pressure p̂ > 0) at the last contact update (collective)."""
        counts = self.comm.allreduce(
            np.array([int(np.count_nonzero(t.p_hat > 0)) for t in self.contacts], dtype=int)
        )
        return [t.name for t, c in zip(self.contacts, np.atleast_1d(counts), strict=True) if c == 0]

    def unpaired_pairs(self) -> list[str]:
        """Names ("SLAVE:MASTER") of the contact pairs where no slave integration point
        projects onto a master facet at the last pairing (the surfaces are apart, beyond
        the search distance, or do not face each other; collective)."""
        counts = self.comm.allreduce(
            np.array([t.paired_points() for t in self.contacts], dtype=np.int64)
        )
        return [t.name for t, c in zip(self.contacts, np.atleast_1d(counts), strict=True) if c == 0]

    def edge_facet_pairs(self) -> dict[str, int]:
        """Per contact pair with segment integration ("SLAVE:MASTER"), the number of slave
        facets in contact across the master surface's edge at the last contact update
        (:meth:`~dolfinx_mortar.contact.MortarContact.edge_facets_in_contact`), pairs with
        none left out (collective)."""
        local = np.array([t.edge_facets_in_contact() for t in self.contacts], dtype=np.int64)
        counts = np.atleast_1d(self.comm.allreduce(local))
        return {t.name: int(c) for t, c in zip(self.contacts, counts, strict=True) if c > 0}

    def reactions(self) -> dict[str, list[float]]:
        """Force (gdim components) each Dirichlet boundary exerts on the bodies at the
        current state: the residual without the conditions, R = F_int − F_ext − F_contact,
        summed over the boundary's owned dofs (collective).

        A boundary has reactions only in the components it prescribes (a symmetry plane
        with u_x = 0 exerts no y or z force), and a dof prescribed by several boundaries (a
        clamp's edge on a symmetry plane) counts in the first of them in declaration
        order, so the reactions of all boundaries sum to the total force of the supports.
        """
        arr = self._residual_without_bcs()
        out = {}
        for name, per_comp in self._reaction_dofs.items():
            local = np.array([arr[dofs].sum() for dofs in per_comp])
            out[name] = [float(v) for v in self.comm.allreduce(local)]
        return out

    def nodal_reactions(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """The reaction forces of the Dirichlet boundary ``name`` at the nodes this rank
        owns, as :meth:`reactions` sums them (collective: one residual evaluation).

        Returns X (n, 3), the nodes' reference coordinates, and F (n, gdim), the force the
        boundary exerts on each node (0 in the components it does not prescribe or that
        an earlier boundary prescribes at that node); n counts the owned nodes with at
        least one such component. The moment of the reactions about the z axis, say, is
        the allreduce of Σ (X_0 F_1 − X_1 F_0). Raises KeyError for a name that is not
        a Dirichlet boundary."""
        per_comp = self._reaction_dofs[name]
        arr = self._residual_without_bcs()
        bs = self.V.dofmap.index_map_bs
        nodes = np.unique(np.concatenate([dofs // bs for dofs in per_comp]))
        F = np.zeros((nodes.size, len(per_comp)))
        for c, dofs in enumerate(per_comp):
            F[np.searchsorted(nodes, dofs // bs), c] = arr[dofs]
        return self.V.tabulate_dof_coordinates()[nodes], F

    def _residual_without_bcs(self) -> np.ndarray:
        """The local residual R = F_int − F_ext − F_contact at the current state, Dirichlet
        rows included (collective); a copy of the owned entries, (owned dofs,)."""
        b = create_vector(self.F_form)
        self.update_contact(self.u.vector)
        self.residual(self.u.vector, b, apply_bcs=False)
        arr = b.array_r.copy()
        b.destroy()
        return arr
