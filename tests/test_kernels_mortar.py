"""The point kernels of :mod:`dolfinx_mortar.kernels.mortar` that build the contact residual
and tangent (``contact_terms``, ``jacobian_terms``, ``compress_rows``, ``point_xi_terms``)
against their NumPy references in :mod:`dolfinx_mortar.kernels.reference` (written from
the kernels' docstring equations, with the AD gap derivatives), on random but valid
configurations: 2D and 3D, P1 and P2 facets, unpaired points (−1), zero weights, nodes not
owned (−1), nodes with p = 0 or kcoef = 0, constrained (−1) and repeated dofs. The
ξ-derivatives of ``point_xi_terms`` are also checked against central differences."""

import numpy as np
import pytest

from dolfinx_mortar.kernels import (
    INTERVAL1,
    INTERVAL2,
    QUAD1,
    QUAD2,
    REFERENCE_NODES,
    TRIANGLE1,
    TRIANGLE2,
    tdim,
)
from dolfinx_mortar.kernels import mortar as kmortar
from dolfinx_mortar.kernels import reference as kref

#: (slave, master, mixed) facet types: the mixed field as MortarContact picks it (P1 on P2
#: triangles), and one slave/master mix
CASES = [
    (INTERVAL1, INTERVAL1, INTERVAL1),
    (INTERVAL2, INTERVAL2, INTERVAL2),
    (TRIANGLE1, TRIANGLE1, TRIANGLE1),
    (TRIANGLE2, TRIANGLE2, TRIANGLE1),
    (QUAD1, QUAD1, QUAD1),
    (QUAD2, QUAD2, QUAD2),
    (TRIANGLE1, QUAD2, TRIANGLE1),
]
IDS = ["I1", "I2", "T1", "T2-T1", "Q1", "Q2", "T1|Q2"]
RTOL = 1e-12
#: second derivatives of the gap: on the strongly curved random P2 triangles one point
#: (projection Hessian condition number 29) puts the kernel's Hessian (envelope formulas)
#: 3e-12 and the AD reference's 1e-12 from a 50-digit evaluation (mpmath, second
#: differences): the float64 conditioning of the point, not a disagreement
RTOL_HESS = 1e-11


def close(a, b, rtol=RTOL):
    """Agreement to rtol relative to the largest entry."""
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape
    scale = max(np.abs(b).max(initial=0.0), 1e-300)
    err = np.abs(a - b).max(initial=0.0) / scale
    assert err <= rtol, err


