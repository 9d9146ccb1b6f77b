"""Tests of the per-point contact kernels: shape functions (against basix), closest-point
projection (against a SciPy reference), gap sign, and exact gap derivatives (against
central finite differences with re-projection and against an independent AD reference)."""

import basix
import numpy as np
import pytest

from dolfinx_mortar.kernels import (
    FACET_TYPES,
    INTERVAL1,
    INTERVAL2,
    QUAD1,
    QUAD2,
    REFERENCE_NODES,
    TRIANGLE1,
    TRIANGLE2,
    clamp_to_reference,
    gap_and_derivatives,
    gap_only,
    inside,
    num_nodes,
    project,
    projection_derivative,
    shape,
    tdim,
    unit_normal,
)
from dolfinx_mortar.kernels import reference as ref

TOL = 1e-13
MAXIT = 50

_BASIX = {
    INTERVAL1: (basix.CellType.interval, 1),
    INTERVAL2: (basix.CellType.interval, 2),
    TRIANGLE1: (basix.CellType.triangle, 1),
    TRIANGLE2: (basix.CellType.triangle, 2),
    QUAD1: (basix.CellType.quadrilateral, 1),
    QUAD2: (basix.CellType.quadrilateral, 2),
}


def basix_element(ftype):
    cell, degree = _BASIX[ftype]
    return basix.create_element(
        basix.ElementFamily.P, cell, degree, basix.LagrangeVariant.equispaced
    )


def numba_shape(ftype, xi):
    n, k = num_nodes(ftype), tdim(ftype)
    N, dN, ddN = np.empty(n), np.empty((n, k)), np.empty((n, k, k))
    shape(ftype, np.asarray(xi, dtype=float), N, dN, ddN)
    return N, dN, ddN


def nproject(x1, xm, ftype, zeta0=None, tol=TOL, maxit=MAXIT):
    k = tdim(ftype)
    z0 = np.full(k, np.nan) if zeta0 is None else np.array(zeta0, dtype=float)
    z = np.empty(k)
    ok = project(x1, xm, ftype, z0, z, tol, maxit)
    return ok, z


