""":func:`dolfinx_mortar.kernels.friction.slip_motion_blocks` (the motion of segment points
in the slip integrals) against its NumPy reference
(:func:`dolfinx_mortar.kernels.reference.slip_motion_blocks`, written from the kernel's
docstring sums), on random rows: 2D and 3D, P1 and P2 slave/master node counts, unused
rows, slots of nodes that take no part (−1), zero weights, zero tractions, several rows
per group, rows of the force weights only (g_only: paired now, not at t_n, the traction
at ζ; session 56), with and without the recoveries' nodal values."""

import numpy as np
import pytest

from dolfinx_mortar.kernels import reference as kref
from dolfinx_mortar.kernels.friction import slip_motion_blocks

#: (d, ns, nm, nphi): intervals P1 and P2, triangles P1 and P2 (mixed P1), quads P1 and P2
SHAPES = [(2, 2, 2, 2), (2, 3, 3, 3), (3, 3, 3, 3), (3, 6, 6, 3), (3, 4, 4, 4), (3, 9, 4, 9)]


def close(a, b, rtol=1e-12):
    scale = max(np.abs(b).max(initial=0.0), 1e-300)
    err = np.abs(a - b).max(initial=0.0) / scale
    assert err <= rtol, err


@pytest.mark.parametrize("nv", [0, 2])
@pytest.mark.parametrize("dims", SHAPES, ids=[str(s) for s in SHAPES])
def test_slip_motion_blocks_matches_reference(dims, nv):
    d, ns, nm, nphi = dims
    rng = np.random.default_rng(sum(dims) + 7 * nv)
    k = m = d - 1
    n, n_nodes, G1, G2 = 9, nphi + 2, 3, 4
    nloc = (ns + nm) * d
    g1 = rng.integers(0, G1, n).astype(np.int64)
    g2 = rng.integers(0, G2, n).astype(np.int64)
    slot_node = np.stack([rng.permutation(n_nodes)[:nphi] for _ in range(n)]).astype(np.int64)
    slot_node[rng.random(slot_node.shape) < 0.25] = -1
    used = rng.random(n) < 0.8
    used[0] = False
    # the force weights' own rows (paired now, not at t_n: tw only)
    g_only = ~used & (rng.random(n) < 0.7)
    g_only[0] = True
    t_vec = rng.standard_normal((n_nodes, d))
    t_vec[rng.integers(n_nodes)] = 0.0  # an open node
    slot_node[0, 0] = np.argmax(np.abs(t_vec).sum(axis=1))  # g_only row 0 reaches tw
    w = rng.uniform(0.1, 1.0, n)
    w[1] = 0.0
    dxi, dw = rng.standard_normal((n, k, nloc)), rng.standard_normal((n, nloc))
    dg, dgxi = rng.standard_normal((n, d)), rng.standard_normal((n, k, d))
    dgn, dgxin = rng.standard_normal((n, d)), rng.standard_normal((n, k, d))
    Ns, dNs = rng.standard_normal((n, ns)), rng.standard_normal((n, ns, k))
    Nm, dNm = rng.standard_normal((n, nm)), rng.standard_normal((n, nm, k))
    psi, dpsi = rng.standard_normal((n, nphi)), rng.standard_normal((n, nphi, k))
    vh, dvh = rng.standard_normal((nv, n, nphi, m)), rng.standard_normal((nv, n, nphi, k, m))
    inputs = (g1, g2, slot_node, used, g_only, t_vec, w, dxi, dw, dg, dgxi, dgn, dgxin)
    inputs += (Ns, dNs, Nm, dNm, psi, dpsi, vh, dvh)
    # the kernel adds to its outputs
    start = (
        rng.standard_normal((G1, nphi, d, nloc)),
        rng.standard_normal((G1, nphi, d, nloc)),
        rng.standard_normal((G1, nphi, nloc)),
        rng.standard_normal((G2, (ns + nm) * d, nloc)),
        rng.standard_normal((nv, G1, nphi, m, nloc)),
    )
    out = tuple(a.copy() for a in start)
    slip_motion_blocks(*inputs, *out)
    ref = kref.slip_motion_blocks(*inputs, G1, G2)
    for name, a, a0, r in zip(("dS", "dSn", "dAT", "tw", "dMv"), out, start, ref, strict=True):
        assert a.shape == r.shape, name
        close(a - a0, r)
    assert np.abs(ref[0]).max() > 0.0 and np.abs(ref[1]).max() > 0.0
    assert np.abs(ref[3]).max() > 0.0
    # the g_only rows reach tw alone: without them tw changes, dS … dMv do not
    ref0 = kref.slip_motion_blocks(*inputs[:4], np.zeros(n, bool), *inputs[5:], G1, G2)
    for j, name in ((0, "dS"), (1, "dSn"), (2, "dAT"), (4, "dMv")):
        np.testing.assert_array_equal(ref[j], ref0[j], err_msg=name)
    assert np.abs(ref[3] - ref0[3]).max() > 0.0
    # a group no used row reaches stays as it was
    for g, G, a, a0, rows in (
        (g1, G1, out[2], start[2], used),
        (g2, G2, out[3], start[3], used | g_only),
    ):
        idle = np.setdiff1d(np.arange(G), g[rows])
        np.testing.assert_array_equal(a[idle], a0[idle])
