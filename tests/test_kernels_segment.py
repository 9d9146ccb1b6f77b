"""Tests of the segment-based integration points (:mod:`dolfinx_mortar.kernels.segment`):
exact areas and moments on flat non-matching facets, pairing of every point with the master
facet containing it, reference-configuration Jacobian, agreement with the NumPy reference,
and the buffer-overflow return."""

import basix
import numpy as np
import pytest

from dolfinx_mortar.kernels import (
    INTERVAL1,
    INTERVAL2,
    QUAD1,
    QUAD2,
    TRIANGLE1,
    TRIANGLE2,
    inside,
    num_nodes,
    project,
    reference_centre,
    shape,
    tdim,
    unit_normal,
)
from dolfinx_mortar.kernels.segment import segment_points
from dolfinx_mortar.kernels.segment_reference import segment_points_reference

TOL = 1e-12


# ---------------------------------------------------------------------------- helpers
def interval_rule(n):
    """n-point Gauss-Legendre rule on [0, 1] (degree 2n - 1)."""
    g, w = np.polynomial.legendre.leggauss(n)
    return (0.5 * (g + 1.0))[:, None], 0.5 * w


def triangle_rule(degree):
    p, w = basix.make_quadrature(basix.CellType.triangle, degree)
    return np.asarray(p, float), np.asarray(w, float)


def run(ftype_s, xs, ssign, ftype_m, xm, msign, rule, Xs=None, nqmax=400, impl=segment_points):
    xs = np.ascontiguousarray(xs, float)
    xm = np.ascontiguousarray(xm, float)
    Xs = xs.copy() if Xs is None else np.ascontiguousarray(Xs, float)
    nsf, nmf = xs.shape[0], xm.shape[0]
    cand_off = np.arange(nsf + 1, dtype=np.int64) * nmf
    cand = np.tile(np.arange(nmf, dtype=np.int64), nsf)
    k = tdim(ftype_s)
    qp_xi = np.full((nsf, nqmax, k), np.nan)
    qp_w = np.full((nsf, nqmax), np.nan)
    qp_m = np.full((nsf, nqmax), -7, dtype=np.int64)
    count = impl(
        ftype_s,
        xs,
        Xs,
        np.asarray(ssign, float),
        ftype_m,
        xm,
        np.asarray(msign, float),
        cand_off,
        cand,
        rule[0],
        rule[1],
        qp_xi,
        qp_w,
        qp_m,
    )
    return count, qp_xi, qp_w, qp_m


def geometry(ftype, x, xi):
    """Point x(xi) of the facet with nodes x."""
    n = num_nodes(ftype)
    k = tdim(ftype)
    N, dN, ddN = np.empty(n), np.empty((n, k)), np.empty((n, k, k))
    shape(ftype, np.asarray(xi, float), N, dN, ddN)
    return N @ x


def outward_sign(ftype, x, direction):
    """Sign making unit_normal(x, ftype, sign, centre) point along ``direction``."""
    xi = np.empty(tdim(ftype))
    reference_centre(ftype, xi)
    nu = np.empty(x.shape[1])
    unit_normal(np.ascontiguousarray(x, float), ftype, 1.0, xi, nu)
    return 1.0 if nu @ direction > 0 else -1.0


def check_unused(count, qp_xi, qp_w, qp_m):
    for f, c in enumerate(count):
        assert np.all(qp_m[f, c:] == -1)
        assert np.all(qp_w[f, c:] == 0.0)
        assert np.all(qp_xi[f, c:] == 0.0)


def check_in_master(ftype_s, xs, ftype_m, xm, count, qp_xi, qp_m, tol=1e-9):
    """Every point's current position projects inside its assigned master facet."""
    km = tdim(ftype_m)
    z0 = np.full(km, np.nan)
    z = np.empty(km)
    for f, c in enumerate(count):
        for j in range(c):
            x = geometry(ftype_s, xs[f], qp_xi[f, j])
            m = qp_m[f, j]
            assert project(x, np.ascontiguousarray(xm[m]), ftype_m, z0, z, 1e-13, 50)
            assert inside(ftype_m, z, tol), (f, j, m, z)


def sorted_points(count, qp_xi, qp_w, qp_m):
    """Per facet: (m, xi, w) of the used points, sorted by master index and position."""
    out = []
    for f, c in enumerate(count):
        xi, w, m = qp_xi[f, :c], qp_w[f, :c], qp_m[f, :c]
        keys = [np.round(xi[:, a], 8) for a in range(xi.shape[1])][::-1] + [m]
        o = np.lexsort(keys)
        out.append((m[o], xi[o], w[o]))
    return out


def assert_same(res_a, res_b, tol=TOL):
    assert np.array_equal(res_a[0], res_b[0])
    for (ma, xa, wa), (mb, xb, wb) in zip(
        sorted_points(*res_a), sorted_points(*res_b), strict=True
    ):
        assert np.array_equal(ma, mb)
        np.testing.assert_allclose(xa, xb, rtol=0, atol=tol)
        np.testing.assert_allclose(wa, wb, rtol=0, atol=tol)


# ---------------------------------------------------------------------------- 2D
BREAKS = np.array([-0.3, 0.05, 0.37, 0.61, 0.9, 1.4])