def rotation(rng, d):
    q, r = np.linalg.qr(rng.standard_normal((d, d)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


def make_facet(ftype, rng, amp=0.1, rotate=True):
    """Master facet from the reference nodes embedded in the plane x_d = 0 (body below,
    outward normal +e_d before rotation), perturbed by ``amp`` noise, randomly rotated and
    translated. Returns (xm, sign)."""
    nodes = REFERENCE_NODES[ftype]
    k = nodes.shape[1]
    d = k + 1
    xm = np.column_stack([nodes, np.zeros(len(nodes))])
    xm = xm + amp * rng.standard_normal(xm.shape)
    if rotate:
        xm = xm @ rotation(rng, d).T + rng.uniform(-3, 3, d)
    sign = -1.0 if d == 2 else 1.0  # n = s (a1_y, -a1_x) resp. s a1 x a2, a1 ~ e1 (, a2 ~ e2)
    return xm, sign


def slave_point(ftype, xm, sign, h, rng, zeta=None):
    """Point at signed distance ~h along the normal of S(zeta), slightly shifted."""
    k = tdim(ftype)
    zeta = np.full(k, 0.3) + 0.05 * rng.standard_normal(k) if zeta is None else zeta
    S, _ = ref.surface(xm, ftype, zeta)
    nu = ref.normal(xm, ftype, sign, zeta)
    return S + h * nu + 0.02 * rng.standard_normal(xm.shape[1])


# --------------------------------------------------------------------------- shape


@pytest.mark.parametrize("ftype", FACET_TYPES)
def test_node_ordering_matches_basix(ftype):
    e = basix_element(ftype)
    assert num_nodes(ftype) == e.dim == len(REFERENCE_NODES[ftype])
    assert tdim(ftype) == REFERENCE_NODES[ftype].shape[1]
    np.testing.assert_allclose(REFERENCE_NODES[ftype], e.points, atol=1e-15)
    # Kronecker property at the nodes
    for b, xb in enumerate(e.points):
        N, _, _ = numba_shape(ftype, xb)
        np.testing.assert_allclose(N, np.eye(len(N))[b], atol=1e-14)


@pytest.mark.parametrize("ftype", FACET_TYPES)
def test_shape_matches_basix_tabulate(ftype):
    rng = np.random.default_rng(ftype)
    e = basix_element(ftype)
    k = tdim(ftype)
    pts = rng.uniform(-0.3, 1.3, (7, k))  # inside and outside (extrapolation)
    tab = e.tabulate(2, pts)[:, :, :, 0]  # (nderiv, npts, n)
    if k == 1:
        i1, i2 = [basix.index(1)], [[basix.index(2)]]
    else:
        i1 = [basix.index(1, 0), basix.index(0, 1)]
        i2 = [
            [basix.index(2, 0), basix.index(1, 1)],
            [basix.index(1, 1), basix.index(0, 2)],
        ]
    for p, xi in enumerate(pts):
        dN_b = np.array([tab[i1[al], p] for al in range(k)]).T
        ddN_b = np.array([[tab[i2[al][be], p] for be in range(k)] for al in range(k)])
        ddN_b = np.moveaxis(ddN_b, 2, 0)
        for N, dN, ddN in (numba_shape(ftype, xi), ref.shape(ftype, xi)):
            np.testing.assert_allclose(N, tab[0, p], atol=1e-13)
            np.testing.assert_allclose(dN, dN_b, atol=1e-12)
            np.testing.assert_allclose(ddN, ddN_b, atol=1e-11)


def test_inside_and_clamp():
    for ft in (INTERVAL1, INTERVAL2):
        assert inside(ft, np.array([0.5]), 0.0)
        assert inside(ft, np.array([1.0 + 1e-9]), 1e-8)
        assert not inside(ft, np.array([1.1]), 1e-8)
        assert not inside(ft, np.array([np.nan]), 1e-8)
        z = np.array([-0.4])
        clamp_to_reference(ft, z)
        assert z[0] == 0.0
    for ft in (TRIANGLE1, TRIANGLE2):
        assert inside(ft, np.array([0.2, 0.3]), 0.0)
        assert not inside(ft, np.array([0.6, 0.6]), 1e-8)
        assert not inside(ft, np.array([-0.1, 0.3]), 1e-8)
        for xi, expect in [
            ([0.6, 0.6], [0.5, 0.5]),
            ([-0.5, -0.2], [0.0, 0.0]),
            ([2.0, -0.5], [1.0, 0.0]),
            ([-0.3, 0.4], [0.0, 0.4]),
            ([0.9, 0.3], [0.8, 0.2]),
            ([0.2, 0.3], [0.2, 0.3]),
        ]:
            z = np.array(xi)
            clamp_to_reference(ft, z)
            np.testing.assert_allclose(z, expect, atol=1e-15)
    for ft in (QUAD1, QUAD2):
        assert inside(ft, np.array([0.9, 0.9]), 0.0)
        assert not inside(ft, np.array([0.5, 1.2]), 1e-8)
        z = np.array([1.5, -0.5])
        clamp_to_reference(ft, z)
        np.testing.assert_allclose(z, [1.0, 0.0])


# --------------------------------------------------------------------------- projection


@pytest.mark.parametrize("ftype", [INTERVAL1, TRIANGLE1, QUAD1])
def test_project_flat_facet_middle(ftype):
    xm, sign = make_facet(ftype, np.random.default_rng(1), amp=0.0, rotate=False)
    k = tdim(ftype)
    centre = np.full(k, 1 / 3 if ftype == TRIANGLE1 else 0.5)
    x1 = ref.surface(xm, ftype, centre)[0]
    x1[-1] = 0.7
    ok, z = nproject(x1, xm, ftype, zeta0=np.zeros(k))
    assert ok
    np.testing.assert_allclose(z, centre, atol=1e-14)
    np.testing.assert_allclose(z, ref.project(x1, xm, ftype), atol=1e-10)
    assert gap_only(x1, xm, ftype, sign, z) == pytest.approx(0.7, abs=1e-14)


@pytest.mark.parametrize("ftype", [INTERVAL1, INTERVAL2, TRIANGLE1, QUAD1, QUAD2])
def test_project_beyond_edge(ftype):
    rng = np.random.default_rng(2)
    xm, sign = make_facet(ftype, rng, amp=0.03)
    k = tdim(ftype)
    target = np.full(k, 0.4)
    target[0] = 1.3  # beyond the xi_1 = 1 edge (for the triangle also beyond xi1 + xi2 = 1)
    x1 = slave_point(ftype, xm, sign, 0.2, rng, zeta=target)
    ok, z = nproject(x1, xm, ftype)
    assert ok
    assert z[0] > 1.1
    assert not inside(ftype, z, 1e-6)
    np.testing.assert_allclose(z, ref.project(x1, xm, ftype), atol=1e-10)
    zc = z.copy()
    clamp_to_reference(ftype, zc)
    assert inside(ftype, zc, 0.0)


@pytest.mark.parametrize("ftype", [INTERVAL2, TRIANGLE2, QUAD2])
def test_project_curved_p2(ftype):
    """Facet nodes on a circle / sphere of radius 1.5 (convex body below)."""
    nodes = REFERENCE_NODES[ftype]
    k = nodes.shape[1]
    R = 1.5
    p = nodes - 0.5
    h = R - np.sqrt(R**2 - np.sum(p**2, axis=1))
    xm = np.column_stack([nodes, -h])
    sign = -1.0 if k == 1 else 1.0
    rng = np.random.default_rng(3)
    for h_slave in (0.5, -0.3, 2.0):
        x1 = slave_point(ftype, xm, sign, h_slave, rng, zeta=np.full(k, 0.35))
        ok, z = nproject(x1, xm, ftype)
        assert ok
        assert inside(ftype, z, 0.0)
        np.testing.assert_allclose(z, ref.project(x1, xm, ftype), atol=1e-10)
        # orthogonality of x1 - S to the tangents
        S, A = ref.surface(xm, ftype, z)
        assert np.abs(A @ (x1 - S)).max() < 1e-13
        assert np.sign(gap_only(x1, xm, ftype, sign, z)) == np.sign(h_slave)


def test_project_warped_bilinear_quad():
    xm = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.2], [0.0, 1.0, 0.3], [1.2, 1.1, -0.25]])
    rng = np.random.default_rng(4)
    for target, h in [((0.3, 0.6), 0.4), ((0.8, 0.2), -0.15), ((1.4, 0.5), 0.3)]:
        target = np.array(target)
        x1 = slave_point(QUAD1, xm, 1.0, h, rng, zeta=target)
        ok, z = nproject(x1, xm, QUAD1)
        assert ok
        np.testing.assert_allclose(z, ref.project(x1, xm, QUAD1), atol=1e-10)
        assert inside(QUAD1, z, 1e-8) == bool(target[0] <= 1.0)


@pytest.mark.parametrize("ftype", FACET_TYPES)
def test_project_far_point_terminates(ftype):
    rng = np.random.default_rng(5)
    xm, sign = make_facet(ftype, rng, amp=0.1)
    d = xm.shape[1]
    for x1 in (1e3 * rng.standard_normal(d), np.full(d, 50.0), xm.mean(axis=0) + 1e-9):
        ok, z = nproject(x1, xm, ftype, maxit=100)
        assert np.all(np.isfinite(z))
        if ok:
            S, A = ref.surface(xm, ftype, z)
            assert np.abs(A @ (x1 - S)).max() < 1e-9 * (1 + np.linalg.norm(x1 - S))
    ok, z = nproject(np.ones(d), xm, ftype, zeta0=np.full(tdim(ftype), 0.2), maxit=0)
    assert not ok
    np.testing.assert_allclose(z, 0.2)


# --------------------------------------------------------------------------- gap sign


@pytest.mark.parametrize("ftype", FACET_TYPES)
def test_gap_sign(ftype):
    rng = np.random.default_rng(6)
    xm, sign = make_facet(ftype, rng, amp=0.05, rotate=False)
    nu = np.empty(xm.shape[1])
    k = tdim(ftype)
    jac = unit_normal(xm, ftype, sign, np.full(k, 0.3), nu)
    assert jac > 0 and nu[-1] > 0.9  # outward normal of the body below the facet
    for h in (0.25, -0.1):
        x1 = slave_point(ftype, xm, sign, h, rng)
        ok, z = nproject(x1, xm, ftype)
        assert ok and inside(ftype, z, 0.0)
        g = gap_only(x1, xm, ftype, sign, z)
        assert np.sign(g) == np.sign(h)
        assert gap_only(x1, xm, ftype, -sign, z) == pytest.approx(-g, abs=1e-15)
        assert ref.gap(x1, xm, ftype, sign, z) == pytest.approx(g, abs=1e-14)


