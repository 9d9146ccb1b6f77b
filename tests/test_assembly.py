"""The PETSc insertion of the contact Jacobians' ragged blocks (dolfinx_mortar.assembly):
add_outer_blocks, add_square_blocks, add_row_blocks, add_keyed_blocks and the recorded
values, each against one setValues per block and a dense NumPy sum (serial)."""

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_mortar import assembly


def _dense(A: PETSc.Mat, n: int) -> np.ndarray:
    A.assemble()
    return A.getValues(range(n), range(n))


def _add_dense(ref: np.ndarray, rows, cols, block) -> None:
    """ref[rows, cols] += block, repeated indices summed, −1 skipped."""
    for a, r in enumerate(rows):
        for b, c in enumerate(cols):
            if r >= 0 and c >= 0:
                ref[r, c] += block[a, b]


def _open_matrix(n: int) -> PETSc.Mat:
    A = PETSc.Mat().createAIJ((n, n), nnz=n, comm=MPI.COMM_SELF)
    A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
    return A


def test_batched_block_insertion_equals_one_call_per_block():
    """assembly.add_outer_blocks / add_square_blocks (one setValuesRCV over padded ragged
    blocks) and assembly.RecordedValues.setValuesRCV (recorded, its block couplings, the
    replay) against dense NumPy sums of the same blocks; −1 dofs are skipped."""
    from dolfinx_mortar.assembly import RecordedValues

    rng = np.random.default_rng(3)
    n, bs = 24, 2
    lengths = np.array([3, 0, 5, 1, 4])
    off = np.concatenate([[0], np.cumsum(lengths)])
    idx = rng.integers(-1, n, off[-1])
    val = rng.standard_normal(off[-1])
    coef = np.array([2.0, 1.0, 0.0, 0.5, 3.0])  # node 2 has no tangent coefficient
    ref = np.zeros((n, n))
    for i in range(lengths.size):
        r, v = idx[off[i] : off[i + 1]], val[off[i] : off[i + 1]]
        if coef[i] > 0:
            _add_dense(ref, r, r, coef[i] * np.outer(v, v))
    A = _open_matrix(n)
    assembly.add_outer_blocks(A, off, idx, val, coef, chunk=40)  # several chunks
    assert np.allclose(_dense(A, n), ref, rtol=0, atol=1e-13)

    blocks = [rng.standard_normal((k, k)) for k in lengths]
    flat = np.concatenate([b.ravel() for b in blocks])
    k_off = np.concatenate([[0], np.cumsum(lengths**2)])
    ref = np.zeros((n, n))
    for i, b in enumerate(blocks):
        _add_dense(ref, idx[off[i] : off[i + 1]], idx[off[i] : off[i + 1]], b)
    A = _open_matrix(n)
    assembly.add_square_blocks(A, off, idx, k_off, flat, chunk=30)
    assert np.allclose(_dense(A, n), ref, rtol=0, atol=1e-13)

    R = rng.integers(-1, n, (6, 4))
    V = rng.standard_normal((6, 4, 4))
    rec = RecordedValues()
    rec.setValuesRCV(R, R, V, addv=PETSc.InsertMode.ADD_VALUES)
    ints = PETSc.IntType
    single = (np.array([0, 5], ints), np.array([7, 9, 11], ints), rng.standard_normal(6))
    rec.setValues(*single, addv=PETSc.InsertMode.ADD_VALUES)
    expect = {
        (int(a) // bs) * (n // bs) + int(b) // bs for r in R for a in r[r >= 0] for b in r[r >= 0]
    } | {(int(a) // bs) * (n // bs) + int(b) // bs for a in single[0] for b in single[1]}
    assert rec.block_couplings(bs, n // bs).tolist() == sorted(expect)
    ref = np.zeros((n, n))
    for r, v in zip(R, V, strict=True):
        _add_dense(ref, r, r, v)
    _add_dense(ref, single[0], single[1], single[2].reshape(2, 3))
    A = _open_matrix(n)
    rec.replay(A)
    assert np.allclose(_dense(A, n), ref, rtol=0, atol=1e-13)
    with pytest.raises(ValueError):
        rec.setValuesRCV(R, R, V, addv=PETSc.InsertMode.INSERT_VALUES)


@pytest.mark.parametrize("chunk, calls", [(1, 5), (80, 3), (1 << 22, 1)])
def test_row_block_insertion_equals_one_call_per_block(chunk, calls):
    """assembly.add_row_blocks (padded ragged rectangular blocks A[R_i, U_i] += K_i, one
    setValuesRCV per chunk; the rows-of-S^I friction tangent of the constrained recovery,
    kernels.friction.node_tangent_blocks) against the same blocks added by one setValues
    each and against a dense NumPy sum: rows R_i ⊂ columns U_i, dofs repeated across
    nodes, a node without dofs, one with columns but no rows, a −1 dof (skipped); chunk 1
    and 80 (the padded blocks are 6 × 6) give 5 and 3 setValuesRCV calls for the 5
    nonempty blocks, the default one (serial)."""
    rng = np.random.default_rng(11)
    n = 30
    nu = np.array([4, 0, 6, 3, 1, 5, 2])
    nr = np.array([2, 0, 6, 0, 1, 3, 1])  # node 1: no dofs; node 3: columns, no rows
    U_list, R_list = [], []
    for a, b in zip(nu, nr, strict=True):
        Ui = np.sort(rng.choice(n, a, replace=False))  # a small n: repeats across nodes
        U_list.append(Ui)
        R_list.append(np.sort(rng.choice(Ui, b, replace=False)))
    R_list[5][R_list[5] == U_list[5][0]] = -1  # a constrained dof (−1, skipped)
    U_list[5][0] = -1
    blocks = [rng.standard_normal((b, a)) for a, b in zip(nu, nr, strict=True)]
    u_off = np.concatenate([[0], np.cumsum(nu)])
    r_off = np.concatenate([[0], np.cumsum(nr)])
    k_off = np.concatenate([[0], np.cumsum(nu * nr)])
    U, R = np.concatenate(U_list).astype(np.int64), np.concatenate(R_list).astype(np.int64)
    K = np.concatenate([b.ravel() for b in blocks])
    assert len(set(U.tolist())) < U.size  # repeated dofs across nodes

    A = _open_matrix(n)
    counted = []

    class Counting:  # forwards setValuesRCV to A, counting the calls
        def setValuesRCV(self, rows, cols, vals, addv):
            counted.append(rows.shape[0])
            A.setValuesRCV(rows, cols, vals, addv=addv)

    assembly.add_row_blocks(Counting(), u_off, U, r_off, R, k_off, K, chunk=chunk)
    assert len(counted) == calls and sum(counted) == 5
    B = _open_matrix(n)
    ref = np.zeros((n, n))
    for Ri, Ui, Ki in zip(R_list, U_list, blocks, strict=True):
        if Ri.size and Ui.size:
            B.setValues(
                Ri.astype(PETSc.IntType), Ui.astype(PETSc.IntType), Ki,
                addv=PETSc.InsertMode.ADD_VALUES,
            )  # fmt: skip
        _add_dense(ref, Ri, Ui, Ki)
    dense = _dense(A, n)
    assert np.allclose(dense, _dense(B, n), rtol=0, atol=1e-13)
    assert np.allclose(dense, ref, rtol=0, atol=1e-13)
    assert np.count_nonzero(ref) > 20  # the blocks reach the matrix


def test_keyed_blocks_sum_equal_keys_first():
    """assembly.add_keyed_blocks: entries with equal keys (the same rows and columns) are
    summed before one setValuesRCV, sums that are all zero are left out (no slot is
    touched), cols = rows takes the rows, −1 dofs are skipped; padded_rows pads ragged
    CSR rows with −1 (integers) and 0 (reals)."""
    n = 8
    rows = np.array([[0, 1], [0, 1], [2, 3], [4, -1], [6, 7]])
    vals = np.arange(20.0).reshape(5, 2, 2)
    vals[4] = 0.0  # an all-zero sum: not inserted
    key = np.array([7, 7, 3, 5, 9])  # entries 0 and 1 share their block
    A = _open_matrix(n)
    calls = []

    class Counting:  # forwards setValuesRCV to A, counting the blocks of each call
        def setValuesRCV(self, r, c, v, addv):
            calls.append(r.shape[0])
            A.setValuesRCV(r, c, v, addv=addv)

    assembly.add_keyed_blocks(Counting(), key, rows, rows, vals)
    assert calls == [3]  # 5 entries, one pair summed, one zero sum left out
    ref = np.zeros((n, n))
    for r, v in zip(rows, vals, strict=True):
        _add_dense(ref, r, r, v)
    assert np.array_equal(_dense(A, n), ref)
    A.assemble()
    assert A.getValues([6], [6])[0, 0] == 0.0 and A.getInfo()["nz_used"] == 4 + 4 + 1
    assembly.add_keyed_blocks(Counting(), key[:0], rows[:0], rows[:0], vals[:0])
    assert calls == [3]  # nothing to insert: no call

    off = np.array([0, 2, 2, 5])
    idx, val = assembly.padded_rows(off, np.array([0, 1, 2]), np.arange(5), np.arange(5.0) + 1)
    assert idx.tolist() == [[0, 1, -1], [-1, -1, -1], [2, 3, 4]]
    assert val.tolist() == [[1.0, 2.0, 0.0], [0.0, 0.0, 0.0], [3.0, 4.0, 5.0]]
    assert idx.dtype == PETSc.IntType