def master_intervals(breaks, y=1e-3, p2=False, flip_up=()):
    """Master facets on y = const tiling ``breaks``, every other one with reversed node order,
    signs making the normal face down (-y), except the indices in ``flip_up``."""
    xm, ms = [], []
    for i in range(len(breaks) - 1):
        a, b = np.array([breaks[i], y]), np.array([breaks[i + 1], y])
        if i % 2:
            a, b = b, a
        nodes = [a, b, 0.5 * (a + b)] if p2 else [a, b]
        ftype = INTERVAL2 if p2 else INTERVAL1
        s = outward_sign(ftype, np.array(nodes), np.array([0.0, -1.0]))
        xm.append(nodes)
        ms.append(-s if i in flip_up else s)
    return np.array(xm), np.array(ms)


def test_2d_flat_p1():
    xs = np.array([[[0.0, 0.0], [1.0, 0.0]]])
    ss = [outward_sign(INTERVAL1, xs[0], np.array([0.0, 1.0]))]
    xm, ms = master_intervals(BREAKS)
    # a duplicate of facet 2 facing up (away from the slave) must be ignored
    xm = np.concatenate([xm, xm[2:3]])
    ms = np.concatenate([ms, -ms[2:3]])
    n = 3
    count, qp_xi, qp_w, qp_m = run(INTERVAL1, xs, ss, INTERVAL1, xm, ms, interval_rule(n))
    assert count[0] == 5 * n
    check_unused(count, qp_xi, qp_w, qp_m)
    c = count[0]
    x, w, m = qp_xi[0, :c, 0], qp_w[0, :c], qp_m[0, :c]
    assert abs(w.sum() - 1.0) < TOL
    for p in range(2 * n):
        assert abs(w @ x**p - 1.0 / (p + 1)) < TOL
    for i in range(len(BREAKS) - 1):
        lo, hi = max(BREAKS[i], 0.0), min(BREAKS[i + 1], 1.0)
        sel = m == i
        assert sel.sum() == n
        assert np.all((x[sel] >= lo - 1e-14) & (x[sel] <= hi + 1e-14))
        for p in range(2 * n):
            assert abs(w[sel] @ x[sel] ** p - (hi ** (p + 1) - lo ** (p + 1)) / (p + 1)) < TOL
    assert not np.any(m == len(BREAKS) - 1)  # the non-facing duplicate
    check_in_master(INTERVAL1, xs, INTERVAL1, xm, count, qp_xi, qp_m)


def test_2d_master_side_at_right_angles_is_not_counted():
    """2D overhang (session 50): slave [0, 1] (normal +y), master face y = 0.001 over
    x ∈ [0.3, 1.3] (normal −y) and the master body's side x = 0.3 up to y = 0.5, turned
    by 1° towards the slave (n_s·ν = −sin 1°). The side projects onto the slave facet as a
    sliver 0.5 sin 1° = 0.0087 long; under the rule n_s·ν < 0 it was counted, now
    (n_s·ν < −cos 85°, kernels.gap.faces) only the face: the weights sum to its overlap
    0.7, in the kernel and its NumPy reference alike."""
    tilt = np.deg2rad(1.0)
    xs = np.array([[[0.0, 0.0], [1.0, 0.0]]])
    ss = [outward_sign(INTERVAL1, xs[0], np.array([0.0, 1.0]))]
    face = np.array([[1.3, 0.001], [0.3, 0.001]])
    side = np.array([[0.3, 0.001], [0.3 - 0.5 * np.sin(tilt), 0.001 + 0.5 * np.cos(tilt)]])
    xm = np.array([face, side])
    ms = np.array(
        [
            outward_sign(INTERVAL1, face, np.array([0.0, -1.0])),
            outward_sign(INTERVAL1, side, np.array([-1.0, 0.0])),
        ]
    )
    nu = np.empty(2)
    unit_normal(side, INTERVAL1, ms[1], np.array([0.5]), nu)
    assert -0.02 < nu[1] < 0.0  # the side turned towards the slave
    for impl in (segment_points, segment_points_reference):
        count, qp_xi, qp_w, qp_m = run(
            INTERVAL1, xs, ss, INTERVAL1, xm, ms, interval_rule(3), impl=impl
        )
        c = count[0]
        assert c == 3
        assert np.all(qp_m[0, :c] == 0)
        assert abs(qp_w[0, :c].sum() - 0.7) < TOL


