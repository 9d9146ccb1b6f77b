"""Slave and master surfaces: facets of a physical group as packed :class:`FacetArrays`.

For every facet of a group whose cell this rank owns, the facet's geometry
nodes are taken in basix's Lagrange order for the facet cell (the order the
kernels' shape functions use). That order is found once per (cell type,
local facet) geometrically: the cell's reference nodes are mapped to the
facet's reference coordinates through the facet's reference vertices and
matched against the facet element's nodes. The outward-normal sign of each
facet is fixed from the reference configuration (facet normal against the
vector from the cell centroid to the facet centroid).
"""

from __future__ import annotations

import math

import basix
import numpy as np
from mpi4py import MPI

from . import compat
from .kernels.gap import unit_normal
from .kernels.shape import (
    INTERVAL1,
    INTERVAL2,
    QUAD1,
    QUAD2,
    REFERENCE_NODES,
    TRIANGLE1,
    TRIANGLE2,
    tdim,
)
from .layout import FacetArrays
from .search import block_owner

_BASIX_CELL = {
    "triangle": basix.CellType.triangle,
    "quadrilateral": basix.CellType.quadrilateral,
    "tetrahedron": basix.CellType.tetrahedron,
    "hexahedron": basix.CellType.hexahedron,
}
_FACET_TYPE = {
    ("triangle", 1): INTERVAL1,
    ("triangle", 2): INTERVAL2,
    ("quadrilateral", 1): INTERVAL1,
    ("quadrilateral", 2): INTERVAL2,
    ("tetrahedron", 1): TRIANGLE1,
    ("tetrahedron", 2): TRIANGLE2,
    ("hexahedron", 1): QUAD1,
    ("hexahedron", 2): QUAD2,
}

#: The displacement degrees (= the mesh's geometry order) of the contact surfaces: P1/Q1
#: and P2/Q2 facets (the kernels' facet types; ``MortarContact`` checks it first).
CONTACT_DEGREES = tuple(sorted({degree for _, degree in _FACET_TYPE}))


def facet_type(cell_name: str, degree: int) -> int:
    """Kernel facet type code of the facets of ``cell_name`` cells of geometric degree ``degree``."""
    try:
        return _FACET_TYPE[(cell_name, degree)]
    except KeyError:
        raise ValueError(f"no contact facets for {cell_name} of degree {degree}") from None


def facet_node_orders(cell_name: str, degree: int) -> np.ndarray:
    """Cell-local node indices of each local facet in facet (basix) order, shape (num_facets, nn)."""
    ct = _BASIX_CELL[cell_name]
    cell_pts = basix.create_element(
        basix.ElementFamily.P, ct, degree, basix.LagrangeVariant.equispaced
    ).points
    verts = basix.geometry(ct)
    topo = basix.topology(ct)
    tdim = verts.shape[1]
    ftype = facet_type(cell_name, degree)
    ref = REFERENCE_NODES[ftype]
    orders = []
    for fverts in topo[tdim - 1]:
        v = verts[fverts]
        axes = (v[1:] - v[0]) if tdim == 2 else np.stack([v[1] - v[0], v[2] - v[0]])
        axes = axes.reshape(tdim - 1, tdim)
        rel = cell_pts - v[0]
        xi, *_ = np.linalg.lstsq(axes.T, rel.T, rcond=None)
        xi = xi.T
        on_facet = np.linalg.norm(xi @ axes - rel, axis=1) < 1e-10
        order = []
        for r in ref:
            d = np.linalg.norm(xi - r, axis=1) + np.where(on_facet, 0.0, 1e9)
            j = int(np.argmin(d))
            if d[j] > 1e-10:
                raise RuntimeError(f"facet node {r} not found on {cell_name} facet {fverts}")
            order.append(j)
        orders.append(order)
    return np.asarray(orders, dtype=np.int32)