def rotation(rng, d):
    q, r = np.linalg.qr(rng.standard_normal((d, d)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


def reference_points(ftype, rng, n):
    """n random points in the reference facet."""
    xi = rng.uniform(0.0, 1.0, (n, tdim(ftype)))
    if ftype in (TRIANGLE1, TRIANGLE2):
        out = xi.sum(axis=1) > 1.0
        xi[out] = 1.0 - xi[out][:, ::-1]
    return xi


def project_points(ftype_s, ftype_m, xs, qp_xi, qp_m, xm, msign, start=None):
    """Closest-point projections (the SciPy reference, from ``start`` or the reference
    centre) and gaps of the paired points: (qp_zeta, qp_g), NaN and 0 elsewhere."""
    nsf, nq = qp_m.shape
    km = tdim(ftype_m)
    qp_zeta = np.full((nsf, nq, km), np.nan)
    qp_g = np.zeros((nsf, nq))
    for f, q in zip(*np.nonzero(qp_m >= 0), strict=True):
        m = qp_m[f, q]
        x1 = kref.shape(ftype_s, qp_xi[f, q])[0] @ xs[f]
        z0 = np.full(km, 1.0 / 3.0) if start is None else start[f, q]
        qp_zeta[f, q] = kref.project(x1, xm[m], ftype_m, zeta0=z0)
        qp_g[f, q] = kref.gap(x1, xm[m], ftype_m, msign[m], qp_zeta[f, q])
    return qp_zeta, qp_g


def scene(ftype_s, ftype_m, ftype_phi, seed, nsf=3, nmf=3, nq=5):
    """Random slave and master facets near the plane x_d = 0 (master below, its outward
    normal ≈ +e_d), rotated and shifted; random points paired with random master facets
    (about 1 in 4 unpaired, one paired point of weight 0 per facet), projected by the
    reference. Returns the leading arguments of the point kernels and
    (p, kcoef)."""
    rng = np.random.default_rng(seed)
    k = tdim(ftype_s)
    d = k + 1
    Q, shift = rotation(rng, d), rng.uniform(-2.0, 2.0, d)

    def facets(ftype, n, height, amp):
        X = REFERENCE_NODES[ftype]
        x = np.concatenate([X, np.zeros((len(X), 1))], axis=1)
        x = np.broadcast_to(x, (n, *x.shape)) + amp * rng.standard_normal((n, *x.shape))
        x[..., -1] += np.asarray(height)[:, None]
        return np.ascontiguousarray(x @ Q.T + shift)

    xs = facets(ftype_s, nsf, 0.08 * (np.arange(nsf) % 2) - 0.03, 0.03)  # open, penetrating
    xm = facets(ftype_m, nmf, np.zeros(nmf), 0.06)
    msign = np.full(nmf, -1.0 if d == 2 else 1.0)
    qp_xi = np.stack([reference_points(ftype_s, rng, nq) for _ in range(nsf)])
    qp_w = rng.uniform(0.1, 1.0, (nsf, nq))
    qp_m = rng.integers(0, nmf, (nsf, nq)).astype(np.int64)
    qp_m[rng.random((nsf, nq)) < 0.25] = -1
    qp_m[:, 0] = -1  # unpaired
    qp_m[:, 1] = rng.integers(0, nmf, nsf)
    qp_w[:, 1] = 0.0  # paired, weight 0
    qp_zeta, qp_g = project_points(ftype_s, ftype_m, xs, qp_xi, qp_m, xm, msign)
    paired = qp_m >= 0
    assert np.all(np.abs(qp_zeta[paired] - 0.5) < 1.0)  # projections near the facets
    assert (qp_g[paired] > 0).any() and (qp_g[paired] < 0).any()
    ns, nm = xs.shape[1], xm.shape[1]
    nphi = REFERENCE_NODES[ftype_phi].shape[0]
    n_nodes = nphi + 3
    node_of = np.stack([rng.permutation(n_nodes)[:nphi] for _ in range(nsf)]).astype(np.int64)
    node_of[rng.random(node_of.shape) < 0.2] = -1  # not owned
    ndof = 12 * d  # few dofs: repeats within and across the rows
    sdofs = rng.integers(-1, ndof, (nsf, ns * d)).astype(np.int64)
    mdofs = rng.integers(-1, ndof, (nmf, nm * d)).astype(np.int64)
    sdofs[:, 0] = -1  # constrained
    p = rng.uniform(0.5, 2.0, n_nodes)
    p[rng.permutation(n_nodes)[:2]] = 0.0
    kcoef = rng.uniform(0.5, 2.0, n_nodes)
    kcoef[rng.permutation(n_nodes)[:2]] = 0.0
    args = (ftype_s, ftype_m, ftype_phi, xs, xm, msign, qp_xi, qp_w, qp_m, qp_zeta)
    return args + (sdofs, mdofs, node_of), p, kcoef


def run_contact_terms(args, p):
    xs, xm, qp_m = args[3], args[4], args[8]
    nloc = (xs.shape[1] + xm.shape[1]) * xs.shape[2]
    n = int(np.count_nonzero(qp_m >= 0))
    res_idx = np.full((n, nloc), -7, np.int64)
    res_val = np.zeros((n, nloc))
    force = np.zeros(xs.shape[2])
    kmortar.contact_terms(*args, p, res_idx, res_val, force)
    return res_idx, res_val, force


@pytest.mark.parametrize("ftypes", CASES, ids=IDS)
def test_contact_terms_matches_reference(ftypes):
    """The residual's entries and the force; the Hessian blocks of the same scenes are
    checked through jacobian_terms (test_jacobian_terms_on_contact_terms_scenes)."""
    args, p, kcoef = scene(*ftypes, seed=sum(ftypes) + 10 * ftypes[0])
    res_idx, res_val, force = run_contact_terms(args, p)
    r_idx, r_val, _, r_force = kref.contact_terms(*args, p)
    np.testing.assert_array_equal(res_idx, r_idx)
    close(res_val, r_val)
    close(force, r_force)
    # the cases exercise every branch: rows with p_w = 0 (res_idx −1) and constrained dofs
    live = (res_idx >= 0).any(axis=1)
    assert live.sum() >= 3 and (~live).sum() >= 3
    assert (res_idx[live] < 0).any()


def check_jacobian_terms(args, p, kcoef, want_hess):
    """jacobian_terms against its reference (the per-point references summed per pair and
    compressed); returns the kernel's (h_idx, h_val, c_off, c_idx, c_val)."""
    out = kmortar.jacobian_terms(*args, p, kcoef, want_hess)
    h_idx, h_val, c_off, c_idx, c_val = out
    r_idx, r_val, rc_off, rc_idx, rc_val = kref.jacobian_terms(*args, p, kcoef, want_hess)
    np.testing.assert_array_equal(h_idx, r_idx)
    close(h_val, r_val, RTOL_HESS)
    np.testing.assert_array_equal(c_off, rc_off)
    np.testing.assert_array_equal(c_idx[: c_off[-1]], rc_idx)
    close(c_val[: c_off[-1]], rc_val)
    return out


@pytest.mark.parametrize("ftypes", CASES, ids=IDS)
def test_jacobian_terms_on_contact_terms_scenes(ftypes):
    """The Hessian blocks and rows B^I of jacobian_terms on the scenes of
    test_contact_terms_matches_reference (where contact_terms' own Hessian blocks, before
    session 63, were checked against the reference), and with one point per (slave facet,
    master facet) pair: every block is then one point's, checked without a sum."""
    args, p, kcoef = scene(*ftypes, seed=sum(ftypes) + 10 * ftypes[0])
    check_jacobian_terms(args, p, kcoef, True)
    qp_m = args[8].copy()
    for f in range(qp_m.shape[0]):  # unpair the repeats of a master facet within a facet
        seen = set()
        for q in range(qp_m.shape[1]):
            if qp_m[f, q] in seen:
                qp_m[f, q] = -1
            elif qp_m[f, q] >= 0:
                seen.add(qp_m[f, q])
    one = args[:8] + (qp_m,) + args[9:]
    h_idx = check_jacobian_terms(one, p, kcoef, True)[0]
    live = (kref.contact_terms(*one, p)[0] >= 0).any(axis=1)
    assert h_idx.shape[0] == live.sum() > 0  # one block per live point


@pytest.mark.parametrize("ftypes", CASES, ids=IDS)
def test_rows_and_compress_rows_match_reference(ftypes):
    """B^I rows with the kcoef mask: compress_rows of the reference's uncompressed rows is
    the reference's compression and the dense sum of the entries per dof ≥ 0, and
    jacobian_terms' rows are those (the scenes of node_rows' test before session 63)."""
    args, p, kcoef = scene(*ftypes, seed=100 + sum(ftypes))
    b_off, b_idx, b_val = kref.node_rows(*args, kcoef)
    c_off, c_idx, c_val = _compressed(b_off, b_idx, b_val)
    n_nodes = kcoef.size
    ndof = 1 + max(b_idx.max(initial=0), 0)
    dense = np.zeros((n_nodes, ndof))
    row = np.repeat(np.arange(n_nodes), np.diff(b_off))
    keep = b_idx >= 0
    np.add.at(dense, (row[keep], b_idx[keep]), b_val[keep])
    back = np.zeros_like(dense)
    back[np.repeat(np.arange(n_nodes), np.diff(c_off)), c_idx[: c_off[-1]]] = c_val[: c_off[-1]]
    close(back, dense)
    assert (b_idx < 0).any() and c_off[-1] < b_off[-1]
    assert (np.diff(b_off) > 0).any() and (np.diff(b_off) == 0).any()
    # only the masked nodes' rows; and with the Hessian blocks or without, the same rows
    for want_hess in (False, True):
        k_off, k_idx, k_val = check_jacobian_terms(args, p, kcoef, want_hess)[2:]
        np.testing.assert_array_equal(k_off, c_off)
        np.testing.assert_array_equal(k_idx[: k_off[-1]], c_idx[: c_off[-1]])
        close(k_val[: k_off[-1]], c_val[: c_off[-1]])


@pytest.mark.parametrize("want_hess", [True, False])
@pytest.mark.parametrize("ftypes", CASES, ids=IDS)
def test_jacobian_terms_matches_reference(ftypes, want_hess):
    """The one-pass tangent terms: the Hessian blocks summed per (slave facet, master
    facet) pair and the compressed rows B^I, against the reference (the per-point
    references summed); the scenes hold pairs of several points, of which some have
    p_w = 0, and facets paired with several master facets."""
    args, p, kcoef = scene(*ftypes, seed=200 + sum(ftypes), nq=7)
    h_idx, h_val, c_off, c_idx, c_val = check_jacobian_terms(args, p, kcoef, want_hess)
    # the blocks are the reference's per-point blocks summed per pair, grouped here
    # independently of kref.jacobian_terms (first-row order by dict)
    res_idx, _, hess_val, _ = kref.contact_terms(*args, p, True)
    live = (res_idx >= 0).any(axis=1)
    assert c_off[-1] > 0
    if want_hess:
        assert 0 < h_idx.shape[0] < live.sum()  # some pairs of several points
        qp_m = args[8]
        fr, qr = np.nonzero(qp_m >= 0)
        key = fr * args[4].shape[0] + qp_m[fr, qr]
        hkey = list(dict.fromkeys(key[hess_val.any(axis=(1, 2))]))  # first-row order
        assert len(hkey) == h_idx.shape[0]
        for b, k in enumerate(hkey):
            close(h_val[b], hess_val[key == k].sum(axis=0), RTOL_HESS)
    else:
        assert h_idx.shape == (0, res_idx.shape[1]) and h_val.shape[0] == 0


#: (slave, master, mixed) facet types over an AFFINE master facet, where jacobian_terms
#: builds a group's Hessian block from its point moments (kernels.mortar._add_group_hessian):
#: P1 and P2 slaves, P2 mixed fields (shape functions of both signs)
AFFINE_CASES = [
    (INTERVAL1, INTERVAL1, INTERVAL1),
    (INTERVAL2, INTERVAL1, INTERVAL2),
    (TRIANGLE1, TRIANGLE1, TRIANGLE1),
    (TRIANGLE2, TRIANGLE1, TRIANGLE1),
]
AFFINE_IDS = ["I1", "I2-I1", "T1", "T2-T1"]


def _point_weights(args, p):
    """c_q = −p_w per point (nsf, nq), p_w = w J₀ Σ_I p^I Φ_I(ξ_q) over the owned nodes."""
    ftype_phi, qp_xi, qp_w, node_of = args[2], args[6], args[7], args[12]
    c = np.zeros(qp_w.shape)
    for f, q in np.ndindex(*qp_w.shape):
        phi = kref.shape(ftype_phi, qp_xi[f, q])[0]
        own = node_of[f] >= 0
        c[f, q] = -qp_w[f, q] * (p[node_of[f][own]] @ phi[own])
    return c


def _group_blocks(args, p):
    """The reference's per-point Hessian blocks summed per (slave facet, master facet)
    group, keyed (f, m) in first-point order, and each group's point weights c_q."""
    res_idx, _, hess_val, _ = kref.contact_terms(*args, p, True)
    qp_m = args[8]
    c = _point_weights(args, p)
    blocks, weights = {}, {}
    for row, (f, q) in enumerate(zip(*np.nonzero(qp_m >= 0), strict=True)):
        if c[f, q] == 0.0:
            continue
        key = (f, qp_m[f, q])
        blocks[key] = blocks.get(key, 0.0) + hess_val[row]
        weights.setdefault(key, []).append(c[f, q])
    return blocks, weights


def _check_blocks_per_group(args, p, rtol=1e-12):
    """jacobian_terms' blocks against the reference's per-point blocks summed per group,
    each to rtol of the block's own largest entry; returns the groups' weights c_q."""
    h_val = kmortar.jacobian_terms(*args, p, np.ones_like(p), True)[1]
    blocks, weights = _group_blocks(args, p)
    assert len(blocks) == h_val.shape[0]
    for b, key in enumerate(blocks):
        close(h_val[b], blocks[key], rtol)
    return list(weights.values())


@pytest.mark.parametrize("ftypes", AFFINE_CASES, ids=AFFINE_IDS)
def test_jacobian_terms_moments_on_affine_masters(ftypes):
    """On affine master facets the blocks come from the groups' point moments: they are
    the per-point blocks of the reference summed per group to 1e-12 of each block's
    scale, with pressures of both signs (groups whose c_q = −p_w are of one sign: one
    gap Hessian at their weighted mean; of mixed signs: two), with a group whose c_q sum
    to zero (round-off), and with ζ that is not the projection of the point (the
    moments give the per-point formulas' sum for any ζ)."""
    ftype_s, ftype_m, ftype_phi = ftypes
    args, p, _ = scene(*ftypes, seed=300 + sum(ftypes), nq=9)
    rng = np.random.default_rng(7)
    p = rng.uniform(-1.0, 2.0, p.size)
    weights = _check_blocks_per_group(args, p)
    mixed = [w for w in weights if min(w) < 0.0 < max(w)]
    assert mixed and [w for w in weights if len(w) > 1 and (min(w) > 0.0 or max(w) < 0.0)]
    # a group whose weights cancel: p^I of one of its facet's nodes solves Σ_q c_q = 0
    # (c_q is affine in p^I), where the others' p keep some c_q ≠ 0
    qp_m, node_of = args[8], args[12]
    c0 = _point_weights(args, p)
    for (f, m), w in _group_blocks(args, p)[1].items():
        sel = qp_m[f] == m
        for node in node_of[f][node_of[f] >= 0]:
            p1 = p.copy()
            p1[node] += 1.0
            slope = _point_weights(args, p1)[f, sel].sum() - c0[f, sel].sum()
            if len(w) > 1 and abs(slope) > 1e-3:
                p2 = p.copy()
                p2[node] -= c0[f, sel].sum() / slope
                w2 = _point_weights(args, p2)[f, sel]
                if np.abs(w2).max() > 1e-3:
                    break
        else:
            continue
        break
    else:
        raise AssertionError("no group to cancel")
    assert abs(w2.sum()) < 1e-12 * np.abs(w2).sum()
    _check_blocks_per_group(args, p2)
    # ζ off the projection (shifted by up to 0.2): the kernel's per-point formulas at that
    # ζ (gap.gap_and_derivatives, whose x1 − S = gν holds at the projection only: not
    # the reference's there) summed, the kernel one point per call
    zeta = args[9] + rng.uniform(-0.2, 0.2, args[9].shape)
    off = args[:9] + (zeta,) + args[10:]
    h_val = kmortar.jacobian_terms(*off, p, np.ones_like(p), True)[1]
    sums = _per_point_sums(off, p)
    assert len(sums) == h_val.shape[0]
    for b, key in enumerate(sums):
        close(h_val[b], sums[key], 1e-12)


def _dense_rows(c_off, c_idx, c_val, ndof):
    """Compressed rows (:func:`compress_rows`) as a dense (n_nodes, ndof) array."""
    n = c_off.size - 1
    dense = np.zeros((n, ndof))
    rows = np.repeat(np.arange(n), np.diff(c_off))
    np.add.at(dense, (rows, c_idx[: c_off[-1]]), c_val[: c_off[-1]])
    return dense


@pytest.mark.parametrize("ftypes", AFFINE_CASES, ids=AFFINE_IDS)
def test_rows_from_moments_on_affine_masters(ftypes):
    """On affine master facets the rows B^I come from the groups' point moments
    (kernels.mortar._add_group_rows): against B^I = Σ_q w Φ_I(ξ_q) [N_a(ξ_q) ν,
    −N^m_a(ζ_q) ν] written out here with the reference's shape functions and normal, to
    1e-12 of the rows' scale, at the projections and with ζ moved off them by up to 0.2
    (the formula holds for any ζ on an affine facet); the P2 mixed fields' Φ_I take both
    signs."""
    ftype_s, ftype_m, ftype_phi = ftypes
    args, p, _ = scene(*ftypes, seed=500 + sum(ftypes), nq=9)
    xs, xm, msign, qp_xi, qp_w, qp_m = args[3:9]
    sdofs, mdofs, node_of = args[10:13]
    d = xs.shape[2]
    ndof = int(max(sdofs.max(), mdofs.max())) + 1
    rng = np.random.default_rng(11)
    for zeta in (args[9], args[9] + rng.uniform(-0.2, 0.2, args[9].shape)):
        run = args[:9] + (zeta,) + args[10:]
        c_off, c_idx, c_val = kmortar.jacobian_terms(*run, p, np.ones_like(p), False)[2:]
        expected = np.zeros((p.size, ndof))
        for f, q in zip(*np.nonzero(qp_m >= 0), strict=True):
            m = qp_m[f, q]
            N = kref.shape(ftype_s, qp_xi[f, q])[0]
            Nm = kref.shape(ftype_m, zeta[f, q])[0]
            nu = np.asarray(kref.normal(xm[m], ftype_m, msign[m], zeta[f, q]), float)
            dg = np.concatenate([np.outer(N, nu).ravel(), -np.outer(Nm, nu).ravel()])
            dofs = np.concatenate([sdofs[f], mdofs[m]])
            phi = kref.shape(ftype_phi, qp_xi[f, q])[0]
            for i, node in enumerate(node_of[f]):
                if node >= 0:
                    np.add.at(expected[node], dofs[dofs >= 0], qp_w[f, q] * phi[i] * dg[dofs >= 0])
        got = _dense_rows(c_off, c_idx, c_val, ndof)
        assert np.abs(expected).max() > 0.1 and d == xm.shape[2]
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def _per_point_sums(args, p):
    """The kernel's blocks built one point at a time (one call per point with the others
    unpaired) and summed per group in point order, as the per-point path sums them."""
    qp_m = args[8]
    sums = {}
    for f, q in zip(*np.nonzero(qp_m >= 0), strict=True):
        one = np.full_like(qp_m, -1)
        one[f, q] = qp_m[f, q]
        h_val = kmortar.jacobian_terms(*args[:8], one, *args[9:], p, np.ones_like(p), True)[1]
        if h_val.shape[0]:
            key = (f, qp_m[f, q])
            sums[key] = sums[key] + h_val[0] if key in sums else 0.0 + h_val[0]
    return sums


def test_jacobian_terms_moment_path_and_its_fallback():
    """_moment_path: affine (INTERVAL1, TRIANGLE1) and non-degenerate master facets only.
    On a degenerate triangle (det m ≤ 1e-12 tr², the test of gap._project_affine) the
    kernel falls back to one gap Hessian per point: its blocks are then the single-point
    blocks summed in point order, bit for bit; on a sound one they are the moments' (not
    bit for bit, equal to round-off)."""
    z = np.empty(2)
    tri = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.1], [0.0, 1.0, -0.2]])
    thin = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 1e-7, 0.0]])
    assert kmortar._moment_path(TRIANGLE1, tri, z)
    assert not kmortar._moment_path(TRIANGLE1, thin, z)
    assert kmortar._moment_path(INTERVAL1, tri[:2, :2].copy(), z[:1])
    assert not kmortar._moment_path(INTERVAL1, np.zeros((2, 2)), z[:1])
    assert not kmortar._moment_path(QUAD1, np.zeros((4, 3)), z)
    assert not kmortar._moment_path(TRIANGLE2, np.zeros((6, 3)), z)
    args, p, _ = scene(TRIANGLE1, TRIANGLE1, TRIANGLE1, seed=17, nq=9)
    rng = np.random.default_rng(5)
    xm = args[4].copy()
    xm[0] = xm[0, 0] + np.outer([0.0, 1.0, 2.0], xm[0, 1] - xm[0, 0])
    xm[0, 2] += 1e-7 * rng.standard_normal(3)
    assert not kmortar._moment_path(TRIANGLE1, xm[0], z)
    args = args[:4] + (xm,) + args[5:]
    h_val = kmortar.jacobian_terms(*args, p, np.ones_like(p), True)[1]
    sums = _per_point_sums(args, p)
    assert len(sums) == h_val.shape[0]
    many = {f: 0 for f in range(3)}
    for b, (f, m) in enumerate(sums):
        npts = int(np.count_nonzero(args[8][f] == m))
        if m == 0:
            np.testing.assert_array_equal(h_val[b], sums[(f, m)])
            many[m] += npts > 1
        else:
            close(h_val[b], sums[(f, m)], 1e-12)
            many[m] += not np.array_equal(h_val[b], sums[(f, m)])
    assert many[0] and (many[1] or many[2])