def test_2d_flat_p2_slave_nonuniform_parametrisation():
    # straight P2 slave with its middle node off-centre: x(xi) is quadratic, J0 linear
    xs = np.array([[[0.0, 0.0], [1.0, 0.0], [0.45, 0.0]]])
    ss = [outward_sign(INTERVAL2, xs[0], np.array([0.0, 1.0]))]
    xm, ms = master_intervals(BREAKS, p2=True)
    n = 4
    count, qp_xi, qp_w, qp_m = run(INTERVAL2, xs, ss, INTERVAL2, xm, ms, interval_rule(n))
    c = count[0]
    assert c == 5 * n
    w, m = qp_w[0, :c], qp_m[0, :c]
    x = np.array([geometry(INTERVAL2, xs[0], xi)[0] for xi in qp_xi[0, :c]])
    assert abs(w.sum() - 1.0) < TOL
    # x(xi)^p J0(xi) has degree 2p + 1 <= 2n - 1
    for p in range(n):
        assert abs(w @ x**p - 1.0 / (p + 1)) < TOL
    for i in range(len(BREAKS) - 1):
        lo, hi = max(BREAKS[i], 0.0), min(BREAKS[i + 1], 1.0)
        sel = m == i
        assert np.all((x[sel] >= lo - 1e-14) & (x[sel] <= hi + 1e-14))
        assert abs(w[sel].sum() - (hi - lo)) < TOL
    check_in_master(INTERVAL2, xs, INTERVAL2, xm, count, qp_xi, qp_m)


def test_2d_partial_overlap():
    xs = np.array([[[0.0, 0.0], [1.0, 0.0]]])
    ss = [outward_sign(INTERVAL1, xs[0], np.array([0.0, 1.0]))]
    xm, ms = master_intervals(np.array([0.3, 0.7]))
    xm2, ms2 = master_intervals(np.array([1.5, 2.0]))
    xm3, ms3 = master_intervals(np.array([-1.0, -0.2]))
    xm = np.concatenate([xm, xm2, xm3])
    ms = np.concatenate([ms, ms2, ms3])
    count, qp_xi, qp_w, qp_m = run(INTERVAL1, xs, ss, INTERVAL1, xm, ms, interval_rule(2))
    assert count[0] == 2
    assert abs(qp_w[0].sum() - 0.4) < TOL
    assert np.all(qp_m[0, :2] == 0)
    check_unused(count, qp_xi, qp_w, qp_m)