# --------------------------------------------------------------------------- derivatives


def split(y, d):
    return y[:d].copy(), y[d:].reshape(-1, d).copy()


def gap_reprojected(y, ftype, sign, d, zeta):
    x1, xm = split(y, d)
    ok, z = nproject(x1, xm, ftype, zeta0=zeta)
    assert ok
    return gap_only(x1, xm, ftype, sign, z)


def derivs_reprojected(y, ftype, sign, d, zeta):
    x1, xm = split(y, d)
    ok, z = nproject(x1, xm, ftype, zeta0=zeta)
    assert ok
    dg = np.empty(len(y))
    d2g = np.empty((len(y), len(y)))
    g = gap_and_derivatives(x1, xm, ftype, sign, z, dg, d2g)
    return g, dg, d2g, z


def relerr(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def fd_errors(ftype, xm, sign, x1):
    """Relative errors (max-norm, relative to the max entry) of dg, d2g against central FD
    with re-projection for every perturbed y: (dg vs FD of g, d2g vs FD of the analytic dg,
    d2g vs second differences of g)."""
    d = xm.shape[1]
    y0 = np.concatenate([x1, xm.ravel()])
    ny = len(y0)
    g0, dg, d2g, z0 = derivs_reprojected(y0, ftype, sign, d, None)
    assert inside(ftype, z0, 0.0)
    np.testing.assert_allclose(d2g, d2g.T, atol=1e-14 * np.abs(d2g).max())

    def gfun(y):
        return gap_reprojected(y, ftype, sign, d, z0)

    h1 = 1e-6
    I = np.eye(ny)
    dg_fd = np.array([(gfun(y0 + h1 * I[i]) - gfun(y0 - h1 * I[i])) / (2 * h1) for i in range(ny)])
    d2g_fd1 = np.array(
        [
            (
                derivs_reprojected(y0 + h1 * I[i], ftype, sign, d, z0)[1]
                - derivs_reprojected(y0 - h1 * I[i], ftype, sign, d, z0)[1]
            )
            / (2 * h1)
            for i in range(ny)
        ]
    )

    def second_differences(h):
        H = np.empty((ny, ny))
        for i in range(ny):
            H[i, i] = (gfun(y0 + h * I[i]) - 2 * g0 + gfun(y0 - h * I[i])) / h**2
            for j in range(i):
                ei, ej = h * I[i], h * I[j]
                v = gfun(y0 + ei + ej) - gfun(y0 + ei - ej) - gfun(y0 - ei + ej)
                H[i, j] = H[j, i] = (v + gfun(y0 - ei - ej)) / (4 * h**2)
        return H

    # central second differences, one Richardson step (O(h^4)): allows a step large
    # enough for the round-off of g (~1e-16 |x|) not to be amplified by 1/h^2
    h2 = 1e-3
    d2g_fd2 = (4 * second_differences(h2) - second_differences(2 * h2)) / 3
    return g0, relerr(dg, dg_fd), relerr(d2g, d2g_fd1), relerr(d2g, d2g_fd2)


CASES = {
    "outside": dict(amp=0.1, h=0.3),
    "penetrating": dict(amp=0.1, h=-0.2),
    "flat_outside": dict(amp=0.0, h=0.25),
}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("ftype", FACET_TYPES)
def test_gap_derivatives_fd(ftype, case):
    rng = np.random.default_rng(10 + ftype)
    c = CASES[case]
    xm, sign = make_facet(ftype, rng, amp=c["amp"])
    x1 = slave_point(ftype, xm, sign, c["h"], rng)
    g, e1, e2, e3 = fd_errors(ftype, xm, sign, x1)
    assert np.sign(g) == np.sign(c["h"])
    assert e1 < 1e-6, e1
    assert e2 < 1e-6, e2
    assert e3 < 1e-6, e3


@pytest.mark.parametrize("ftype", FACET_TYPES)
def test_numba_matches_reference(ftype):
    rng = np.random.default_rng(20 + ftype)
    xm, sign = make_facet(ftype, rng, amp=0.12)
    d = xm.shape[1]
    ny = d * (1 + len(xm))
    for h in (0.35, -0.15):
        x1 = slave_point(ftype, xm, sign, h, rng)
        ok, z = nproject(x1, xm, ftype)
        assert ok
        np.testing.assert_allclose(z, ref.project(x1, xm, ftype), atol=1e-10)
        dg = np.empty(ny)
        d2g = np.empty((ny, ny))
        g = gap_and_derivatives(x1, xm, ftype, sign, z, dg, d2g)
        gr, dgr, d2gr = ref.gap_derivatives(x1, xm, ftype, sign, z)
        assert g == pytest.approx(gr, abs=1e-12)
        assert gap_only(x1, xm, ftype, sign, z) == pytest.approx(g, abs=1e-14)
        assert relerr(dg, dgr) < 1e-10
        assert relerr(d2g, d2gr) < 1e-10


@pytest.mark.parametrize("ftype", [INTERVAL2, TRIANGLE1, QUAD2])
def test_projection_derivative_fd(ftype):
    rng = np.random.default_rng(30 + ftype)
    xm, sign = make_facet(ftype, rng, amp=0.1)
    x1 = slave_point(ftype, xm, sign, 0.2, rng)
    d = xm.shape[1]
    k = tdim(ftype)
    y0 = np.concatenate([x1, xm.ravel()])
    ok, z0 = nproject(x1, xm, ftype)
    assert ok
    dz = np.empty((k, len(y0)))
    projection_derivative(x1, xm, ftype, z0, dz)
    h = 1e-6
    fd = np.empty_like(dz)
    for i in range(len(y0)):
        zz = []
        for s in (1, -1):
            y = y0.copy()
            y[i] += s * h
            ok, z = nproject(*split(y, d), ftype, zeta0=z0)
            assert ok
            zz.append(z)
        fd[:, i] = (zz[0] - zz[1]) / (2 * h)
    assert relerr(dz, fd) < 1e-6


def test_project_robust_strongly_curved():
    """Random points around strongly curved P2 facets, from the centre and from random
    starts (indefinite initial Hessians): always a converged local minimum."""
    rng = np.random.default_rng(40)
    ang = np.deg2rad([190.0, 350.0, 270.0])  # interval2 nodes on a circle of radius 0.6
    xm2 = np.array([0.5, 0.0]) + 0.6 * np.column_stack([np.cos(ang), np.sin(ang)])
    nodes = REFERENCE_NODES[QUAD2]
    xm3 = np.column_stack([nodes, -1.5 * np.sum((nodes - 0.5) ** 2, axis=1)])
    for ftype, xm in ((INTERVAL2, xm2), (QUAD2, xm3)):
        k = tdim(ftype)
        for _ in range(200):
            x1 = xm.mean(axis=0) + rng.uniform(-2, 2, xm.shape[1])
            for z0 in (None, rng.uniform(-0.5, 1.5, k)):
                ok, z = nproject(x1, xm, ftype, zeta0=z0, maxit=60)
                assert ok
                N, dN, ddN = ref.shape(ftype, z)
                w = x1 - N @ xm
                A = dN.T @ xm
                H = A @ A.T - np.einsum("i,abi->ab", w, np.einsum("nab,ni->abi", ddN, xm))
                assert np.abs(A @ w).max() < 1e-10
                assert np.linalg.eigvalsh(H).min() > -1e-10


def _pair_one(ftype_s, xs, xi, ftype_m, xm, msign):
    """kernels.mortar.pair_points for one slave point (slave facet xs (ns, d) at ξ = xi)
    against master facets xm (nmf, nm, d): (master facet or −1, gap). The slave normal
    is oriented towards +z (2D: +y), the masters' normals by ``msign``."""
    from dolfinx_mortar.kernels import mortar as kmortar

    d = xs.shape[1]
    nus = np.empty(d)
    ssign = np.ones(1)
    unit_normal(xs, ftype_s, 1.0, np.asarray(xi, float), nus)
    if nus[-1] < 0.0:
        ssign[0] = -1.0
    nmf = xm.shape[0]
    qp_m, qp_zeta, qp_g = np.empty((1, 1), np.int64), np.empty((1, 1, d - 1)), np.empty((1, 1))
    kmortar.pair_points(
        ftype_s, ftype_m, xs[None], ssign, np.asarray(xi, float)[None, None], np.ones((1, 1)),
        xm, msign, kmortar.facet_keys(xm), np.array([0, nmf]), np.arange(nmf), np.full(1, 1.0), np.full(1, 10.0),
        qp_m, qp_zeta, qp_g, kmortar.OUTSIDE_TOL, False,
    )  # fmt: skip
    return int(qp_m[0, 0]), float(qp_g[0, 0])


def _down(ftype, xm):
    """Signs that turn each master facet's normal towards −z (2D: −y)."""
    k = tdim(ftype)
    nu = np.empty(xm.shape[2])
    out = np.empty(len(xm))
    for m, x in enumerate(xm):
        unit_normal(x, ftype, 1.0, np.full(k, 1.0 / 3.0), nu)
        out[m] = -1.0 if nu[-1] > 0.0 else 1.0
    return out


@pytest.mark.parametrize("g", [0.05, 0.1])
def test_open_point_in_the_blind_spot_of_a_convex_vertex_is_paired(g):
    """2D: a master of two segments meeting at a convex vertex (kink 2 × 2.9°, as a
    faceted die seen from below) and a slave point g below the vertex. Its projections
    onto both segments lie outside them, by ≈ g sin(2.9°)/|facet| = 2.5e-3 in ζ at g = 0.05,
    more than OUTSIDE_TOL: it is paired all the same (kernels.mortar.BLIND_SPOT_SLOPE) with
    the gap to the facet's extension, ≈ g. Before, it dropped out of the pairing, and
    with it its share of the lumped A^I, G^I of its nodes (the nodal gap of a neighbour
    node in contact jumped: ironing2d). The point beyond the master's free end, as far
    outside, stays unpaired."""
    from dolfinx_mortar.kernels import mortar as kmortar

    xm = np.array([[[-1.0, 0.05], [0.0, 0.0]], [[0.0, 0.0], [1.0, 0.05]]])
    msign = _down(INTERVAL1, xm)
    xs = np.array([[-0.5, -g], [0.5, -g]])
    m, gap = _pair_one(INTERVAL1, xs, [0.5], INTERVAL1, xm, msign)
    assert m in (0, 1)
    assert gap == pytest.approx(g, rel=0.01)
    out = g * np.sin(np.arctan(0.05)) / np.hypot(1.0, 0.05)
    assert out > kmortar.OUTSIDE_TOL  # the case the ζ tolerance alone rejected
    # g below the extension of the master's free end, 0.3 g beyond it (≈ 0.25 g from the
    # facet, more than BLIND_SPOT_SLOPE g): no pairing
    xs_end = xs + np.array([1.0 + 0.3 * g, 0.05])
    assert _pair_one(INTERVAL1, xs_end, [0.5], INTERVAL1, xm[1:], msign[1:])[0] == -1


@pytest.mark.parametrize("angle", [0.0, 30.0, 55.0, 65.0, 89.0])
def test_a_master_facet_faces_the_point_within_the_largest_facing_angle(angle):
    """2D: a master facet through (0.5, 0) turned by ``angle`` from facing the slave point
    0.01 below it (n_s·ν = −cos angle): paired below θ_max = 85° (gap 0.01 cos angle, the
    distance to the facet's line), not beyond (kernels.gap.MAX_FACING_ANGLE)."""
    from dolfinx_mortar.kernels.gap import MAX_FACING_ANGLE

    a = np.deg2rad(angle)
    t = np.array([np.cos(a), np.sin(a)])
    xm = np.array([[[0.5, 0.0] - 0.3 * t, [0.5, 0.0] + 0.3 * t]])
    msign = _down(INTERVAL1, xm)
    xs = np.array([[0.0, -0.01], [1.0, -0.01]])
    m, gap = _pair_one(INTERVAL1, xs, [0.5], INTERVAL1, xm, msign)
    if angle < MAX_FACING_ANGLE:
        assert m == 0
        assert gap == pytest.approx(0.01 * np.cos(a), rel=1e-12)
    else:
        assert m == -1


def test_a_master_side_beside_the_point_is_not_paired():
    """2D overhang (session 50): the master body occupies y > 0, x > 0 (its face y = 0
    towards the slave, its side x = 0 tilted by 1° towards the slave, as a load leaves
    it). A slave point beyond the master's edge, beside the side (x = −0.05, y = 0.01,
    its normal +y) projects inside the side with n_s·ν = −sin 1°: the rule n_s·ν < 0
    paired it with its horizontal distance 0.05 as the gap; under n_s·ν < −cos 85° it
    stays unpaired, as it is without the side (its projection onto the face lies 0.05
    beyond the face's end and it penetrates: neither tolerance applies). A point under
    the face pairs with the face."""
    tilt = np.deg2rad(1.0)
    face = [[1.0, 0.0], [0.0, 0.0]]
    side = [[0.0, 0.0], [-0.5 * np.sin(tilt), 0.5 * np.cos(tilt)]]
    xm = np.array([face, side])
    msign = np.empty(2)
    nu = np.empty(2)
    for i, outward in enumerate(([0.0, -1.0], [-1.0, 0.0])):
        unit_normal(xm[i], INTERVAL1, 1.0, np.array([0.5]), nu)
        msign[i] = 1.0 if nu @ outward > 0.0 else -1.0
    unit_normal(xm[1], INTERVAL1, msign[1], np.array([0.5]), nu)
    assert -0.02 < nu[1] < 0.0  # the side turned towards the slave (n_s = +y)
    xs = np.array([[-0.55, 0.01], [0.45, 0.01]])
    assert _pair_one(INTERVAL1, xs, [0.5], INTERVAL1, xm, msign)[0] == -1
    assert _pair_one(INTERVAL1, xs, [0.5], INTERVAL1, xm[:1], msign[:1])[0] == -1
    m, gap = _pair_one(INTERVAL1, xs + [0.6, -0.02], [0.5], INTERVAL1, xm, msign)
    assert (m, gap) == (0, pytest.approx(0.01, rel=1e-12))


def test_a_facet_containing_the_point_wins_in_any_candidate_order():
    """2D: a slave point 5e-4 (in ζ) beyond the end of master facet A, at gap 0.05 to A's
    extension, and inside facet B, 0.06 away. B wins (a facet that contains the projection
    comes first), whichever candidate comes first. Before, with A first, B's bounding box
    (0.06 away) was pruned by A's distance, and A won: the pairing depended on the
    candidates' order, which depends on the partition."""
    xm = np.array([[[-1.0, 0.0], [0.0, 0.0]], [[0.0, 0.01], [1.0, 0.01]]])
    msign = _down(INTERVAL1, xm)
    xs = np.array([[-0.4995, -0.05], [0.5005, -0.05]])
    for order in ([0, 1], [1, 0]):
        m, gap = _pair_one(INTERVAL1, xs, [0.5], INTERVAL1, xm[order], msign[order])
        assert order[m] == 1
        assert gap == pytest.approx(0.06, rel=1e-12)


def test_open_point_above_a_convex_ridge_is_paired_3d():
    """3D: two triangles meeting along a convex ridge (the x axis, 2.9° each way), a slave
    point g = 0.05 below the ridge: paired, gap ≈ g."""
    xm = np.array(
        [
            [[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.05]],
            [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.05]],
        ]
    )
    msign = _down(TRIANGLE1, xm)
    g = 0.05
    xs = np.array([[-0.5, -0.5, -g], [0.5, -0.5, -g], [0.0, 1.0, -g]])
    xi = np.array([1.0 / 3.0, 1.0 / 3.0])
    x1 = xs.T @ np.array([1.0 / 3.0] * 3)
    assert abs(x1[1]) < 1e-12  # the point lies under the ridge
    m, gap = _pair_one(TRIANGLE1, xs, xi, TRIANGLE1, xm, msign)
    assert m in (0, 1)
    assert gap == pytest.approx(g, rel=0.01)