def extract_facets(problem, group: str) -> tuple[FacetArrays, np.ndarray, int]:
    """Facets of facet group ``group`` whose cells this rank owns (local, no communication),
    in the mesh's coordinates (a contact pair moves them to its origin: :func:`pair_origin`,
    :func:`relative_to`).

    Returns ``(facets, cells, interior)``: the packed facets, the local index of each
    facet's cell (for material look-ups) and the number of facets of the group that are
    not on the boundary (shared by two cells) and that this rank owns, so that the sum
    over the ranks counts each such facet once whatever the partition (the caller
    rejects them collectively).
    """
    mesh = problem.mesh
    md = problem.mesh_data
    tdim = mesh.topology.dim
    fdim = tdim - 1
    cell_name = mesh.topology.cell_name()
    degree = mesh.geometry.cmap.degree
    if problem.degree != degree:
        raise ValueError("contact needs the displacement degree to equal the geometric degree")
    ftype = facet_type(cell_name, degree)
    orders = facet_node_orders(cell_name, degree)
    nn = orders.shape[1]
    d = mesh.geometry.dim
    facets = compat.tagged_entities(md.facet_tags, md.facet_groups[group])
    mesh.topology.create_connectivity(fdim, tdim)
    mesh.topology.create_connectivity(tdim, fdim)
    f2c = mesh.topology.connectivity(fdim, tdim)
    c2f = mesh.topology.connectivity(tdim, fdim)
    n_owned_cells = mesh.topology.index_map(tdim).size_local
    # an interior facet on a partition boundary is on both ranks (as owned or ghost, with
    # both its cells under the shared-facet ghost mode): count it on its owner only
    n_owned_facets = mesh.topology.index_map(fdim).size_local
    geo_nodes = compat.cell_geometry_nodes(mesh)
    x = mesh.geometry.x[:, :d]
    dofmap = problem.V.dofmap
    bs = dofmap.index_map_bs
    imap = dofmap.index_map
    nblocks = imap.size_local + imap.num_ghosts
    gblocks = np.asarray(imap.local_to_global(np.arange(nblocks, dtype=np.int32)), dtype=np.int64)
    rank = mesh.comm.rank
    blocks, dofs, X, signs, cells = [], [], [], [], []
    interior = 0
    nu = np.empty(d)
    centre = np.array([0.5] if fdim == 1 else ([1 / 3, 1 / 3] if ftype in (2, 3) else [0.5, 0.5]))
    for f in facets:
        cs = f2c.links(f)
        c = int(cs[0])
        if len(cs) != 1:
            interior += int(f < n_owned_facets)
            continue
        if c >= n_owned_cells:
            continue
        lf = int(np.flatnonzero(c2f.links(c) == f)[0])
        local_nodes = orders[lf]
        xn = x[geo_nodes[c, local_nodes]]
        cdofs = dofmap.cell_dofs(c)[local_nodes]
        gb = gblocks[cdofs]
        ldofs = (cdofs[:, None] * bs + np.arange(bs)).ravel()
        unit_normal(np.ascontiguousarray(xn), ftype, 1.0, centre, nu)
        out = xn.mean(axis=0) - x[geo_nodes[c]].mean(axis=0)
        blocks.append(gb)
        dofs.append(problem.global_dofs[ldofs])
        X.append(xn)
        signs.append(1.0 if nu @ out > 0 else -1.0)
        cells.append(c)
    if not blocks:
        return FacetArrays.empty(ftype, nn, d), np.empty(0, np.int32), interior
    nf = len(blocks)
    fa = FacetArrays(
        ftype,
        d,
        np.asarray(blocks, np.int64),
        np.asarray(dofs, np.int64),
        np.asarray(X, float),
        np.asarray(signs, float),
        np.full(nf, rank, np.int32),
    )
    return fa, np.asarray(cells, np.int32), interior


#: :func:`pair_origin`: a slave surface whose centre lies within this many times s (the
#: power of two above its size) of the origin gets the origin o = 0, and runs as it did
#: before the pair had an origin, to the last bit.
ORIGIN_NEAR = 8.0