def _compressed(b_off, b_idx, b_val):
    """compress_rows of the rows (b_off, b_idx, b_val), checked against its reference;
    returns the kernel's (c_off, c_idx, c_val)."""
    c_off, c_idx, c_val = np.zeros_like(b_off), np.empty_like(b_idx), np.empty_like(b_val)
    kmortar.compress_rows(b_off, b_idx, b_val, c_off, c_idx, c_val)
    rc_off, rc_idx, rc_val = kref.compress_rows(b_off, b_idx, b_val)
    np.testing.assert_array_equal(c_off, rc_off)
    np.testing.assert_array_equal(c_idx[: c_off[-1]], rc_idx)
    close(c_val[: c_off[-1]], rc_val)
    return c_off, c_idx, c_val


def test_compress_rows_matches_reference():
    """Random rows with repeated dofs, dofs < 0 (−1 and others), empty rows and a row of
    negative dofs only."""
    rng = np.random.default_rng(3)
    counts = np.array([0, 7, 1, 30, 0, 4, 12, 3])
    b_off = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    b_idx = rng.integers(-3, 9, b_off[-1]).astype(np.int64)
    b_idx[b_off[7] : b_off[8]] = [-1, -2, -1]
    b_val = rng.standard_normal(b_off[-1])
    c_off, c_idx, c_val = _compressed(b_off, b_idx, b_val)
    assert c_off[8] == c_off[7] and c_off[1] == c_off[0] == 0