@pytest.mark.parametrize("ftype", [INTERVAL1, TRIANGLE1])
def test_affine_projection_in_closed_form(ftype):
    """Affine facets are projected in closed form (kernels.gap._project_affine): the same
    point as the SciPy reference inside and beyond the facet, with the work-array
    variants (project_in, unit_normal_in, gap_only_in) equal to the allocating ones; a
    degenerate facet falls back to the Newton iteration and stays finite."""
    from dolfinx_mortar.kernels.gap import gap_only_in, project_in, unit_normal_in, work

    rng = np.random.default_rng(11)
    w = work(ftype)
    k = tdim(ftype)
    for target in (np.full(k, 0.3), np.full(k, 1.4), np.full(k, -0.6)):
        xm, sign = make_facet(ftype, rng, amp=0.2)
        x1 = slave_point(ftype, xm, sign, rng.uniform(-0.5, 0.5), rng, zeta=target)
        ok, z = nproject(x1, xm, ftype)
        assert ok
        np.testing.assert_allclose(z, ref.project(x1, xm, ftype, zeta0=target), atol=1e-12)
        S, A = ref.surface(xm, ftype, z)
        assert np.abs(A @ (x1 - S)).max() < 1e-13
        z2 = np.empty(k)
        assert project_in(x1, xm, ftype, np.full(k, np.nan), z2, TOL, MAXIT, w)
        np.testing.assert_array_equal(z2, z)
        nu, nu2 = np.empty(k + 1), np.empty(k + 1)
        assert unit_normal(xm, ftype, sign, z, nu) == unit_normal_in(xm, ftype, sign, z, nu2, w)
        np.testing.assert_array_equal(nu, nu2)
        assert gap_only(x1, xm, ftype, sign, z) == gap_only_in(x1, xm, ftype, sign, z, w)
        assert gap_only(x1, xm, ftype, sign, z) == pytest.approx(
            float(ref.gap(x1, xm, ftype, sign, z)), abs=1e-13
        )
    degenerate = np.zeros((k + 1, k + 1))
    degenerate[1:, 0] = np.arange(1, k + 1)  # all nodes on one line (k = 2) or one point
    if k == 1:
        degenerate[1] = degenerate[0]
    ok, z = nproject(np.ones(k + 1), degenerate, ftype)
    assert np.all(np.isfinite(z))


