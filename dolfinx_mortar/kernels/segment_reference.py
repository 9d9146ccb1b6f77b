"""Slow NumPy reference of :func:`dolfinx_mortar.kernels.segment.segment_points` (for tests).

Same signature, outputs and conventions (see :mod:`.segment`); the geometry is computed
along an independent route:

* shape functions, surface points, tangents and normals come from the NumPy reference
  :mod:`.reference` (not the numba kernels);
* 2D: the closest point of a master end node on the slave interval by a direct formula
  (P1: orthogonal projection; P2: the real roots of the cubic (x(ξ) - p)·x'(ξ) = 0, the
  closest one is taken);
* 3D: the master vertex is projected along n₀ onto the slave plane and mapped to ξ by a
  least-squares solve (triangles) or Gauss-Newton with ``numpy.linalg.lstsq`` (quads);
* the intersection of the (convex) master polygon with the slave reference element is
  not clipped edge by edge: it is the convex hull of the vertices of either polygon lying
  inside the other and all edge-edge intersection points, ordered by angle about their
  mean;
* the facing test projects with the SciPy-based :func:`.reference.project` (its threshold is
  the kernels' one, :data:`.gap.FACING_COS`).

The canonical polygon form and the fan triangulation are the same as in :mod:`.segment`
(they define which points are produced), so the results agree point by point.
"""

import numpy as np

from . import reference as ref
from .gap import FACING_COS
from .segment import COLLINEAR_TOL, KEY, MIN_AREA, MIN_LENGTH
from .shape import (
    INTERVAL1,
    QUAD1,
    TRIANGLE1,
    TRIANGLE2,
    clamp_to_reference,
)


def _centre(ftype):
    if ftype in (TRIANGLE1, TRIANGLE2):
        return np.array([1.0 / 3.0, 1.0 / 3.0])
    if ref.tdim(ftype) == 1:
        return np.array([0.5])
    return np.array([0.5, 0.5])


def _jacobian(X, ftype, xi):
    """Surface Jacobian |a1| (2D) or |a1 x a2| (3D) of the facet X at xi."""
    _, A = ref.surface(X, ftype, np.asarray(xi, float))
    if X.shape[1] == 2:
        return float(np.linalg.norm(A[0]))
    return float(np.linalg.norm(np.cross(A[0], A[1])))


def _faces(ftype_s, xsf, ss, ftype_m, xmm, ms, xi):
    x, _ = ref.surface(xsf, ftype_s, xi)
    ns = ref.normal(xsf, ftype_s, ss, xi)
    z = ref.project(x, xmm, ftype_m, zeta0=_centre(ftype_m))
    if not np.all(np.isfinite(z)):
        z = _centre(ftype_m)
    z = np.array(z, dtype=float)
    clamp_to_reference(ftype_m, z)
    return float(ns @ ref.normal(xmm, ftype_m, ms, z)) < -FACING_COS


def _interval_parameter(p, xsf, ftype):
    """Parameter of the closest point of the (extrapolated) slave interval to p."""
    x0, x1 = xsf[0], xsf[1]
    if ftype == INTERVAL1:
        e = x1 - x0
        return float((p - x0) @ e / (e @ e))
    x2 = xsf[2]
    # x(t) = A + B t + C t^2
    A, B, C = x0, -3.0 * x0 - x1 + 4.0 * x2, 2.0 * x0 + 2.0 * x1 - 4.0 * x2
    D = A - p
    coef = [2.0 * (C @ C), 3.0 * (B @ C), 2.0 * (D @ C) + B @ B, D @ B]
    roots = np.roots(coef)
    roots = roots[np.abs(roots.imag) < 1e-9].real
    dist = [np.sum((A + B * t + C * t * t - p) ** 2) for t in roots]
    return float(roots[int(np.argmin(dist))])