def test_2d_reference_configuration():
    xs = np.array([[[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [1.3, 0.0]]])
    ss = [outward_sign(INTERVAL1, x, np.array([0.0, 1.0])) for x in xs]
    xm, ms = master_intervals(BREAKS)
    rule = interval_rule(3)
    a = run(INTERVAL1, xs, ss, INTERVAL1, xm, ms, rule)
    b = run(INTERVAL1, xs, ss, INTERVAL1, xm, ms, rule, Xs=2.0 * xs)
    assert np.array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    np.testing.assert_array_equal(a[3], b[3])
    np.testing.assert_allclose(b[2], 2.0 * a[2], rtol=1e-14, atol=0)
    assert abs(b[2][1].sum() - 2.0 * 0.3) < TOL


@pytest.mark.parametrize(
    "ftype_s, mid_y, ftype_m",
    [(INTERVAL1, None, INTERVAL1), (INTERVAL2, 0.05, INTERVAL1), (INTERVAL2, -0.04, INTERVAL2)],
)
def test_2d_matches_reference(ftype_s, mid_y, ftype_m):
    xs = [[[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [1.7, 0.1]]]
    if ftype_s == INTERVAL2:
        xs = [x + [[0.5 * (x[0][0] + x[1][0]), 0.5 * (x[0][1] + x[1][1]) + mid_y]] for x in xs]
    xs = np.array(xs)
    ss = [outward_sign(ftype_s, x, np.array([0.0, 1.0])) for x in xs]
    xm, ms = master_intervals(np.array([-0.3, 0.05, 0.37, 0.61, 0.9, 1.22, 1.5, 2.0]), y=0.08,
                              p2=ftype_m == INTERVAL2, flip_up=(3,))  # fmt: skip
    rule = interval_rule(3)
    Xs = 1.5 * xs + 0.1
    a = run(ftype_s, xs, ss, ftype_m, xm, ms, rule, Xs=Xs)
    b = run(ftype_s, xs, ss, ftype_m, xm, ms, rule, Xs=Xs, impl=segment_points_reference)
    assert np.all(a[0] > 0)
    assert_same(a, b)


# ---------------------------------------------------------------------------- 3D
ANGLE = np.deg2rad(17.0)
GRID_X = np.array([-0.5, -0.1, 0.23, 0.5, 0.71, 1.02, 1.5])
GRID_Y = np.array([-0.5, 0.04, 0.3, 0.62, 0.85, 1.17, 1.5])


def master_surface(ftype, z=1e-3, perturb=0.03, seed=3):
    """Non-matching master surface: a perturbed non-uniform grid of [-0.5, 1.5]^2 rotated by
    17 degrees about (0.5, 0.5) at height z, facing down; alternate node orderings."""
    X, Y = np.meshgrid(GRID_X, GRID_Y, indexing="ij")
    rng = np.random.default_rng(seed)
    X[1:-1, 1:-1] += rng.uniform(-perturb, perturb, X[1:-1, 1:-1].shape)
    Y[1:-1, 1:-1] += rng.uniform(-perturb, perturb, Y[1:-1, 1:-1].shape)
    c, s = np.cos(ANGLE), np.sin(ANGLE)
    P = np.stack([0.5 + c * (X - 0.5) - s * (Y - 0.5), 0.5 + s * (X - 0.5) + c * (Y - 0.5)], -1)
    facets = []
    for i in range(X.shape[0] - 1):
        for j in range(X.shape[1] - 1):
            p00, p10, p01, p11 = P[i, j], P[i + 1, j], P[i, j + 1], P[i + 1, j + 1]
            flip = (i + j) % 2 == 1
            if ftype in (TRIANGLE1, TRIANGLE2):
                for t in ([p00, p10, p11], [p00, p11, p01]):
                    facets.append(t[::-1] if flip else t)
            else:
                facets.append([p01, p11, p00, p10] if flip else [p00, p10, p01, p11])
    xm = np.array([[[*p, z] for p in f] for f in facets])
    xm = add_p2_nodes(ftype, xm)
    ms = np.array([outward_sign(ftype, x, np.array([0.0, 0.0, -1.0])) for x in xm])
    return xm, ms


def add_p2_nodes(ftype, x, bulge=None):
    """Append the P2 nodes (straight edges, or displaced by ``bulge`` (d,)) to P1 facets."""
    if ftype == TRIANGLE2:
        pairs = [(1, 2), (0, 2), (0, 1)]
    elif ftype == QUAD2:
        pairs = [(0, 1), (0, 2), (1, 3), (2, 3), (0, 3)]
    else:
        return x
    extra = [0.5 * (x[:, a] + x[:, b]) for a, b in pairs]
    if ftype == QUAD2:  # centre: mean of the four vertices
        extra[-1] = 0.25 * x[:, :4].sum(axis=1)
    extra = np.stack(extra, axis=1)
    if bulge is not None:
        extra = extra + bulge
    return np.concatenate([x, extra], axis=1)


SLAVE_TRI = np.array(
    [[[0.1, 0.2, 0.0], [0.9, 0.3, 0.0], [0.3, 0.8, 0.0]],
     [[0.9, 0.3, 0.0], [1.2, 0.9, 0.0], [0.3, 0.8, 0.0]]]
)  # fmt: skip
# parallelograms (affine bilinear map), basix order (0,0), (1,0), (0,1), (1,1)
SLAVE_QUAD = np.array(
    [[[0.1, 0.1, 0.0], [0.9, 0.2, 0.0], [0.2, 0.8, 0.0], [1.0, 0.9, 0.0]],
     [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.5, 0.5, 0.0]]]
)  # fmt: skip


def slave_facets(ftype, bulge=None):
    base = SLAVE_TRI if ftype in (TRIANGLE1, TRIANGLE2) else SLAVE_QUAD
    xs = add_p2_nodes(ftype, base.copy(), bulge)
    ss = np.array([outward_sign(ftype, x, np.array([0.0, 0.0, 1.0])) for x in xs])
    return xs, ss


def exact_integral(ftype, x, fun, degree=6):
    """Integral of fun over the facet by a high-degree rule on the facet itself."""
    cell = (
        basix.CellType.triangle if ftype in (TRIANGLE1, TRIANGLE2) else basix.CellType.quadrilateral
    )
    pts, wts = basix.make_quadrature(cell, degree)
    nu = np.empty(3)
    total = 0.0
    for p, w in zip(pts, wts, strict=True):
        j0 = unit_normal(np.ascontiguousarray(x), ftype, 1.0, np.asarray(p, float), nu)
        total += w * j0 * fun(geometry(ftype, x, p))
    return total


def bilinear(x):
    return 1.0 + 2.0 * x[0] - 3.0 * x[1] + 5.0 * x[0] * x[1]


@pytest.mark.parametrize(
    "ftype_s, ftype_m",
    [
        (TRIANGLE1, TRIANGLE1),
        (TRIANGLE1, QUAD1),
        (QUAD1, QUAD1),
        (QUAD1, TRIANGLE1),
        (TRIANGLE2, TRIANGLE2),
        (QUAD2, QUAD1),
    ],
)
def test_3d_flat_exact(ftype_s, ftype_m):
    xs, ss = slave_facets(ftype_s)
    xm, ms = master_surface(ftype_m)
    # the same master facets facing up (away from the slave) must be ignored
    nmf = xm.shape[0]
    xm = np.concatenate([xm, xm])
    ms = np.concatenate([ms, -ms])
    rule = triangle_rule(2)
    count, qp_xi, qp_w, qp_m = run(ftype_s, xs, ss, ftype_m, xm, ms, rule)
    assert np.all(count > 0)
    check_unused(count, qp_xi, qp_w, qp_m)
    assert np.all(qp_m[qp_m >= 0] < nmf)
    assert len(np.unique(qp_m[0, : count[0]])) > 3  # really non-matching
    for f, c in enumerate(count):
        area = exact_integral(ftype_s, xs[f], lambda x: 1.0)
        assert abs(qp_w[f, :c].sum() - area) < TOL
        val = sum(
            w * bilinear(geometry(ftype_s, xs[f], xi))
            for xi, w in zip(qp_xi[f, :c], qp_w[f, :c], strict=True)
        )
        assert abs(val - exact_integral(ftype_s, xs[f], bilinear)) < TOL
        for xi in qp_xi[f, :c]:
            assert inside(ftype_s, xi, 1e-12)
    check_in_master(ftype_s, xs, ftype_m, xm, count, qp_xi, qp_m)


def test_3d_reference_configuration():
    xs, ss = slave_facets(TRIANGLE1)
    xm, ms = master_surface(TRIANGLE1)
    rule = triangle_rule(2)
    a = run(TRIANGLE1, xs, ss, TRIANGLE1, xm, ms, rule)
    b = run(TRIANGLE1, xs, ss, TRIANGLE1, xm, ms, rule, Xs=2.0 * xs)
    assert np.array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    np.testing.assert_array_equal(a[3], b[3])
    np.testing.assert_allclose(b[2], 4.0 * a[2], rtol=1e-14, atol=0)
    for f, c in enumerate(b[0]):
        assert abs(b[2][f, :c].sum() - 4.0 * exact_integral(TRIANGLE1, xs[f], lambda x: 1.0)) < TOL


def test_3d_nonconvex_master_quad():
    # a dart (reflex vertex C) and a convex quad tiling [-0.5, 1.5]^2; slave = unit square
    A, B, C, D, E = [-0.5, -0.5], [1.5, -0.5], [0.5, 0.4], [-0.5, 1.5], [1.5, 1.5]
    cyc = [[A, B, C, D], [B, E, D, C]]
    xm = np.array([[[*p, 1e-3] for p in (q[0], q[1], q[3], q[2])] for q in cyc])
    ms = np.array([outward_sign(QUAD1, x, np.array([0.0, 0.0, -1.0])) for x in xm])
    xs = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]])
    ss = [outward_sign(QUAD1, xs[0], np.array([0.0, 0.0, 1.0]))]
    rule = triangle_rule(2)
    a = run(QUAD1, xs, ss, QUAD1, xm, ms, rule)
    c = a[0][0]
    xi, w, m = a[1][0, :c], a[2][0, :c], a[3][0, :c]
    assert abs(w.sum() - 1.0) < TOL
    assert abs(w @ (xi[:, 0] * xi[:, 1]) - 0.25) < TOL
    assert abs(w @ xi[:, 1] ** 2 - 1.0 / 3.0) < TOL
    # dart ∩ square = {x + y <= 1} ∩ square minus triangle BCD ∩ square (by hand)
    x1 = 17.0 / 18.0  # where the line C-B leaves the square through y = 0
    bcd = 3.0 / 80.0 + 0.15 * (x1 - 0.5) - 0.05 * (x1**2 - 0.25) + 0.5 * (1.0 - x1) ** 2
    assert abs(w[m == 0].sum() - (0.5 - bcd)) < TOL
    assert abs(w[m == 1].sum() - (0.5 + bcd)) < TOL
    b = run(QUAD1, xs, ss, QUAD1, xm, ms, rule, impl=segment_points_reference)
    assert_same(a, b)