def run_point_xi_terms(args):
    xs, xm, qp_xi, qp_m, node_of = args[3], args[4], args[6], args[8], args[12]
    n = int(np.count_nonzero(qp_m >= 0))
    k, nloc, nphi = qp_xi.shape[2], (xs.shape[1] + xm.shape[1]) * xs.shape[2], node_of.shape[1]
    b, db = np.zeros((n, nloc)), np.zeros((n, k, nloc))
    g, gxi = np.zeros(n), np.zeros((n, k))
    phi, dphi = np.zeros((n, nphi)), np.zeros((n, nphi, k))
    kmortar.point_xi_terms(*args, b, db, g, gxi, phi, dphi)
    return b, db, g, gxi, phi, dphi


@pytest.mark.parametrize("ftypes", CASES, ids=IDS)
def test_point_xi_terms_matches_reference_and_fd(ftypes):
    """Against the reference, and db, gxi, dphi against central differences in ξ of b, g
    and phi (the closest point re-projected at every shifted ξ)."""
    args, _, _ = scene(*ftypes, seed=200 + sum(ftypes))
    out = run_point_xi_terms(args)
    for a, r in zip(out, kref.point_xi_terms(*args), strict=True):
        close(a, r)
    b, db, g, gxi, phi, dphi = out
    ftype_s, ftype_m, xs, xm, msign, qp_xi, qp_m = (args[i] for i in (0, 1, 3, 4, 5, 6, 8))
    h = 1e-6
    fd = []
    for be in range(qp_xi.shape[2]):
        shifted = []
        for s in (h, -h):
            xi = qp_xi.copy()
            xi[..., be] += s
            zeta = project_points(ftype_s, ftype_m, xs, xi, qp_m, xm, msign, args[9])[0]
            shifted.append(run_point_xi_terms(args[:6] + (xi,) + args[7:9] + (zeta,) + args[10:]))
        fd.append([(p - m) / (2 * h) for p, m in zip(*shifted, strict=True)])
    close(db, np.stack([f[0] for f in fd], axis=1), 1e-7)
    close(gxi, np.stack([f[2] for f in fd], axis=1), 1e-7)
    close(dphi, np.stack([f[4] for f in fd], axis=2), 1e-7)