def test_quad1_surface_unrolled_equals_the_generic_path():
    """kernels.gap._surface / _surface_in of a QUAD1 facet (session 62: unrolled over its
    4 nodes, kernels.gap._surface_quad1) against the generic path, kernels.shape.shape
    then the sums over the nodes in node order from 0.0 (here in Python floats, the
    same IEEE operations): N, dN, ddN, S, A and SS bit for bit (signed zeros included)
    on a warped quad, inside and far outside the reference square; _surface_in leaves
    SS as it was."""
    from dolfinx_mortar.kernels.gap import _surface, _surface_in, work

    rng = np.random.default_rng(62)
    xm = REFERENCE_NODES[QUAD1] @ np.array([[0.7, 0.1, 0.05], [-0.2, 0.9, 0.1]])
    xm = xm + rng.uniform(-0.1, 0.1, xm.shape) + np.array([0.3, -0.2, 1.5])
    N, dN, ddN, S, A, SS = work(QUAD1)[:6]
    N0, dN0, ddN0 = np.empty(4), np.empty((4, 2)), np.empty((4, 2, 2))
    points = [(0.5, 0.5), (0.0, 0.0), (1.0, 1.0), (1.0, -0.0), (-0.0, 2.0)]
    points += [tuple(z) for z in rng.uniform(-3.0, 4.0, (300, 2))]
    for zeta in np.array(points):
        shape(QUAD1, zeta, N0, dN0, ddN0)
        S0 = [sum_in_order(N0, xm[:, i]) for i in range(3)]
        A0 = [[sum_in_order(dN0[:, al], xm[:, i]) for i in range(3)] for al in range(2)]
        SS0 = [
            [[sum_in_order(ddN0[:, al, be], xm[:, i]) for i in range(3)] for be in range(2)]
            for al in range(2)
        ]
        SS[...] = 7.0
        _surface_in(xm, QUAD1, zeta, N, dN, ddN, S, A, SS)
        assert np.all(SS == 7.0)
        for got, want in ((N, N0), (dN, dN0), (ddN, ddN0), (S, S0), (A, A0)):
            np.testing.assert_array_equal(got.view(np.int64), np.array(want).view(np.int64))
        _surface(xm, QUAD1, zeta, N, dN, ddN, S, A, SS)
        for got, want in ((N, N0), (dN, dN0), (ddN, ddN0), (S, S0), (A, A0), (SS, SS0)):
            np.testing.assert_array_equal(got.view(np.int64), np.array(want).view(np.int64))