def _points_1d(f, ftype_s, xs, Xs, ssign, ftype_m, xm, msign, cands, rule_pts, rule_w):
    out = []
    for m in cands:
        t0 = _interval_parameter(xm[m, 0], xs[f], ftype_s)
        t1 = _interval_parameter(xm[m, 1], xs[f], ftype_s)
        lo, hi = max(min(t0, t1), 0.0), min(max(t0, t1), 1.0)
        if not hi - lo > MIN_LENGTH:
            continue
        if not _faces(ftype_s, xs[f], ssign[f], ftype_m, xm[m], msign[m], [0.5 * (lo + hi)]):
            continue
        for r, w in zip(rule_pts[:, 0], rule_w, strict=True):
            xi = np.array([lo + (hi - lo) * r])
            out.append((xi, w * (hi - lo) * _jacobian(Xs[f], ftype_s, xi), m))
    return out


def _cross2(u, v):
    return u[0] * v[1] - u[1] * v[0]


def _inside_convex(p, poly, tol=1e-14):
    """p inside (or on) the CCW convex polygon."""
    n = len(poly)
    return all(_cross2(poly[(i + 1) % n] - poly[i], p - poly[i]) >= -tol for i in range(n))


def _convex_intersection(P, Q):
    """Vertices (CCW, unordered start) of the intersection of two CCW convex polygons."""
    pts = [p for p in P if _inside_convex(p, Q)] + [q for q in Q if _inside_convex(q, P)]
    for i in range(len(P)):
        a, b = P[i], P[(i + 1) % len(P)]
        for j in range(len(Q)):
            c, e = Q[j], Q[(j + 1) % len(Q)]
            M = np.column_stack([b - a, c - e])
            if abs(np.linalg.det(M)) < 1e-300:
                continue
            s, t = np.linalg.solve(M, c - a)
            if -1e-14 <= s <= 1 + 1e-14 and -1e-14 <= t <= 1 + 1e-14:
                pts.append(a + s * (b - a))
    if len(pts) < 3:
        return np.empty((0, 2))
    pts = np.array(pts)
    # drop exact / near duplicates
    keep = []
    for p in pts:
        if all(np.max(np.abs(p - k)) > 1e-14 for k in keep):
            keep.append(p)
    pts = np.array(keep)
    if len(pts) < 3:
        return np.empty((0, 2))
    c = pts.mean(axis=0)
    ang = np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0])
    return pts[np.argsort(ang)]


def _canonical(poly):
    """Canonical polygon (see :mod:`.segment`): drop collinear / duplicate vertices, rotate."""
    poly = [np.array(p, float) for p in poly]
    changed = True
    while changed and len(poly) >= 3:
        changed = False
        n = len(poly)
        for i in range(n):
            u = poly[i] - poly[i - 1]
            v = poly[(i + 1) % n] - poly[i]
            if abs(_cross2(u, v)) <= COLLINEAR_TOL:
                del poly[i]
                changed = True
                break
    if len(poly) < 3:
        return np.empty((0, 2))
    poly = np.array(poly)
    i0 = int(np.argmin(poly[:, 0] + KEY * poly[:, 1]))
    return np.roll(poly, -i0, axis=0)