@pytest.mark.parametrize(
    "ftype_s, ftype_m, bulge",
    [
        (TRIANGLE1, TRIANGLE1, None),
        (QUAD1, QUAD1, None),
        (TRIANGLE1, QUAD1, None),
        (QUAD1, TRIANGLE2, None),
        (TRIANGLE2, TRIANGLE1, [0.0, 0.0, 0.03]),
        (QUAD2, QUAD1, [0.01, -0.02, 0.04]),
    ],
)
def test_3d_matches_reference(ftype_s, ftype_m, bulge):
    xs, ss = slave_facets(ftype_s, None if bulge is None else np.array(bulge))
    if ftype_s == QUAD1:
        xs = xs.copy()
        xs[0, 3] += [0.07, -0.05, 0.04]  # warped, non-parallelogram bilinear facet
    xm, ms = master_surface(ftype_m, z=0.02)
    rule = triangle_rule(3)
    Xs = 1.2 * xs + 0.3
    a = run(ftype_s, xs, ss, ftype_m, xm, ms, rule, Xs=Xs)
    b = run(ftype_s, xs, ss, ftype_m, xm, ms, rule, Xs=Xs, impl=segment_points_reference)
    assert np.all(a[0] > 0)
    assert_same(a, b)


def test_3d_curved_slave_tiles_reference_facet():
    # approximate geometry (vertex-based clipping), but the segments still tile the facet
    xs, ss = slave_facets(TRIANGLE2, np.array([0.02, -0.01, 0.05]))
    xm, ms = master_surface(TRIANGLE1, z=0.1)
    count, qp_xi, qp_w, qp_m = run(TRIANGLE2, xs, ss, TRIANGLE1, xm, ms, triangle_rule(4))
    for f, c in enumerate(count):
        area = exact_integral(TRIANGLE2, xs[f], lambda x: 1.0, degree=20)
        assert abs(qp_w[f, :c].sum() - area) < 1e-6 * area


def test_3d_flat_trapezoid_slave_total_area():
    # non-parallelogram bilinear slave: segment boundaries are approximate (straight in the
    # reference plane) but the segments tile the facet and J0 is linear in xi, so the
    # total weight is still the exact area
    xs = np.array([[[0.0, 0.0, 0.0], [1.0, 0.1, 0.0], [0.2, 0.7, 0.0], [0.8, 1.0, 0.0]]])
    ss = [outward_sign(QUAD1, xs[0], np.array([0.0, 0.0, 1.0]))]
    xm, ms = master_surface(TRIANGLE1)
    count, qp_xi, qp_w, qp_m = run(QUAD1, xs, ss, TRIANGLE1, xm, ms, triangle_rule(2))
    c = count[0]
    area = exact_integral(QUAD1, xs[0], lambda x: 1.0)
    assert abs(qp_w[0, :c].sum() - area) < TOL
    assert np.all(qp_w[0, :c] > 0.0)