def sum_in_order(c, x):
    """Σ_a c[a] x[a] in Python floats, from 0.0 in the order of a (the kernels' sums)."""
    s = 0.0
    for a in range(len(c)):
        s += float(c[a]) * float(x[a])
    return s


def _quad_grid(n, lo, hi, z):
    """QUAD1 facets of an n × n grid of [lo, hi]², heights z(x, y): (n², 4, 3)."""
    t = np.linspace(lo, hi, n + 1)
    out = []
    for j in range(n):
        for i in range(n):
            nodes = [(t[i], t[j]), (t[i + 1], t[j]), (t[i], t[j + 1]), (t[i + 1], t[j + 1])]
            out.append([[x, y, z(x, y)] for x, y in nodes])
    return np.array(out)


def test_nearest_first_pairing_equals_the_sweep_in_candidate_order():
    """kernels.mortar.pair_points with ``nearest_first`` (the t_n pairings of friction,
    session 54) against the plain sweep, every master facet a candidate of every slave
    facet, in a shuffled order, reach 2 h: the same master facet, ζ and gap, bit for bit,
    at 1520 points of a 4 × 4 slave grid over a 6 × 6 master (h = 0.2) with a convex
    kink and a bump: points inside a facet, over shared edges and vertices of the flat
    part (ties, decided by the facet keys), just outside both facets of the kink (the
    least-outside winner: no facet contains them, the sweep is replayed), and beyond the
    master (unpaired: both sweeps run)."""
    from dolfinx_mortar.kernels import mortar as kmortar

    rng = np.random.default_rng(54)

    def z(x, y):  # flat for x ≤ 0.4, a convex kink along x = 0.4, a bump near (0.9, 0.9)
        return 0.03 * max(x - 0.4, 0.0) + 0.01 * np.exp(-((x - 0.9) ** 2 + (y - 0.9) ** 2) / 0.02)

    xm = _quad_grid(6, -0.2, 1.0, z)
    msign = _down(QUAD1, xm)
    xs = _quad_grid(4, -0.3, 1.1, lambda x, y: -0.002)  # reaches past the master's end
    nsf, nq = len(xs), 100
    ssign = -_down(QUAD1, xs)
    qp_xi = rng.uniform(0.0, 1.0, (nsf, nq, 2))
    # points exactly over master edges and vertices of the flat part (x < 0.4)
    t = np.linspace(-0.3, 1.1, 5)
    for f in range(nsf):
        i, j = f % 4, f // 4
        for q, (x, y) in enumerate([(0.0, 0.0), (0.2, 0.2), (0.0, 0.1), (0.2, -0.1)]):
            qp_xi[f, q] = [(x - t[i]) / (t[i + 1] - t[i]), (y - t[j]) / (t[j + 1] - t[j])]
    qp_w = np.ones((nsf, nq))
    qp_w[:, -5:] = 0.0  # unused slots
    off = np.arange(nsf + 1) * len(xm)
    idx = np.concatenate([rng.permutation(len(xm)) for _ in range(nsf)])
    reach = np.full(nsf, 0.4)
    out = []
    for nearest in (False, True):
        qp_m = np.full((nsf, nq), -7, np.int64)
        qp_zeta, qp_g = np.full((nsf, nq, 2), 7.0), np.full((nsf, nq), 7.0)
        kmortar.pair_points(
            QUAD1, QUAD1, xs, ssign, qp_xi, qp_w, xm, msign, kmortar.facet_keys(xm), off, idx,
            reach, reach, qp_m, qp_zeta, qp_g, kmortar.OUTSIDE_TOL, nearest,
        )  # fmt: skip
        out.append((qp_m, qp_zeta, qp_g))
    for a, b in zip(*out, strict=True):
        np.testing.assert_array_equal(a, b)
    qp_m, qp_zeta, _ = out[1]
    used = qp_w != 0.0
    paired = used & (qp_m >= 0)
    outside = np.array([kmortar._outside(QUAD1, zz) for zz in qp_zeta[paired]])
    assert np.count_nonzero(used & (qp_m < 0)) > 50  # beyond the master
    assert np.count_nonzero(outside > kmortar.INSIDE_TOL) > 0  # just outside every facet
    assert np.count_nonzero(np.abs(outside) <= kmortar.INSIDE_TOL) >= 3 * nsf  # on edges
    assert np.all(qp_m[~used] == -1)