def _points_2d(f, ftype_s, xs, Xs, ssign, ftype_m, xm, msign, cands, rule_pts, rule_w):
    tri_s = ftype_s in (TRIANGLE1, TRIANGLE2)
    vt = TRIANGLE1 if tri_s else QUAD1
    nv = 3 if tri_s else 4
    ref_area = 0.5 if tri_s else 1.0
    ref_poly = (
        np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
        if tri_s
        else np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    )
    tri_m = ftype_m in (TRIANGLE1, TRIANGLE2)
    order = [0, 1, 2] if tri_m else [0, 1, 3, 2]
    xv = xs[f, :nv]
    xic = _centre(vt)
    c, A = ref.surface(xv, vt, xic)
    n0 = np.cross(A[0], A[1])
    n0 /= np.linalg.norm(n0)
    Pn = np.eye(3) - np.outer(n0, n0)

    def to_xi(p):
        p = p - ((p - c) @ n0) * n0
        if tri_s:
            sol, *_ = np.linalg.lstsq(
                np.column_stack([xv[1] - xv[0], xv[2] - xv[0]]), p - xv[0], rcond=None
            )
            return sol
        z = xic.copy()
        for _ in range(50):
            S, At = ref.surface(xv, vt, z)
            step, *_ = np.linalg.lstsq(Pn @ At.T, Pn @ (S - p), rcond=None)
            if not np.all(np.isfinite(step)):
                break
            z = z - step
            if np.max(np.abs(step)) <= 1e-13:
                return z
            if np.max(np.abs(z)) > 1e8:
                break
        step, *_ = np.linalg.lstsq(Pn @ A.T, Pn @ (p - c), rcond=None)
        return xic + step

    out = []
    for m in cands:
        poly = np.array([to_xi(xm[m, i]) for i in order])
        a2 = sum(_cross2(poly[i], poly[(i + 1) % len(poly)]) for i in range(len(poly)))
        if not abs(a2) >= 2.0 * MIN_AREA * ref_area:
            continue
        if a2 < 0:
            poly = poly[::-1].copy()
        pieces = [poly]
        if len(poly) == 4:
            crs = [_cross2(poly[i] - poly[i - 1], poly[(i + 1) % 4] - poly[i]) for i in range(4)]
            neg = [i for i in range(4) if crs[i] < 0.0]
            if neg:
                r = neg[0]
                pieces = [poly[[r, (r + 1) % 4, (r + 2) % 4]], poly[[r, (r + 2) % 4, (r + 3) % 4]]]
        facing = None
        for piece in pieces:
            if len(piece) == 3 and _cross2(piece[1] - piece[0], piece[2] - piece[0]) <= 0.0:
                continue
            canon = _canonical(_convex_intersection(piece, ref_poly))
            if len(canon) < 3:
                continue
            if facing is None:
                xbar = np.array([sum(canon[:, 0] / len(canon)), sum(canon[:, 1] / len(canon))])
                facing = _faces(ftype_s, xs[f], ssign[f], ftype_m, xm[m], msign[m], xbar)
            if not facing:
                break
            v0 = canon[0]
            for i in range(1, len(canon) - 1):
                e1, e2 = canon[i] - v0, canon[i + 1] - v0
                jac = _cross2(e1, e2)
                if not 0.5 * jac >= MIN_AREA * ref_area:
                    continue
                for (r1, r2), w in zip(rule_pts, rule_w, strict=True):
                    xi = v0 + r1 * e1 + r2 * e2
                    out.append((xi, w * jac * _jacobian(Xs[f], ftype_s, xi), m))
    return out


def segment_points_reference(
    ftype_s, xs, Xs, ssign, ftype_m, xm, msign, cand_off, cand, rule_pts, rule_w, qp_xi, qp_w, qp_m
):
    """NumPy reference of :func:`.segment.segment_points` (same arguments, outputs, return)."""
    xs, Xs, xm = (np.asarray(a, float) for a in (xs, Xs, xm))
    rule_pts = np.asarray(rule_pts, float)
    nsf = xs.shape[0]
    nqmax = qp_w.shape[1]
    qp_xi[...] = 0.0
    qp_w[...] = 0.0
    qp_m[...] = -1
    count = np.zeros(nsf, dtype=np.int64)
    pts = _points_1d if ref.tdim(ftype_s) == 1 else _points_2d
    for f in range(nsf):
        cands = cand[cand_off[f] : cand_off[f + 1]]
        out = pts(f, ftype_s, xs, Xs, ssign, ftype_m, xm, msign, cands, rule_pts, rule_w)
        for j, (xi, w, m) in enumerate(out[:nqmax]):
            qp_xi[f, j] = xi
            qp_w[f, j] = w
            qp_m[f, j] = m
        count[f] = len(out) if len(out) <= nqmax else -len(out)
    return count
