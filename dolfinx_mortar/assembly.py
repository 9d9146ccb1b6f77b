"""PETSc matrices whose sparsity covers the bulk form plus the contact couplings.

dolfinx's ``create_matrix`` preallocates the bulk pattern only; mortar contact
couples slave dofs with master dofs that may live on other ranks. Here the
pattern is the union of dolfinx's bulk sparsity (block level) and a list of
contact couplings given as global block-row/block-column pairs; rows owned by
other ranks are sent to their owner. The matrix is AIJ with block size gdim and
the local-to-global map of the displacement space (so dolfinx's bulk assembly
with ``MatSetValuesLocal`` works unchanged). The couplings of every contact Jacobian
are checked against the matrix's pattern before its values go in, and grow the
pattern in place where they are new (:class:`RecordedValues`,
:meth:`MatrixPattern.grow`): PETSc would otherwise reallocate inside ``MatSetValues``.

The contact Jacobians go in as ragged blocks, padded to a common width with dof −1
(which PETSc skips) and inserted with one ``setValuesRCV`` per batch
(:func:`add_outer_blocks`, :func:`add_square_blocks`, :func:`add_row_blocks`,
:func:`add_keyed_blocks`).
"""

from __future__ import annotations

import logging
import weakref

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from . import compat

log = logging.getLogger(__name__)


def bulk_block_pattern(a_form, V) -> tuple[np.ndarray, np.ndarray]:
    """Global (block row, block column) pairs of the bulk form's sparsity, owned rows only.

    Local, not collective except for dolfinx's pattern assembly (collective).
    Returns two int64 arrays of equal length.
    """
    sp = compat.sparsity_pattern(a_form)
    imap = V.dofmap.index_map
    nrow = imap.size_local
    graph = sp.graph
    offsets = np.asarray(graph.offsets)
    cols_local = np.asarray(graph.array, dtype=np.int32)
    cmap = sp.column_index_map()
    ncol_local = cmap.size_local + cmap.num_ghosts
    col_global = np.asarray(
        cmap.local_to_global(np.arange(ncol_local, dtype=np.int32)), dtype=np.int64
    )
    row_global = np.arange(nrow, dtype=np.int64) + imap.local_range[0]
    counts = np.diff(offsets[: nrow + 1])
    rows = np.repeat(row_global, counts)
    cols = col_global[cols_local[: offsets[nrow]]]
    return rows, cols


def _send_rows_to_owners(comm, ranges: np.ndarray, rows: np.ndarray, cols: np.ndarray):
    """Alltoallv the (row, col) pairs to the ranks owning the rows (collective)."""
    owner = np.searchsorted(ranges, rows, side="right") - 1
    order = np.argsort(owner, kind="stable")
    rows, cols, owner = rows[order], cols[order], owner[order]
    send_counts = np.bincount(owner, minlength=comm.size).astype(np.int64)
    recv_counts = np.empty_like(send_counts)
    comm.Alltoall(send_counts, recv_counts)
    sbuf = np.empty(2 * rows.size, dtype=np.int64)
    sbuf[0::2], sbuf[1::2] = rows, cols
    rbuf = np.empty(2 * int(recv_counts.sum()), dtype=np.int64)
    comm.Alltoallv([sbuf, 2 * send_counts], [rbuf, 2 * recv_counts])
    return rbuf[0::2], rbuf[1::2]