def pair_origin(comm, X: np.ndarray) -> np.ndarray:
    """The origin o (d,) of a contact pair's coordinates (collective; the same on every
    rank, fixed for the run): the centre c of the global bounding box of the points X
    (..., d) (this rank's slave facet nodes, each facet on one rank), or 0 where
    max_k |c_k| ≤ ORIGIN_NEAR · s, s the power of two with L < s ≤ 2 L (L: the box's
    largest side).

    The contact kernels work in current coordinates x = X + u, whose round-off eps·|x|
    is noise in the gaps: 2e-12 for a model 1e4 from the origin, which ε_N turns into
    contact forces of the size of Newton's tolerance and Uzawa's multiplier changes. The
    pair keeps its coordinates relative to o (:mod:`~dolfinx_mortar.layout`: X − o), so
    that the kernels see (X − o) + u: on the slave surface at most L/2 (o ≠ 0) or
    (2 ORIGIN_NEAR + 0.5) L (o = 0, a model near the origin) per component, wherever the
    model sits. Along an axis where the surface lies far from 0 (X within a factor 2 of
    o_k), X − o is exact (Sterbenz) and (X − o) + o gives X back; elsewhere it rounds at
    eps·L, the round-off the kernels have anyway."""
    d = X.shape[-1]
    pts = X.reshape(-1, d)
    lo = np.array(pts.min(axis=0) if pts.size else np.full(d, np.inf), float)
    hi = np.array(pts.max(axis=0) if pts.size else np.full(d, -np.inf), float)
    comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)
    comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
    size = float(np.max(hi - lo)) if np.all(hi >= lo) else 0.0
    if not (math.isfinite(size) and size > 0.0):
        return np.zeros(d)
    s = math.ldexp(1.0, math.frexp(size)[1])  # the power of two in (L, 2 L]
    centre = 0.5 * (lo + hi)
    if np.max(np.abs(centre)) <= ORIGIN_NEAR * s:
        return np.zeros(d)
    return centre + 0.0  # + 0.0: no −0.0


def relative_to(fa: FacetArrays, origin: np.ndarray) -> FacetArrays:
    """The facets ``fa`` with coordinates X − ``origin`` (:func:`pair_origin`; a new
    FacetArrays sharing the other fields; ``fa`` itself where the origin is 0)."""
    if not np.any(origin):
        return fa
    return FacetArrays(fa.ftype, fa.gdim, fa.blocks, fa.dofs, fa.X - origin, fa.sign, fa.owner)


def shared_nodes(comm, ranges: np.ndarray, a: np.ndarray, b: np.ndarray) -> int:
    """The number of mesh nodes in both of two node sets spread over the ranks
    (collective; no rank gathers a set).

    ``a`` and ``b``: this rank's global node (dof block) indices of each set, any shape
    and with repeats (``FacetArrays.blocks``); ``ranges`` (size + 1,): the first global
    node of each rank and the total. Each rank sends its nodes to their owners, which
    intersect the two sets they receive."""
    ranges = np.asarray(ranges, dtype=np.int64)

    def to_owners(x):
        x = np.unique(np.asarray(x, dtype=np.int64).ravel())
        owner = block_owner(ranges, x)
        return [x[owner == r] for r in range(comm.size)]

    got_a = np.concatenate(comm.alltoall(to_owners(a)))
    got_b = np.concatenate(comm.alltoall(to_owners(b)))
    return comm.allreduce(int(np.intersect1d(got_a, got_b).size))


def mixed_nodes(ftype: int) -> np.ndarray:
    """Facet-local nodes carrying the mixed fields: the 3 vertices of a 6-node triangular
    facet (of a P2 tetrahedron), where ∫N_vertex = 0; every node of any other facet (the
    3-node intervals of 2D P2 cells included)."""
    if ftype == TRIANGLE2:
        return np.arange(3)
    return np.arange(REFERENCE_NODES[ftype].shape[0])


