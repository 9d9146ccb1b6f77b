"""PETSc matrices whose sparsity covers the bulk form plus the contact couplings.

dolfinx's ``create_matrix`` preallocates the bulk pattern only; mortar contact
couples slave dofs with master dofs that may live on other ranks. Here the
pattern is the union of dolfinx's bulk sparsity (block level) and a list of
contact couplings given as global block-row/block-column pairs; rows owned by
other ranks are sent to their owner. The matrix is AIJ with block size gdim and
the local-to-global map of the displacement space (so dolfinx's bulk assembly
with ``MatSetValuesLocal`` works unchanged). Couplings that the contact terms learn
while a Jacobian is assembled grow the pattern in place before the values go in
(:class:`RecordedValues`, :meth:`MatrixPattern.grow`).
"""

from __future__ import annotations

import logging

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

    ``create(extra_rows, extra_cols)`` is collective; the returned Mat belongs to the caller.
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

    @property
    def nblocks(self) -> int:
        """Global number of block rows (= block columns)."""
        return int(self.ranges[-1])

    def create(self, extra_rows=None, extra_cols=None) -> PETSc.Mat:
        """A new preallocated matrix for the bulk pattern ∪ the given global block couplings."""
        if extra_rows is None:
            extra_rows = np.empty(0, dtype=np.int64)
            extra_cols = np.empty(0, dtype=np.int64)
        extra_rows = np.asarray(extra_rows, np.int64)
        extra_cols = np.asarray(extra_cols, np.int64)
        er, ec = _send_rows_to_owners(self.comm, self.ranges, extra_rows, extra_cols)
        nglob = self.nblocks
        self.key_set = np.unique(np.concatenate([self.rows * nglob + self.cols, er * nglob + ec]))
        # the couplings this rank knows to be in the pattern (any row): checked locally first
        self._known = np.unique(np.concatenate([self.key_set, extra_rows * nglob + extra_cols]))
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
        log.debug("matrix pattern: %d block nonzeros (%d from contact)", self.key_set.size, er.size)
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
        couplings ``keys`` = block row × N_blocks + block column (any rows; local input),
        collective.

        Keys this rank knows are skipped; the others go to their rows' owners. Where any
        is new, every rank preallocates ``A`` again in place for the grown pattern (PETSc
        then discards its values: the caller assembles again) and True is returned. This
        replaces PETSc's reallocations of rows that overflow inside ``MatSetValues``, which
        copy the whole matrix each time (hertz3d with the unconstrained recovery: 0.76 s
        for one Jacobian instead of 0.09 s; 45 s for the first one of a P2 FD check)."""
        nglob = self.nblocks
        keys = np.unique(keys)
        keys = keys[~_sorted_contains(self._known, keys)]
        if self.comm.allreduce(int(keys.size), op=MPI.MAX) == 0:
            return False  # the usual case (nothing learned, or all known): one reduction
        er, ec = _send_rows_to_owners(self.comm, self.ranges, keys // nglob, keys % nglob)
        got = np.unique(er * nglob + ec)
        new = got[~_sorted_contains(self.key_set, got)]
        grown = self.comm.allreduce(int(new.size), op=MPI.SUM) > 0
        if keys.size:
            self._known = np.union1d(self._known, keys)
        if grown:
            self.key_set = np.union1d(self.key_set, new)
            self._known = np.union1d(self._known, new)
            self._preallocate(A)
            A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
            log.debug("matrix pattern grown by %d block couplings", new.size)
        return grown


def _sorted_contains(sorted_keys: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Mask of ``keys`` found in the sorted array ``sorted_keys`` (local)."""
    if not sorted_keys.size:
        return np.zeros(keys.size, bool)
    pos = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
    return sorted_keys[pos] == keys


class RecordedValues:
    """Stand-in for a PETSc Mat that keeps ``setValues(rows, cols, values, ADD_VALUES)``
    calls (global indices) for :meth:`replay` (local). Lets the caller grow the matrix
    pattern (:meth:`MatrixPattern.grow`) before any value goes in. The arrays are kept,
    not copied: a caller must not overwrite them before the replay (the contact terms
    pass fresh arrays, or views of arrays they no longer change)."""

    def __init__(self):
        self._calls = []

    def setValues(self, rows, cols, values, addv=None) -> None:  # noqa: N802 (PETSc's name)
        if addv != PETSc.InsertMode.ADD_VALUES:
            raise ValueError("RecordedValues records ADD_VALUES only")
        self._calls.append((rows, cols, values))

    def replay(self, A: PETSc.Mat) -> None:
        """The recorded calls, in order, on ``A`` (local; ``A.assemble()`` is the caller's)."""
        for rows, cols, values in self._calls:
            A.setValues(rows, cols, values, addv=PETSc.InsertMode.ADD_VALUES)
        self._calls = []