class MatrixPattern:
    """Builds and owns nothing but the recipe: bulk pattern + contact couplings → AIJ matrix.

    ``create(keys)`` is collective; the returned Mat belongs to the caller.
    """

    def __init__(self, a_form, V):
        self.V = V
        self.comm = V.mesh.comm
        self.bs = V.dofmap.index_map_bs
        imap = V.dofmap.index_map
        self.nrow = imap.size_local
        self.rows, self.cols = bulk_block_pattern(a_form, V)
        ranges = np.asarray(
            self.comm.allgather(imap.local_range[0]) + [imap.size_global], dtype=np.int64
        )
        self.ranges = ranges
        nblocks = imap.size_local + imap.num_ghosts
        gblocks = np.asarray(
            imap.local_to_global(np.arange(nblocks, dtype=np.int32)), dtype=PETSc.IntType
        )
        self.lgmap = PETSc.LGMap().create(gblocks, bsize=self.bs, comm=self.comm)
        self.key_set = np.empty(0, dtype=np.int64)  # block couplings of the owned rows
        self._known = np.empty(0, dtype=np.int64)
        nglob = int(ranges[-1])
        self._bulk_keys = np.unique(self.rows * nglob + self.cols)
        #: per matrix (by handle): what this rank knows its pattern holds (_MatrixSlots)
        self._slots: dict[int, _MatrixSlots] = {}

    @property
    def nblocks(self) -> int:
        """Global number of block rows (= block columns)."""
        return int(self.ranges[-1])

    def create(self, keys=None) -> PETSc.Mat:
        """A new preallocated matrix for the bulk pattern ∪ the global block couplings
        ``keys`` (block row × N_blocks + block column, sorted and unique, any rows;
        collective). Couplings of rows owned elsewhere go to their owners."""
        nglob = self.nblocks
        keys = np.empty(0, np.int64) if keys is None else np.asarray(keys, np.int64)
        r0, r1 = nglob * self.ranges[self.comm.rank], nglob * self.ranges[self.comm.rank + 1]
        lo, hi = np.searchsorted(keys, [r0, r1])  # the owned rows' keys: a sorted slice
        away = np.concatenate([keys[:lo], keys[hi:]])
        er, ec = _send_rows_to_owners(self.comm, self.ranges, away // nglob, away % nglob)
        got = np.unique(er * nglob + ec)
        self.key_set = _merge_sorted(_merge_sorted(self._bulk_keys, keys[lo:hi]), got)
        # the couplings this rank knows to be in the pattern (any row): checked locally first
        self._known = _merge_sorted(self.key_set, away)
        n = self.nrow * self.bs
        A = PETSc.Mat().create(comm=self.comm)
        A.setType(PETSc.Mat.Type.AIJ)
        A.setSizes(((n, PETSc.DECIDE), (n, PETSc.DECIDE)), bsize=self.bs)
        self._preallocate(A)
        A.setLGMap(self.lgmap, self.lgmap)
        # a coupling that appears within a Newton solve (sliding beyond the candidates
        # used for the pattern) still goes in; :meth:`grow` normally sees it first
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        A.setUp()
        # forget the matrices destroyed or collected since (their handles may be reused)
        self._slots = {
            h: v for h, v in self._slots.items() if getattr(v.matrix(), "handle", 0) == h
        }
        self._slots[A.handle] = _MatrixSlots(A)
        log.debug(
            "matrix pattern: %d block nonzeros (%d contact couplings)", self.key_set.size, keys.size
        )
        return A

    def _preallocate(self, A: PETSc.Mat) -> None:
        """Preallocate ``A`` (new, or assembled: its values are then discarded) for the
        owned rows of ``key_set`` (local). Counts only: a slot not filled by the first
        final assembly is squeezed out, so the factorization sees the couplings in use,
        not every candidate."""
        nglob = self.nblocks
        r0, r1 = self.ranges[self.comm.rank], self.ranges[self.comm.rank + 1]
        rows, cols = self.key_set // nglob, self.key_set % nglob
        diag = (cols >= r0) & (cols < r1)
        lr = (rows - r0).astype(np.int64)
        d_nnz = np.bincount(lr[diag], minlength=self.nrow).astype(PETSc.IntType)
        o_nnz = np.bincount(lr[~diag], minlength=self.nrow).astype(PETSc.IntType)
        # AIJ with block size bs: petsc4py wants counts per scalar row
        A.setPreallocationNNZ(
            (np.repeat(d_nnz * self.bs, self.bs), np.repeat(o_nnz * self.bs, self.bs))
        )

    def grow(self, A: PETSc.Mat, keys: np.ndarray) -> bool:
        """Make the pattern of ``A`` (made by :meth:`create`) cover the global block
        couplings ``keys`` = block row × N_blocks + block column (sorted, unique, any
        rows, as :meth:`RecordedValues.block_couplings` gives them; local input) that
        are about to be inserted, collective.

        Until its first final assembly a matrix holds the slots :meth:`create` or the last
        growth preallocated (``key_set``, every candidate coupling). That assembly
        squeezes out the slots it did not fill, so from then on the matrix holds the
        bulk and the contact couplings inserted so far (:meth:`filled`), and a contact
        zone that has grown since needs new slots. Keys this rank knows to be held are
        skipped; the others go to their rows' owners. Where any is new, every rank
        preallocates ``A`` again in place for ``key_set`` and the new keys, puts explicit
        zeros in the contact couplings it had inserted before (the pattern only grows),
        and True is returned: ``A`` has lost its values, and the caller assembles again.
        This replaces PETSc's reallocations of rows that overflow inside ``MatSetValues``,
        which copy the whole matrix each time (hertz3d with the unconstrained recovery:
        0.76 s for one Jacobian instead of 0.09 s; hertz3d with the lumped one: 1273
        such copies in one matrix at 11k dofs, 16 s of an 84 s run at 53k dofs)."""
        nglob = self.nblocks
        slots = self._slots_of(A)
        fresh = slots is None or slots.fresh

        def held(k: np.ndarray) -> np.ndarray:
            if fresh:
                return sorted_contains(self._known, k)
            return slots.holds(k, self._bulk_keys)

        keys = keys[~held(keys)]
        if self.comm.allreduce(int(keys.size), op=MPI.MAX) == 0:
            return False  # the usual case: one reduction
        er, ec = _send_rows_to_owners(self.comm, self.ranges, keys // nglob, keys % nglob)
        got = np.unique(er * nglob + ec)
        owned = sorted_contains(self.key_set, got) if fresh else slots.holds(got, self._bulk_keys)
        new = got[~owned]
        grown = self.comm.allreduce(int(new.size), op=MPI.SUM) > 0
        if keys.size:
            self._known = _sorted_union(self._known, keys)
        if grown:
            self.key_set = _sorted_union(self.key_set, new)
            self._known = _sorted_union(self._known, new)
            self._preallocate(A)
            A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
            if slots is not None:
                _insert_zeros(A, slots.contact, nglob, self.bs)
                slots.fresh = True
            A.assemblyBegin(PETSc.Mat.AssemblyType.FLUSH)
            A.assemblyEnd(PETSc.Mat.AssemblyType.FLUSH)
            log.debug("matrix pattern grown by %d block couplings", new.size)
        elif not fresh:
            slots.confirmed = _sorted_union(slots.confirmed, keys)  # the owners hold them
        return grown

    def filled(self, A: PETSc.Mat, keys: np.ndarray, bulk: bool) -> None:
        """Record that a final assembly of ``A`` followed the insertion of the contact
        couplings ``keys`` (sorted, unique: this rank's, any rows) and, with ``bulk``, of
        the bulk part (local). ``A`` then holds them, the contact couplings inserted
        before, and no other slot."""
        slots = self._slots_of(A)
        if slots is None:
            return
        new = keys[~sorted_contains(slots.contact, keys)]
        if new.size:
            slots.contact = _sorted_union(slots.contact, new)
        if slots.fresh:  # squeezed: what other ranks had put in is unknown here
            slots.confirmed = np.empty(0, np.int64)
        slots.fresh, slots.bulk = False, bulk

    def _slots_of(self, A: PETSc.Mat):
        """The record of ``A`` (None for a matrix this pattern did not make). PETSc's
        callbacks hand over new Python objects for the same matrix: compared by handle."""
        slots = self._slots.get(A.handle)
        mat = None if slots is None else slots.matrix()
        return slots if mat is not None and mat.handle == A.handle else None


class _MatrixSlots:
    """What one rank knows of the pattern of one matrix (see :meth:`MatrixPattern.grow`):
    ``matrix`` (a weak reference: the caller owns the matrix), ``fresh`` (preallocated,
    not squeezed yet), ``bulk`` (its last fill included the bulk part), ``contact`` (the
    sorted contact couplings this rank inserted, any rows), ``confirmed`` (sorted keys
    their owners said they hold since the last squeeze)."""

    def __init__(self, A: PETSc.Mat):
        self.matrix = weakref.ref(A)
        self.fresh = True
        self.bulk = True
        self.contact = np.empty(0, np.int64)
        self.confirmed = np.empty(0, np.int64)

    def holds(self, keys: np.ndarray, bulk_keys: np.ndarray) -> np.ndarray:
        """Mask of the sorted ``keys`` the squeezed matrix is known to hold: the bulk of
        the owned rows (``bulk_keys``, where the last fill had it), the contact couplings
        inserted, and those confirmed by their owners (local)."""
        mask = sorted_contains(self.contact, keys) | sorted_contains(self.confirmed, keys)
        if self.bulk:
            mask |= sorted_contains(bulk_keys, keys)
        return mask


def _insert_zeros(A: PETSc.Mat, keys: np.ndarray, nglob: int, bs: int) -> None:
    """Explicit zeros in the dofs of the sorted global block couplings ``keys`` (any rows;
    local, not assembled): one dense block row at a time."""
    if not keys.size:
        return
    rows, cols = keys // nglob, keys % nglob
    bounds = np.flatnonzero(np.diff(rows)) + 1
    comp = np.arange(bs, dtype=PETSc.IntType)
    for r, c in zip(np.split(rows, bounds), np.split(cols, bounds), strict=True):
        ridx = (r[0] * bs + comp).astype(PETSc.IntType)
        cidx = (c[:, None] * bs + comp).ravel().astype(PETSc.IntType)
        A.setValues(ridx, cidx, np.zeros(ridx.size * cidx.size), addv=PETSc.InsertMode.ADD_VALUES)


def unique_runs(keys: np.ndarray) -> np.ndarray:
    """``np.unique`` of int64 ``keys`` made of sorted runs (local): a stable sort (timsort,
    which merges runs instead of sorting afresh: 38 ms against 82 ms for 1.2 × 10⁶ keys in
    400 runs) and the duplicates dropped. ``keys`` is sorted in place."""
    keys.sort(kind="stable")
    return keys[np.concatenate([[True], keys[1:] != keys[:-1]])] if keys.size else keys


def _merge_sorted(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The sorted union of two sorted unique int64 arrays (local)."""
    return unique_runs(np.concatenate([a, b]))


def _sorted_union(sorted_keys: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """``np.union1d(sorted_keys, keys)`` for a sorted unique ``sorted_keys`` (local): the
    keys not in it are inserted in place of a sort of the whole (a growth step adds a few
    hundred keys to sets of 10⁵–10⁶)."""
    keys = np.unique(keys)
    keys = keys[~sorted_contains(sorted_keys, keys)]
    return np.insert(sorted_keys, np.searchsorted(sorted_keys, keys), keys)


def sorted_contains(sorted_keys: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Mask of ``keys`` found in the sorted array ``sorted_keys`` (local)."""
    if not sorted_keys.size:
        return np.zeros(keys.size, bool)
    pos = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
    return sorted_keys[pos] == keys


def _blocks_per_row(idx: np.ndarray, bs: int) -> np.ndarray:
    """The distinct block indices of each row of the 2D dof array ``idx`` (local): shape
    (rows, k) with k the most any row has, −1 padding (negative dofs are skipped)."""
    blk = np.where(idx >= 0, idx // bs, -1)
    blk.sort(axis=1)
    blk[:, 1:][blk[:, 1:] == blk[:, :-1]] = -1
    blk = -np.sort(-blk, axis=1)  # distinct blocks first, then the −1s
    k = int((blk >= 0).sum(axis=1).max(initial=0))
    return blk[:, :k]


class RecordedValues:
    """Stand-in for a PETSc Mat that keeps ``setValues(rows, cols, values, ADD_VALUES)``
    and ``setValuesRCV(R, C, V, ADD_VALUES)`` calls (global indices) for :meth:`replay`
    (local). Lets the caller grow the matrix pattern (:meth:`MatrixPattern.grow`) before
    any value goes in. The arrays are kept, not copied: a caller must not overwrite them
    before the replay (the contact terms pass fresh arrays, or views of arrays they no
    longer change)."""

    def __init__(self):
        self._calls = []
        self._batches = []

    def setValues(self, rows, cols, values, addv=None) -> None:  # noqa: N802 (PETSc's name)
        if addv != PETSc.InsertMode.ADD_VALUES:
            raise ValueError("RecordedValues records ADD_VALUES only")
        self._calls.append((rows, cols, values))

    def setValuesRCV(self, R, C, V, addv=None) -> None:  # noqa: N802 (PETSc's name)
        """A batch of dense blocks: block k adds V[k] (rows × cols) at R[k] × C[k]; R
        (blocks, rows), C (blocks, cols), V (blocks, rows, cols); negative indices are
        skipped, as PETSc skips them. One call where setValues would take one per block."""
        if addv != PETSc.InsertMode.ADD_VALUES:
            raise ValueError("RecordedValues records ADD_VALUES only")
        if len(R):
            self._batches.append((R, C, V))

    def indices(self) -> list[np.ndarray]:
        """The row and column index arrays of the recorded batches, then of the single
        calls, in order (local; the recorded arrays themselves, not copies: a caller that
        keeps them past the replay copies them). Two recordings with equal lists fill the
        same :meth:`block_couplings`."""
        out = []
        for rows, cols, _ in (*self._batches, *self._calls):
            out += [np.asarray(rows), np.asarray(cols)]
        return out

    def block_couplings(self, bs: int, nglob: int) -> np.ndarray:
        """The sorted global block couplings (block row × ``nglob`` + block column) that the
        recorded calls fill: for each call or block, its block rows × its block columns
        (local; negative indices, constrained dofs, are skipped as PETSc skips them)."""
        keys = [self._call_couplings(bs, nglob)]
        for R, C, _ in self._batches:
            rb = _blocks_per_row(np.asarray(R, np.int64), bs)
            cb = rb if C is R else _blocks_per_row(np.asarray(C, np.int64), bs)
            pair = rb[:, :, None] * nglob + cb[:, None, :]
            keys.append(pair[(rb[:, :, None] >= 0) & (cb[:, None, :] >= 0)])
        return np.unique(np.concatenate(keys))

    def _call_couplings(self, bs: int, nglob: int) -> np.ndarray:
        """:meth:`block_couplings` of the single ``setValues`` calls (local)."""
        if not self._calls:
            return np.empty(0, np.int64)
        n = len(self._calls)

        def blocks(which: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            idx = [np.asarray(c[which], np.int64) for c in self._calls]
            call = np.repeat(np.arange(n, dtype=np.int64), [i.size for i in idx])
            idx = np.concatenate(idx)
            keep = idx >= 0
            u = np.unique(call[keep] * nglob + idx[keep] // bs)  # (call, block), sorted
            owner = u // nglob
            return owner, u % nglob, np.bincount(owner, minlength=n)

        r_call, r_blk, c_count = blocks(0)
        c_blk = r_blk
        if any(c[0] is not c[1] for c in self._calls):  # most calls are square: rows = cols
            _, c_blk, c_count = blocks(1)
        c_start = np.concatenate([[0], np.cumsum(c_count)[:-1]])
        rep = c_count[r_call]  # each (call, row block) meets the call's column blocks
        total = int(rep.sum())
        first = np.repeat(np.cumsum(rep) - rep, rep)
        cols = c_blk[np.repeat(c_start[r_call], rep) + np.arange(total) - first]
        return np.repeat(r_blk, rep) * nglob + cols

    def replay(self, A: PETSc.Mat) -> None:
        """The recorded calls on ``A`` (local; ``A.assemble()`` is the caller's): the
        batches first, then the single calls in order."""
        ADD = PETSc.InsertMode.ADD_VALUES
        for R, C, V in self._batches:
            A.setValuesRCV(np.asarray(R, PETSc.IntType), np.asarray(C, PETSc.IntType), V, addv=ADD)
        for rows, cols, values in self._calls:
            A.setValues(rows, cols, values, addv=ADD)
        self._calls = []
        self._batches = []


def add_keyed_blocks(A: PETSc.Mat, key, rows, cols, vals) -> None:
    """A[rows_e, cols_e] += vals_e (global indices, −1 ignored) for the entries e, with
    rows (E, r), cols (E, c), vals (E, r, c); entries with equal ``key`` (E,) have the same
    rows and columns and are summed first; the sums that are not all zero go in with one
    ``setValuesRCV`` (local)."""
    if not key.size:
        return
    order = np.argsort(key, kind="stable")
    k = key[order]
    start = np.flatnonzero(np.r_[True, k[1:] != k[:-1]])
    sums = np.add.reduceat(vals[order], start, axis=0)
    nz = np.any(sums != 0.0, axis=(1, 2))
    sums, first = sums[nz], order[start][nz]
    if first.size:
        r = rows[first].astype(PETSc.IntType)
        c = r if cols is rows else cols[first].astype(PETSc.IntType)
        A.setValuesRCV(r, c, sums, addv=PETSc.InsertMode.ADD_VALUES)


def padded_rows(off, sel, *data):
    """The ragged rows ``sel`` of CSR arrays sharing the offsets ``off``, padded to the
    longest row (local): for each flat array in ``data``, a (sel.size, width) array with
    −1 (integer data: a dof PETSc skips) or 0 (real data) after each row's entries."""
    n_sel = off[sel + 1] - off[sel]
    row = np.repeat(np.arange(sel.size), n_sel)
    pos = np.arange(row.size) - np.repeat(np.cumsum(n_sel) - n_sel, n_sel)
    src = np.repeat(off[sel], n_sel) + pos
    width = int(n_sel.max(initial=0))
    out = []
    for d in data:
        integer = np.issubdtype(d.dtype, np.integer)
        a = np.full((sel.size, width), -1 if integer else 0, PETSc.IntType if integer else d.dtype)
        a[row, pos] = d[src]
        out.append(a)
    return out


def _chunks(sel, off, chunk: int):
    """``sel`` split so that each part's padded square blocks hold about ``chunk`` entries."""
    width = int((off[sel + 1] - off[sel]).max(initial=1))
    step = max(1, chunk // width**2)
    return [sel[lo : lo + step] for lo in range(0, sel.size, step)]


def add_outer_blocks(A, c_off, c_idx, c_val, coef, chunk: int = 1 << 22) -> None:
    """A += Σ_I coef_I B^I ⊗ B^I over the nodes with coef_I > 0, B^I the CSR row
    c_idx[c_off[I]:c_off[I+1]] (global dofs) with values c_val (local). The rows are
    padded to the longest one with dof −1 (skipped by PETSc) and inserted with one
    ``setValuesRCV`` per ``chunk`` entries instead of one ``setValues`` per node."""
    nodes = np.flatnonzero((coef > 0.0) & (np.diff(c_off) > 0))
    for sel in _chunks(nodes, c_off, chunk):
        idx, val = padded_rows(c_off, sel, c_idx, c_val)
        blocks = coef[sel, None, None] * val[:, :, None] * val[:, None, :]
        A.setValuesRCV(idx, idx, blocks, addv=PETSc.InsertMode.ADD_VALUES)


def add_square_blocks(A, u_off, U, k_off, K, chunk: int = 1 << 22) -> None:
    """A[U_i, U_i] += K_i for the ragged blocks i: dofs U[u_off[i]:u_off[i+1]] (global,
    −1 skipped), K_i = K[k_off[i]:k_off[i+1]] the n_i × n_i block in row-major order
    (local). Padded as :func:`add_outer_blocks`, one ``setValuesRCV`` per ``chunk``
    entries instead of one ``setValues`` per block."""
    n = np.diff(u_off)
    for sel in _chunks(np.flatnonzero(n > 0), u_off, chunk):
        (idx,) = padded_rows(u_off, sel, U)
        width = idx.shape[1]
        sq = n[sel] ** 2
        blk = np.repeat(np.arange(sel.size), sq)
        local = np.arange(blk.size) - np.repeat(np.cumsum(sq) - sq, sq)  # 0 … n_i² − 1
        side = np.repeat(n[sel], sq)
        blocks = np.zeros((sel.size, width, width))
        blocks[blk, local // side, local % side] = K[np.repeat(k_off[sel], sq) + local]
        A.setValuesRCV(idx, idx, blocks, addv=PETSc.InsertMode.ADD_VALUES)


def add_row_blocks(A, u_off, U, r_off, R, k_off, K, chunk: int = 1 << 22) -> None:
    """A[R_i, U_i] += K_i for the ragged rectangular blocks i: columns U[u_off[i]:u_off[i+1]]
    and rows R[r_off[i]:r_off[i+1]] (global dofs, −1 skipped), K_i = K[k_off[i]:k_off[i+1]]
    the n_r × n_u block in row-major order (:func:`.kernels.friction.node_tangent_blocks`;
    local). Padded as :func:`add_square_blocks`, one ``setValuesRCV`` per ``chunk``
    entries."""
    nu, nr = np.diff(u_off), np.diff(r_off)
    sel_all = np.flatnonzero((nu > 0) & (nr > 0))
    if not sel_all.size:
        return
    wc, wr = int(nu[sel_all].max()), int(nr[sel_all].max())
    step = max(1, chunk // (wc * wr))
    for lo in range(0, sel_all.size, step):
        sel = sel_all[lo : lo + step]
        (cols,) = padded_rows(u_off, sel, U)
        (rows,) = padded_rows(r_off, sel, R)
        n = nr[sel] * nu[sel]
        blk = np.repeat(np.arange(sel.size), n)
        local = np.arange(blk.size) - np.repeat(np.cumsum(n) - n, n)
        side = np.repeat(nu[sel], n)
        blocks = np.zeros((sel.size, rows.shape[1], cols.shape[1]))
        blocks[blk, local // side, local % side] = K[np.repeat(k_off[sel], n) + local]
        A.setValuesRCV(rows, cols, blocks, addv=PETSc.InsertMode.ADD_VALUES)
