"""Distributed contact search: no rank ever holds a whole contact surface.

- :func:`distribute_slave_facets`: each slave facet goes to every rank owning
  one of its mixed-field nodes (a rank computes the nodal mortar integrals of
  the nodes it owns, so it needs every facet touching them).
- :func:`exchange_master_facets`: each rank sends its master facets only to the
  ranks whose (inflated) slave bounding box they come near, with all-to-all
  messages of packed facets (:mod:`dolfinx_mortar.layout`); with friction, in the
  current and the start-of-step configurations both (the t_n pairing's masters).
- :func:`candidates`: per slave facet, the master facets whose bounding box meets
  its inflated one (compiled sweeps along one axis, one per size class).
- :class:`Fetcher`: current displacements of arbitrary global dofs (PETSc
  scatter from the global vector), rebuilt only when the set of dofs changes.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from .kernels._numba import numba
from .layout import FacetArrays, pack, record_width, unpack


def _alltoall_rows(comm, rows_per_rank: list[np.ndarray], width: int) -> np.ndarray:
    """Send rows_per_rank[r] (shape (n_r, width)) to rank r; return the received rows (collective)."""
    send_counts = np.array([r.shape[0] * width for r in rows_per_rank], dtype=np.int64)
    recv_counts = np.empty_like(send_counts)
    comm.Alltoall(send_counts, recv_counts)
    sbuf = np.concatenate([r.ravel() for r in rows_per_rank]) if rows_per_rank else np.empty(0)
    rbuf = np.empty(int(recv_counts.sum()))
    comm.Alltoallv([sbuf, send_counts], [rbuf, recv_counts])
    return rbuf.reshape(-1, width)


def block_owner(ranges: np.ndarray, blocks: np.ndarray) -> np.ndarray:
    """Owning rank of global blocks, from the gathered ownership ranges (size+1,)."""
    return np.searchsorted(ranges, blocks, side="right") - 1


def distribute_slave_facets(
    comm, local: FacetArrays, mixed: np.ndarray, ranges: np.ndarray
) -> FacetArrays:
    """Local slave facets plus those of other ranks touching nodes this rank owns (collective).

    Returns only facets with at least one owned mixed-field node.
    """
    nn, d = local.nodes_per_facet, local.gdim
    owners = (
        block_owner(ranges, local.blocks[:, mixed])
        if local.num_facets
        else np.empty((0, len(mixed)), int)
    )
    rows = pack(local)
    out = []
    for r in range(comm.size):
        sel = np.any(owners == r, axis=1) if r != comm.rank else np.zeros(local.num_facets, bool)
        out.append(rows[sel])
    recv = unpack(_alltoall_rows(comm, out, record_width(nn, d)), local.ftype, nn, d)
    allf = FacetArrays.concatenate([local, recv])
    lo, hi = ranges[comm.rank], ranges[comm.rank + 1]
    mine = (allf.blocks[:, mixed] >= lo) & (allf.blocks[:, mixed] < hi)
    return allf.take(np.flatnonzero(mine.any(axis=1)))


def bounding_box(x: np.ndarray, d: int) -> np.ndarray:
    """(2, d) box of points x (..., d); an inverted box when there are none."""
    pts = x.reshape(-1, d)
    if pts.size == 0:
        return np.array([np.full(d, np.inf), np.full(d, -np.inf)])
    return np.array([pts.min(axis=0), pts.max(axis=0)])


def exchange_master_facets(
    comm, local: FacetArrays, x_local, slave_x, margin: float
) -> FacetArrays:
    """Master facets (of any rank) near this rank's slave facets (collective).

    ``x_local`` (nf, nn, d): coordinates of the local master facets; ``slave_x``:
    coordinates of this rank's slave facet nodes (any shape (..., d)). A facet is sent
    to rank r when its box, inflated by ``margin``, meets r's slave box.

    Several configurations (the current one and the start of the step, for friction's
    t_n pairing): ``x_local`` and ``slave_x`` are then lists of the same length K, one
    entry per configuration, and a facet is sent to r when, in SOME configuration k, its
    box at k (inflated) meets r's slave box at k. The boxes of different configurations
    are not merged, so a slide within a step adds the facets near the slave surface's
    two positions, not those along the path between them. Every rank passes the same K.
    """
    d = local.gdim
    if not isinstance(x_local, (list, tuple)):
        x_local, slave_x = [x_local], [slave_x]
    if len(x_local) != len(slave_x):
        raise ValueError("exchange_master_facets: one slave configuration per master one")
    # (size, K, 2, d): every rank's slave box in each configuration
    boxes = np.array(comm.allgather(np.array([bounding_box(x, d) for x in slave_x])))
    rows = pack(local)
    if local.num_facets:
        lo = [x.min(axis=1) - margin for x in x_local]
        hi = [x.max(axis=1) + margin for x in x_local]
    out = []
    for r in range(comm.size):
        if local.num_facets == 0:
            out.append(rows)
            continue
        sel = np.zeros(local.num_facets, bool)
        for k in range(len(x_local)):
            sel |= np.all((hi[k] >= boxes[r, k, 0]) & (lo[k] <= boxes[r, k, 1]), axis=1)
        out.append(rows[sel])
    recv = _alltoall_rows(comm, out, record_width(local.nodes_per_facet, d))
    return unpack(recv, local.ftype, local.nodes_per_facet, d)


#: size classes of :func:`_box_sweep`: master extents within a factor 2 share one
MAX_CLASSES = 32


@numba.njit(cache=True)
def _box_sweep(slo, shi, mlo, mhi, off):
    """Every pair (f, m) whose boxes [slo[f], shi[f]] and [mlo[m], mhi[m]] ((n, d)
    arrays) overlap, by sweeps along the axis where the master boxes spread most.

    The master boxes are grouped in size classes (extent along the axis within a factor
    2 of each other, so graded meshes keep narrow windows) and sorted by their lower end
    within each class; a slave box tests only the masters of a class whose lower end
    lies in [slo − the class's largest extent, shi]. Fills the offsets ``off`` (nsf + 1,)
    and returns the master indices, ascending per f (the CSR of :func:`candidates`). A
    box with a NaN coordinate meets none."""
    nsf, d = slo.shape
    nmf = mlo.shape[0]
    axis = 0
    spread = -1.0
    for c in range(d):
        lo, hi = np.inf, -np.inf
        for m in range(nmf):
            lo = min(lo, mlo[m, c])
            hi = max(hi, mhi[m, c])
        if hi - lo > spread:
            spread, axis = hi - lo, c
    ext = mhi[:, axis] - mlo[:, axis]
    emax = 0.0
    for m in range(nmf):
        if ext[m] > emax:  # NaN: no
            emax = ext[m]
    cls = np.zeros(nmf, np.int64)
    for m in range(nmf):
        if ext[m] > 0.0 and emax > 0.0:
            cls[m] = min(MAX_CLASSES - 1, int(np.floor(np.log2(emax / ext[m]))))
    # masters by class, then by lower end (NaN last): a stable counting sort of the order
    by_lo = np.argsort(mlo[:, axis])
    coff = np.zeros(MAX_CLASSES + 1, np.int64)
    for m in range(nmf):
        coff[cls[m] + 1] += 1
    for k in range(MAX_CLASSES):
        coff[k + 1] += coff[k]
    fill = coff[:-1].copy()
    order = np.empty(nmf, np.int64)
    for j in range(nmf):
        m = by_lo[j]
        order[fill[cls[m]]] = m
        fill[cls[m]] += 1
    keys = mlo[order, axis]
    blo, bhi = mlo[order], mhi[order]  # the boxes in sweep order: contiguous reads
    cext = np.zeros(MAX_CLASSES)
    for m in range(nmf):
        if ext[m] > cext[cls[m]]:
            cext[cls[m]] = ext[m]
    idx = np.empty(0, np.int64)
    for sweep in range(2):  # count, then fill
        n = 0
        for f in range(nsf):
            off[f] = n
            for k in range(MAX_CLASSES):
                c0, c1 = coff[k], coff[k + 1]
                if c1 == c0:
                    continue
                a = c0 + np.searchsorted(keys[c0:c1], slo[f, axis] - cext[k])
                b = c0 + np.searchsorted(keys[c0:c1], shi[f, axis], side="right")
                for j in range(a, b):
                    ok = True
                    for c in range(d):
                        if not (bhi[j, c] >= slo[f, c] and blo[j, c] <= shi[f, c]):  # NaN: no
                            ok = False
                            break
                    if ok:
                        if sweep == 1:
                            idx[n] = order[j]
                        n += 1
            if sweep == 1:
                idx[off[f] : n].sort()
        off[nsf] = n
        if sweep == 0:
            idx = np.empty(n, np.int64)
    return idx


def candidates(xs: np.ndarray, xm: np.ndarray, reach: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CSR (offsets (nsf+1,), indices) of the master facets near each slave facet.

    A master facet is a candidate of slave facet f when their bounding boxes, the
    slave's inflated by ``reach[f]``, overlap (:func:`_box_sweep`: compiled sweeps per
    size class of master facets). xs (nsf, k, d), xm (nmf, k', d)
    facet node coordinates, reach (nsf,); indices sorted within each slave facet. Local
    (not collective).
    """
    nsf, nmf = xs.shape[0], xm.shape[0]
    if nsf == 0 or nmf == 0:
        return np.zeros(nsf + 1, np.int64), np.empty(0, np.int64)
    slo, shi = xs.min(axis=1) - reach[:, None], xs.max(axis=1) + reach[:, None]
    mlo, mhi = xm.min(axis=1), xm.max(axis=1)
    off = np.empty(nsf + 1, np.int64)
    return off, _box_sweep(slo, shi, mlo, mhi, off)


class Fetcher:
    """Current values of given global dofs of a distributed PETSc vector (collective create and fetch).

    Owns a PETSc Scatter, an IS and a sequential Vec; :meth:`destroy` frees them.
    """

    def __init__(self, vec: PETSc.Vec, dofs: np.ndarray):
        self.dofs = np.asarray(dofs, dtype=PETSc.IntType)
        self._is = PETSc.IS().createGeneral(self.dofs, comm=PETSc.COMM_SELF)
        self._out = PETSc.Vec().createSeq(self.dofs.size, comm=PETSc.COMM_SELF)
        self._sc = PETSc.Scatter().create(vec, self._is, self._out, None)

    def __call__(self, vec: PETSc.Vec) -> np.ndarray:
        self._sc.scatter(
            vec, self._out, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD
        )
        return self._out.array_r.copy()

    def destroy(self) -> None:
        for obj in (self._sc, self._out, self._is):
            obj.destroy()


#: A point closer than sqrt(this) × (1 + |x|) to a geometry node of a cell is that node
#: (points_in_cells: a cell of which it is a node does not count as holding it)
_OWN_NODE_TOL2 = 1e-24


def points_in_cells(comm, mesh, cells: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Which of this rank's ``points`` (n, 3), reference coordinates, lie in one of the
    ``cells`` (local cell indices, owned or ghost) of any rank, other than a cell that
    has the point as one of its geometry nodes (the point's own cells, where it is a
    node of that mesh: a slave node is not "inside" the body it bounds). Returns (n,)
    bool. Collective: the ranks whose cells' bounding box holds a point (dolfinx's
    global bounding-box tree) are sent that point, test it against their cells
    (``compute_colliding_cells``, GJK to round-off) and send the answer back; no rank
    gathers a whole surface."""
    from dolfinx import geometry

    from .compat import cell_geometry_nodes

    tdim = mesh.topology.dim
    cells = np.asarray(cells, np.int32)
    points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
    tree = geometry.BoundingBoxTree(mesh, tdim, cells)
    ranks = geometry.compute_collisions(tree.create_global_tree(comm), points)
    point_of = np.repeat(np.arange(points.shape[0]), np.diff(ranks.offsets))
    rank_of = np.asarray(ranks.array, np.int64)
    send = [point_of[rank_of == r] for r in range(comm.size)]
    asked = comm.alltoall([points[s] for s in send])
    geo, x = cell_geometry_nodes(mesh), mesh.geometry.x
    answers = []
    for pts in asked:
        hit = np.zeros(pts.shape[0], bool)
        if pts.shape[0] and cells.size:
            coll = geometry.compute_colliding_cells(
                mesh, geometry.compute_collisions(tree, pts), pts
            )
            j = np.repeat(np.arange(pts.shape[0]), np.diff(coll.offsets))
            c = np.asarray(coll.array, np.int64)
            # not one of the point's own cells (the point is a geometry node of them)
            d2 = np.sum((x[geo[c]] - pts[j][:, None, :]) ** 2, axis=2).min(axis=1, initial=np.inf)
            own = d2 <= _OWN_NODE_TOL2 * (1.0 + np.sum(pts[j] ** 2, axis=1))
            hit[j[~own]] = True
        answers.append(hit)
    back = comm.alltoall(answers)
    inside = np.zeros(points.shape[0], bool)
    for s, b in zip(send, back, strict=True):
        inside[s] |= b
    return inside