def quadrature(ftype: int, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss points (nq, k) and weights (nq,) on the reference facet, exact to ``degree``."""
    cell = {1: basix.CellType.interval, 2: basix.CellType.triangle}[tdim(ftype)]
    if ftype in (QUAD1, QUAD2):
        cell = basix.CellType.quadrilateral
    pts, wts = basix.make_quadrature(cell, degree)
    return np.ascontiguousarray(pts, dtype=float), np.ascontiguousarray(wts, dtype=float)


def nodal_rule(ftype: int, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Node-to-segment "quadrature": one point per facet node, weight ∫_f N_a dA₀.

    X (nf, nn, d) reference facet coordinates. Returns qp_xi (nf, nn, k) (the reference
    nodes) and qp_w (nf, nn) with w_{f,a} = Σ_q w_q N_a(ξ_q) J₀_f(ξ_q) from a Gauss rule
    exact for the facet's own polynomials. With these weights A^I = Σ_f w_{f,I} and
    G^I = A^I g(x_I): the mixed gap of a slave node is the gap at the node itself, the
    classical node-to-segment penalty baseline. Undefined on 6-node triangles, where the
    vertex functions integrate to zero (raises ValueError).
    """
    from .kernels.mortar import reference_weights
    from .kernels.shape import shape

    if ftype == TRIANGLE2:
        raise ValueError(
            "node-to-segment integration needs positive nodal weights, "
            "which 6-node triangles do not have"
        )
    nodes = REFERENCE_NODES[ftype]
    nf, nn = X.shape[0], nodes.shape[0]
    k = nodes.shape[1]
    pts, wts = quadrature(ftype, 8)
    gw_xi = np.zeros((nf, wts.size, k))
    gw = np.zeros((nf, wts.size))
    if nf:
        reference_weights(ftype, X, pts, wts, gw_xi, gw)
    N = np.empty((wts.size, 9))
    dN = np.empty((9, k))
    ddN = np.empty((9, k, k))
    row = np.empty(9)
    for q in range(wts.size):
        shape(ftype, np.ascontiguousarray(pts[q]), row, dN, ddN)
        N[q] = row
    qp_w = gw @ N[:, :nn]
    qp_xi = np.broadcast_to(nodes, (nf, nn, k)).copy()
    return qp_xi, qp_w


def dual_coefficients(
    ftype: int, ftype_phi: int, X: np.ndarray, rule: tuple[np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Biorthogonal ("dual") weight functions of the mixed field on every slave facet.

    Ψ_i = Σ_j C_ij Φ_j with C = D M⁻¹, M_ij = ∫_f Φ_i Φ_j dA₀, D = diag(∫_f Φ_i dA₀)
    (Wohlmuth's dual basis), so that ∫_f Ψ_i Φ_j dA₀ = δ_ij ∫_f Φ_j dA₀ and Σ_i Ψ_i = 1.

    X (nf, nn, d) reference facet coordinates; ``rule`` = (points (nq, k), weights (nq,)),
    a Gauss rule on the reference facet exact for Φ_iΦ_j J₀ (the contact's element rule).
    Returns C (nf, nphi, nphi) and the facet areas (nf,) = Σ_q w_q J₀(ξ_q). Raises
    ValueError when a Φ_i has ∫Φ_i ≤ 0 (no dual basis).
    """
    from .kernels.mortar import reference_weights
    from .kernels.shape import shape

    pts, wts = rule
    nf = X.shape[0]
    nq, k = pts.shape
    qp_xi, qp_w = np.zeros((nf, nq, k)), np.zeros((nf, nq))
    if nf:
        reference_weights(ftype, X, pts, wts, qp_xi, qp_w)
    nphi = REFERENCE_NODES[ftype_phi].shape[0]
    phi = np.empty((nq, nphi))
    N, dN, ddN = np.empty(9), np.empty((9, k)), np.empty((9, k, k))
    for q in range(nq):
        shape(ftype_phi, np.ascontiguousarray(pts[q]), N, dN, ddN)
        phi[q] = N[:nphi]
    M = np.einsum("fq,qi,qj->fij", qp_w, phi, phi)
    D = M.sum(axis=2)
    if np.any(D <= 0.0):
        raise ValueError("a mixed-field basis function has ∫Φ ≤ 0: no dual basis")
    # C = D M⁻¹ = (M⁻¹ D)ᵀ (M symmetric)
    C = np.transpose(np.linalg.solve(M, D[:, :, None] * np.eye(nphi)), (0, 2, 1))
    return np.ascontiguousarray(C), qp_w.sum(axis=1)