def test_nearest_first_pairing_keeps_the_order_of_a_tie_cycle():
    """Three stacked master facets over a slave point, at gaps d, d + 0.7 tie and
    d + 1.4 tie (tie = PAIR_TIE_TOL reach), keys C < B < A: B beats A (a tie, the smaller
    key), C beats B (likewise), A beats C (nearer by more than the tie), so the sweep's
    winner depends on the candidates' order: C for (A, B, C), B for (C, A, B). The
    nearest-first pairing meets A, B, C in that order whatever the candidates' order; its
    check finds the cycle and replays the sweep in the candidates' order: the same winner
    for both orders."""
    from dolfinx_mortar.kernels import mortar as kmortar

    reach, d = 1.0, 0.01
    tie = kmortar.PAIR_TIE_TOL * reach
    sq = np.array([[-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0], [1.0, 1.0]])
    xm = np.array([np.column_stack([sq, np.full(4, d + s * tie)]) for s in (0.0, 0.7, 1.4)])
    msign = _down(QUAD1, xm)
    keys = np.array([[3.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 0.0, 0.0]])  # A, B, C
    xs = np.array([[[-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [-0.5, 0.5, 0.0], [0.5, 0.5, 0.0]]])
    ssign = -_down(QUAD1, xs)
    for order, winner in (([0, 1, 2], 2), ([2, 0, 1], 1)):
        for nearest in (False, True):
            qp_m, qp_zeta, qp_g = np.empty((1, 1), np.int64), np.empty((1, 1, 2)), np.empty((1, 1))
            kmortar.pair_points(
                QUAD1, QUAD1, xs, ssign, np.full((1, 1, 2), 0.5), np.ones((1, 1)), xm, msign,
                keys, np.array([0, 3]), np.array(order), np.full(1, 1.0), np.full(1, reach),
                qp_m, qp_zeta, qp_g, kmortar.OUTSIDE_TOL, nearest,
            )  # fmt: skip
            assert qp_m[0, 0] == winner, (order, nearest)
            assert qp_g[0, 0] == pytest.approx(d + [0.0, 0.7, 1.4][winner] * tie, abs=1e-16)


@pytest.mark.parametrize("ftype", [INTERVAL1, TRIANGLE1])
def test_affine_frames_give_the_gap_functions_values_bit_for_bit(ftype):
    """kernels.mortar's affine shortcuts of the pairing (session 68): the unit normal of
    ``_affine_frames`` and the gap of ``_affine_gap`` against gap.unit_normal and
    gap.gap_only at the same ζ, on 200 random affine facets of both orientations, at ζ
    inside and outside the facet and points on both sides: equal to the last bit (the
    pairing's results, ties included, must not move)."""
    from dolfinx_mortar.kernels import mortar as kmortar

    rng = np.random.default_rng(68)
    k = tdim(ftype)
    d = k + 1
    n = num_nodes(ftype)
    xm = rng.normal(size=(200, n, d)) * rng.uniform(1e-3, 1e3, (200, 1, 1))
    xm += rng.uniform(-1e4, 1e4, (200, 1, d))  # far from the origin too
    sign = rng.choice([-1.0, 1.0], 200)
    mnu, mnv, mjn = kmortar._affine_frames(ftype, xm, sign)
    num, nu = np.empty(d), np.empty(d)
    for m in range(200):
        for _ in range(5):
            zeta = rng.uniform(-0.5, 1.5, k)
            x1 = xm[m].mean(axis=0) + rng.normal(size=d) * np.abs(xm[m]).max() * 1e-3
            unit_normal(xm[m], ftype, sign[m], zeta, nu)
            kmortar._affine_normal(m, mnu, num)
            np.testing.assert_array_equal(num, nu)
            want = gap_only(x1, xm[m], ftype, sign[m], zeta)
            assert kmortar._affine_gap(ftype, x1, xm, m, zeta, mnv, mjn) == want
    # other facet types get no frames: the pairing evaluates them per point
    assert kmortar._affine_frames(QUAD1, np.zeros((3, 4, 3)), np.ones(3))[0].shape == (0, 3)


def test_box_distance_of_a_box_bounds_its_points_in_floating_point():
    """The pairing drops, per slave facet, the candidates whose bounding box lies beyond
    ``reach`` from the box of the facet's points (session 68). That is exact only if no
    point's rounded box distance is shorter than the rounded box-to-box distance: checked
    at the corners, edges and random interior points of 500 random point boxes, against
    master boxes on every side (rounding is monotone)."""
    from dolfinx_mortar.kernels import mortar as kmortar

    rng = np.random.default_rng(168)
    for _ in range(500):
        d = int(rng.integers(2, 4))
        c = rng.uniform(-1e3, 1e3, d)
        lo = c + rng.uniform(-1.0, 0.0, d) * 10.0 ** rng.uniform(-8, 1)
        hi = lo + rng.uniform(0.0, 1.0, d) * 10.0 ** rng.uniform(-8, 1)
        pbox = np.array([lo, hi])
        shift = rng.uniform(-3.0, 3.0, d) * (hi - lo + 1e-9)
        boxes = np.array([[lo + shift - 1e-9, hi + shift * 0.5]])
        boxes.sort(axis=1)
        bb = kmortar._box_box_distance2(boxes, 0, pbox)
        corners = np.array(np.meshgrid(*[[lo[i], hi[i]] for i in range(d)])).reshape(d, -1).T
        inner = lo + rng.uniform(0.0, 1.0, (20, d)) * (hi - lo)
        for x in np.concatenate([corners, inner]):
            x = np.minimum(np.maximum(x, lo), hi)
            assert kmortar._box_distance2(boxes, 0, x) >= bb


def test_pairing_on_triangles_keeps_the_result_of_every_candidate():
    """kernels.mortar.pair_points on affine triangles (P1 tetrahedra's faces, the
    degree-12 rule: 33 points per facet) against itself with every master facet a
    candidate of every slave facet: the same facets, ζ and gaps, bit for bit (the
    per-facet drop of far candidates and the affine shortcuts change nothing), and each
    pair as the gap module's per-point functions give it: ζ = gap.project, g =
    gap.gap_only at that ζ, bit for bit; no paired point with a nearer valid facet
    containing its projection (a brute-force check over all facets); forced_points (segment
    integration's gaps at given pairs) gives the same ζ and g."""
    from dolfinx_mortar.kernels import mortar as kmortar
    from dolfinx_mortar.search import candidates

    rng = np.random.default_rng(268)

    def tri_grid(n, lo, hi, z, jitter):
        t = np.linspace(lo, hi, n + 1)
        X, Y = np.meshgrid(t, t)
        P = np.column_stack([X.ravel(), Y.ravel()])
        P[:, :] += rng.uniform(-jitter, jitter, P.shape) * (hi - lo) / n
        P3 = np.column_stack([P, [z(x, y) for x, y in P]])
        out = []
        for j in range(n):
            for i in range(n):
                a, b = j * (n + 1) + i, j * (n + 1) + i + 1
                c, e = a + n + 1, b + n + 1
                out += [P3[[a, b, e]], P3[[a, e, c]]]
        return np.array(out)

    xm = tri_grid(9, -0.2, 1.0, lambda x, y: 0.05 * (x - 0.5) ** 2 + 0.02 * y, 0.2)
    # the slave opens away from the master with x: gaps 0.003 … 0.12, up to 0.45 h
    xs = tri_grid(
        5,
        -0.3,
        1.1,
        lambda x, y: 0.05 * (x - 0.5) ** 2 + 0.02 * y - 0.003 - 0.2 * max(x - 0.5, 0),
        0.1,
    )
    msign = _down(TRIANGLE1, xm)
    ssign = -_down(TRIANGLE1, xs)
    pts, wts = basix.make_quadrature(basix.CellType.triangle, 12)
    nsf, nq = len(xs), len(wts)
    qp_xi = np.broadcast_to(pts, (nsf, nq, 2)).copy()
    qp_w = np.broadcast_to(wts, (nsf, nq)).copy()
    qp_w[::7, -3:] = 0.0  # unused slots
    h = np.linalg.norm(xs[:, 1] - xs[:, 0], axis=1)
    keys = kmortar.facet_keys(xm)
    off, cand = candidates(xs, xm, h)
    full_off = np.arange(nsf + 1) * len(xm)
    full = np.tile(np.arange(len(xm)), nsf)
    out = []
    for o, c in ((off, cand), (full_off, full)):
        qp_m = np.full((nsf, nq), -7, np.int64)
        qp_zeta, qp_g = np.full((nsf, nq, 2), 7.0), np.full((nsf, nq), 7.0)
        kmortar.pair_points(
            TRIANGLE1, TRIANGLE1, xs, ssign, qp_xi, qp_w, xm, msign, keys, o, c, 2.0 * h,
            h, qp_m, qp_zeta, qp_g, kmortar.OUTSIDE_TOL, False,
        )  # fmt: skip
        out.append((qp_m, qp_zeta, qp_g))
    for a, b in zip(*out, strict=True):
        np.testing.assert_array_equal(a, b)
    qp_m, qp_zeta, qp_g = out[0]
    assert np.all(qp_m[qp_w == 0.0] == -1)
    # segment integration's gaps at given pairs (forced_points): the same ζ and g
    fz, fg = np.full((nsf, nq, 2), 7.0), np.full((nsf, nq), 7.0)
    kmortar.forced_points(TRIANGLE1, TRIANGLE1, xs, qp_xi, qp_m, xm, msign, fz, fg)
    np.testing.assert_array_equal(fz[qp_m >= 0], qp_zeta[qp_m >= 0])
    np.testing.assert_array_equal(fg, np.where(qp_m >= 0, qp_g, 0.0))
    paired = np.argwhere(qp_m >= 0)
    assert len(paired) > 0.5 * np.count_nonzero(qp_w)
    assert np.count_nonzero((qp_m < 0) & (qp_w != 0.0)) > 50  # beyond the master
    N, dN, ddN = np.empty(3), np.empty((3, 2)), np.empty((3, 2, 2))
    zeta = np.empty(2)
    for f, q in paired:
        shape(TRIANGLE1, qp_xi[f, q], N, dN, ddN)
        x1 = np.array([sum(N[a] * xs[f, a, c] for a in range(3)) for c in range(3)])
        m = qp_m[f, q]
        project(x1, xm[m], TRIANGLE1, np.full(2, np.nan), zeta, 1e-13, 30)
        np.testing.assert_array_equal(qp_zeta[f, q], zeta)
        assert qp_g[f, q] == gap_only(x1, xm[m], TRIANGLE1, msign[m], zeta)
        if kmortar._outside(TRIANGLE1, zeta) <= kmortar.INSIDE_TOL:
            for mm in range(len(xm)):  # no containing facet nearer by more than the tie
                project(x1, xm[mm], TRIANGLE1, np.full(2, np.nan), zeta, 1e-13, 30)
                if kmortar._outside(TRIANGLE1, zeta) <= kmortar.INSIDE_TOL:
                    g = gap_only(x1, xm[mm], TRIANGLE1, msign[mm], zeta)
                    assert abs(g) >= abs(qp_g[f, q]) - kmortar.PAIR_TIE_TOL * h[f]
    assert np.max(qp_g[qp_m >= 0] / h[paired[:, 0]]) > 0.3  # open points paired far off
    for f, q in np.argwhere((qp_m < 0) & (qp_w != 0.0)):  # no facet within reach holds them
        shape(TRIANGLE1, qp_xi[f, q], N, dN, ddN)
        x1 = np.array([sum(N[a] * xs[f, a, c] for a in range(3)) for c in range(3)])
        for mm in range(len(xm)):
            project(x1, xm[mm], TRIANGLE1, np.full(2, np.nan), zeta, 1e-13, 30)
            if kmortar._outside(TRIANGLE1, zeta) <= kmortar.INSIDE_TOL:
                assert abs(gap_only(x1, xm[mm], TRIANGLE1, msign[mm], zeta)) > h[f]