@pytest.mark.parametrize("dim", [2, 3])
def test_buffer_overflow(dim):
    if dim == 2:
        xs = np.array([[[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [1.2, 0.0]]])
        ss = [outward_sign(INTERVAL1, x, np.array([0.0, 1.0])) for x in xs]
        xm, ms = master_intervals(BREAKS)
        ftype, rule = INTERVAL1, interval_rule(3)
    else:
        xs, ss = slave_facets(TRIANGLE1)
        xm, ms = master_surface(TRIANGLE1)
        ftype, rule = TRIANGLE1, triangle_rule(2)
    full = run(ftype, xs, ss, ftype, xm, ms, rule)
    need = full[0]
    assert np.all(need > 0)
    nq = int(need.min()) - 1
    for impl in (segment_points, segment_points_reference):
        short = run(ftype, xs, ss, ftype, xm, ms, rule, nqmax=nq, impl=impl)
        np.testing.assert_array_equal(short[0], -need)
        np.testing.assert_allclose(short[1], full[1][:, :nq], rtol=0, atol=TOL)
        np.testing.assert_allclose(short[2], full[2][:, :nq], rtol=0, atol=TOL)
        np.testing.assert_array_equal(short[3], full[3][:, :nq])
    # exactly fitting buffer: positive counts
    fit = run(ftype, xs, ss, ftype, xm, ms, rule, nqmax=int(need.max()))
    np.testing.assert_array_equal(fit[0], need)


def test_shape_errors():
    xs = np.zeros((1, 2, 2))
    xm = np.zeros((1, 3, 3))
    with pytest.raises(ValueError):
        run(INTERVAL1, xs, [1.0], TRIANGLE1, xm, [1.0], interval_rule(2))


def _fd_derivatives(ftype_s, xs, ss, ftype_m, xm, ms, rule, Xs, h=1e-6):
    """segment_derivatives against central differences of segment_points in every local
    dof of every point (the slave facet's nodes and the point's master facet's nodes);
    the FD perturbations must not change the point set. Returns (dxi, dw)."""
    from dolfinx_mortar.kernels.segment import segment_derivatives

    count, qp_xi, qp_w, qp_m = run(ftype_s, xs, ss, ftype_m, xm, ms, rule, Xs=Xs)
    nsf, nmf = xs.shape[0], xm.shape[0]
    cand_off = np.arange(nsf + 1, dtype=np.int64) * nmf
    cand = np.tile(np.arange(nmf, dtype=np.int64), nsf)
    ns, nm, d = xs.shape[1], xm.shape[1], xs.shape[2]
    k, nloc = d - 1, (ns + nm) * d
    rows = np.flatnonzero(qp_m.ravel() >= 0)
    dxi, dw = np.zeros((rows.size, k, nloc)), np.zeros((rows.size, nloc))
    args = (ftype_s, xs, Xs, np.asarray(ss, float), ftype_m, xm, np.asarray(ms, float))
    n = segment_derivatives(*args, cand_off, cand, *rule, qp_m, dxi, dw)
    assert n == rows.size
    # The points of every perturbed geometry, by the node coordinate moved: the points
    # of a slave facet (or of one master facet) share its perturbations, and the kernel
    # is deterministic, so each perturbed geometry is run once.
    perturbed = {}

    def run_perturbed(key, sgn):
        if (key, sgn) not in perturbed:
            xs2, xm2 = xs.copy(), xm.copy()
            side, facet, node, comp = key
            (xs2 if side == "s" else xm2)[facet, node, comp] += sgn * h
            c2, xi2, w2, m2 = run(ftype_s, xs2, ss, ftype_m, xm2, ms, rule, Xs=Xs)
            assert np.array_equal(c2, count) and np.array_equal(m2, qp_m)
            perturbed[key, sgn] = (xi2, w2)
        return perturbed[key, sgn]

    for r, flat in enumerate(rows):
        f, q = divmod(flat, qp_m.shape[1])
        m = qp_m[f, q]
        for j in range(nloc):
            if j < ns * d:
                key = ("s", f, j // d, j % d)
            else:
                key = ("m", m, (j - ns * d) // d, j % d)
            pts = []
            for sgn in (1.0, -1.0):
                xi2, w2 = run_perturbed(key, sgn)
                pts.append((xi2[f, q], w2[f, q]))
            fd_xi = (pts[0][0] - pts[1][0]) / (2 * h)
            fd_w = (pts[0][1] - pts[1][1]) / (2 * h)
            np.testing.assert_allclose(dxi[r, :, j], fd_xi, rtol=0, atol=1e-7, err_msg=f"{r} {j}")
            assert dw[r, j] == pytest.approx(fd_w, abs=1e-7), (r, j)
    return dxi, dw


@pytest.mark.parametrize("ftype_s", [INTERVAL1, INTERVAL2])
def test_2d_segment_derivatives_match_fd(ftype_s):
    """dξ_q and dw_q of every point (segment_derivatives) against central differences
    (inclined, curved slave on a kinked master; reference geometry ≠ current)."""
    xs = [[0.0, 0.02], [1.0, 0.09]]
    if ftype_s == INTERVAL2:
        xs.append([0.5, 0.09])
    xs = np.array([xs])
    ss = [outward_sign(ftype_s, xs[0], np.array([0.0, 1.0]))]
    xm, ms = master_intervals(np.array([-0.3, 0.05, 0.37, 0.61, 0.9, 1.22]), y=0.08)
    xm[2, 1, 1] += 0.03  # a kink
    dxi, dw = _fd_derivatives(ftype_s, xs, ss, INTERVAL1, xm, ms, interval_rule(3), 1.3 * xs + 0.1)
    assert np.abs(dxi).max() > 0.1 and np.abs(dw).max() > 0.01  # the ends do move


@pytest.mark.parametrize(
    "ftype_s, ftype_m, bulge",
    [
        (TRIANGLE1, TRIANGLE1, None),
        (TRIANGLE1, QUAD1, None),
        (QUAD1, QUAD1, None),
        (QUAD1, TRIANGLE1, None),
        (TRIANGLE2, TRIANGLE2, [0.0, 0.0, 0.03]),
        (QUAD2, QUAD1, [0.01, -0.02, 0.04]),
    ],
)
def test_3d_segment_derivatives_match_fd(ftype_s, ftype_m, bulge):
    """3D: dξ_q and dw_q of every point against central differences, on tilted and warped
    slave facets (the frame c, t₁, t₂ moves with every slave vertex) over a rotated,
    perturbed, non-flat master: points in polygons with master vertices, edge-edge
    intersections and reference corners; reference geometry ≠ current."""
    xs, ss = slave_facets(ftype_s, None if bulge is None else np.array(bulge))
    xs = xs.copy()
    xs[..., 2] += 0.05 * xs[..., 0] - 0.03 * xs[..., 1]  # tilted
    if ftype_s == QUAD1:
        xs[0, 3] += [0.07, -0.05, 0.04]  # warped, non-parallelogram
    xm, ms = master_surface(ftype_m, z=0.02)
    xm = xm.copy()
    xm[..., 2] += 0.02 * np.sin(3.0 * xm[..., 0]) * np.cos(2.0 * xm[..., 1])
    Xs = 1.2 * xs + 0.3
    Xs[..., 2] += 0.1 * Xs[..., 0] ** 2  # curved reference facet: J₀ varies with ξ
    dxi, dw = _fd_derivatives(ftype_s, xs, ss, ftype_m, xm, ms, triangle_rule(2), Xs)
    assert np.abs(dxi).max() > 0.1 and np.abs(dw).max() > 0.01


def _moment_derivative_error(xs, G, conn, h=1e-7):
    """P1 triangles: slave facet xs (1, 3, 3) over the master triangles G[conn] (all
    candidates). The moments Σw, Σwξ, Σwξ² summed over ALL pairs, differentiated with
    segment_derivatives (chain rule over the points), against central differences of
    segment_points in every coordinate of the slave nodes and of the master vertices.
    Returns the largest |analytic − FD|."""
    from dolfinx_mortar.kernels.segment import segment_derivatives

    rule = triangle_rule(2)
    xs = np.ascontiguousarray(xs, float)
    Xs = xs.copy()  # fixed reference geometry

    def points(xs_, G_):
        xm = G_[conn]
        ss = [outward_sign(TRIANGLE1, xs_[0], np.array([0.0, 0.0, -1.0]))]
        ms = [outward_sign(TRIANGLE1, x, np.array([0.0, 0.0, 1.0])) for x in xm]
        return xm, ss, ms, run(TRIANGLE1, xs_, ss, TRIANGLE1, xm, ms, rule, Xs=Xs)

    def moments(xi, w):
        return np.concatenate([[w.sum()], w @ xi, w @ xi**2])

    xm, ss, ms, (count, qp_xi, qp_w, qp_m) = points(xs, G)
    n = count[0]
    xi, w, m = qp_xi[0, :n], qp_w[0, :n], qp_m[0, :n]
    nmf = xm.shape[0]
    dxi, dw = np.zeros((n, 2, 18)), np.zeros((n, 18))
    segment_derivatives(
        TRIANGLE1, xs, Xs, np.asarray(ss, float), TRIANGLE1, xm, np.asarray(ms, float),
        np.array([0, nmf], dtype=np.int64), np.arange(nmf, dtype=np.int64), *rule, qp_m, dxi, dw,
    )  # fmt: skip
    worst = 0.0
    dofs = [("s", a, c) for a in range(3) for c in range(3)]
    dofs += [("m", v, c) for v in np.unique(conn[m]) for c in range(3)]
    for kind, v, c in dofs:
        # column of the dof in each point's local block [slave nodes, its master facet's nodes]
        cols = np.full(n, v * 3 + c)
        if kind == "m":
            loc = conn[m] == v
            cols = np.where(loc.any(axis=1), 9 + 3 * loc.argmax(axis=1) + c, -1)
        sel = cols >= 0
        dw_j = np.where(sel, dw[np.arange(n), np.maximum(cols, 0)], 0.0)
        dxi_j = np.where(sel[:, None], dxi[np.arange(n), :, np.maximum(cols, 0)], 0.0)
        an = np.concatenate(
            [[dw_j.sum()], dw_j @ xi + w @ dxi_j, dw_j @ xi**2 + 2.0 * w @ (xi * dxi_j)]
        )
        fd = []
        for sgn in (1.0, -1.0):
            xs2, G2 = xs.copy(), G.copy()
            if kind == "s":
                xs2[0, v, c] += sgn * h
            else:
                G2[v, c] += sgn * h
            _, _, _, (c2, xi2, w2, _) = points(xs2, G2)
            fd.append(moments(xi2[0, : c2[0]], w2[0, : c2[0]]))
        worst = max(worst, np.abs(an - (fd[0] - fd[1]) / (2 * h)).max())
    return worst


def _master_grid(x0, y0, spacing, n, z=-1e-3):
    """Triangulated n × n master grid (diagonals alternating), facing up (+z)."""
    G = np.array(
        [[x0 + i * spacing, y0 + j * spacing, z] for j in range(n + 1) for i in range(n + 1)]
    )
    conn = []
    for j in range(n):
        for i in range(n):
            a, b = j * (n + 1) + i, j * (n + 1) + i + 1
            c, e = a + n + 1, b + n + 1
            conn += [[a, b, e], [a, e, c]] if (i + j) % 2 else [[a, b, c], [b, e, c]]
    return G, np.array(conn)


@pytest.mark.parametrize("shift", [0.0, 1e-9, 0.1, -0.2])
def test_3d_segment_derivatives_master_edge_on_the_hypotenuse(shift):
    """A master edge lying ON the slave triangle's hypotenuse (ξ₁ + ξ₂ = 1; here y = 0),
    shared by a master triangle covering the slave and one outside it, slave moved along
    the line by ``shift``. The covered area and the moments are constant, so every
    derivative summed over the pairs must be 0, as the central differences are. The
    master edge is cut by the leg ξ₂ = 0 before the hypotenuse is clipped: that cut, the
    corner (1, 0), used to move along the leg (errors 0.34)."""
    xs = np.array([[[0.5, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]])
    xs[..., 0] += shift
    G = np.array([[-1.0, 0.0, -1e-3], [2.0, 0.0, -1e-3], [0.5, 2.0, -1e-3], [0.5, -2.0, -1e-3]])
    conn = np.array([[0, 1, 2], [0, 3, 1]])
    assert _moment_derivative_error(xs, G, conn) < 1e-6


@pytest.mark.parametrize("x0", [-0.5, -0.499, -0.37])
def test_3d_segment_derivatives_master_vertices_on_the_hypotenuse(x0):
    """A triangulated master grid whose grid line y = 0 is the slave triangle's
    hypotenuse: master vertices on it inside the slave edge (x0 = -0.499, -0.37) and at
    its corners too (x0 = -0.5). A master vertex on the line but outside it by round-off
    is cut away: the cut points, one per master edge at that vertex, moved as the
    intersections of those edges with the line, and the canonical form kept one of the
    (coincident) cuts, so the neighbouring pairs disagreed; at a corner, a vertex slid
    along the leg and then along the hypotenuse kept part of its motion (errors 2.5e-4
    to 0.19 before the fix)."""
    xs = np.array([[[1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]])
    G, conn = _master_grid(x0, -0.5, 0.25, 8)
    assert _moment_derivative_error(xs, G, conn) < 1e-6


@pytest.mark.parametrize(
    "x0, y0, spacing, n, angle",
    [(0.3, -0.4, 0.4, 4, 0.0), (0.3, -0.5, 0.25, 8, 0.0), (0.3, 0.0, 0.25, 6, np.pi / 4),
     (0.3, 0.0, 0.25, 6, -0.4)],
)  # fmt: skip
def test_3d_segment_derivatives_master_boundary_on_the_hypotenuse(x0, y0, spacing, n, angle):
    """A master grid that ENDS inside the slave triangle, its boundary crossing the
    hypotenuse (y = 0) at a master vertex: the grid's left edge x = x0 (angle 0, with a
    boundary vertex and interior vertices on the line) or, rotated by ``angle`` about its
    corner (x0, 0), the master's corner on the line. The covered region's vertex there is
    the crossing of the master boundary edge with the line, and every polygon's vertex at
    the master vertex must move as that crossing does when the vertex moves out of the
    triangle: a vertex on the line was slid orthogonally to it, right only where the
    master continues across the line or the boundary edge is perpendicular to it in the
    reference coordinates (errors 0.0089 to 0.16 before the fix)."""
    xs = np.array([[[1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]])
    G, conn = _master_grid(0.0, y0, spacing, n)
    c, s = np.cos(angle), np.sin(angle)
    G[:, :2] = G[:, :2] @ np.array([[c, s], [-s, c]])
    G[:, 0] += x0
    assert _moment_derivative_error(xs, G, conn) < 1e-6
