r"""Segment-based mortar integration points (numba).

Element-based integration (:func:`dolfinx_mortar.kernels.mortar.pair_points`) projects a
fixed Gauss rule of the slave facet onto the master surface; the integrands of
:math:`\int \Phi_I\, g\, dA` and :math:`\int \Phi_I N_{master}\, dA` are then only
piecewise smooth over the facet (kinks where the projection jumps from one master facet
to the next), so the contact patch test passes only to quadrature accuracy. Segment-based
integration splits every slave facet into *segments*, each the overlap of the slave
facet with the projection of ONE master facet, and puts a separate Gauss rule on every
segment. With flat facets and polynomial integrands the mortar integrals are then exact
and the flat patch test passes to round-off on non-matching meshes (METHOD.md §7).

:func:`segment_points` only produces the points: slave reference coordinates, weights
(including the reference surface Jacobian J₀ of the slave facet) and the master facet
each point is paired with (forced pairing: the point's master projection is then
computed on that facet only, even if it falls marginally outside due to round-off).

Conventions
-----------
Facet type codes, node ordering (basix) and the normal ``unit_normal(x, ftype, sign,
xi, nu)`` are those of :mod:`dolfinx_mortar.kernels.shape` / :mod:`.gap`: d = 2 with
interval facets (k = 1), d = 3 with triangle / quadrilateral facets (k = 2). Slave and
master facets have the same topological dimension but may have different types
(e.g. triangle slave, quad master; P1 slave, P2 master).

Geometry (current configuration ``xs`` / ``xm``)
------------------------------------------------
2D (interval slave facets, P1 or P2)
    For a candidate master facet its two END nodes (``xm[m, 0]``, ``xm[m, 1]``) are
    mapped to the slave parameter by closest-point projection onto the (extrapolated)
    slave facet (:func:`.gap.project` with the slave facet as the surface; ξ is not
    restricted to [0, 1]). The segment is [min, max] ∩ [0, 1]; overlaps shorter than
    :data:`MIN_LENGTH` (reference units) are skipped. For a straight slave this is the
    orthogonal projection, and segments of a conforming master surface tile [0, 1]
    exactly. The master facet's own curvature (P2) does not enter: only its end nodes
    bound a segment.
3D (triangle / quadrilateral slave facets)
    The clipping uses the slave facet's VERTEX geometry (first 3 or 4 nodes, mapped
    affinely / bilinearly): centre c = x_v(ξ_c), unit normal n₀ at ξ_c, orthonormal
    in-plane basis (t₁, t₂). Every master VERTEX (first 3 or 4 nodes; quads in the
    cyclic order 0, 1, 3, 2) is projected along n₀ onto the plane and mapped to the
    slave reference plane by solving (x_v(ξ) - p)·t_α = 0 (α = 1, 2) with Newton's method
    (one step for triangles; if Newton fails for a bilinear slave, e.g. beyond a fold of
    the extrapolated map, the affine map of the centre tangents is used instead — a
    deterministic function of the vertex, so neighbouring master facets stay
    consistent). The master polygon is oriented counter-clockwise by its signed area
    (degenerate ones, |area| < :data:`MIN_AREA` × reference area, e.g. master facets
    seen edge-on, are skipped); a non-convex projected master quad is split into two
    triangles at its reflex vertex. Each convex piece is clipped against the slave
    reference element (unit triangle or unit square) by Sutherland–Hodgman, put in the
    canonical form below, triangulated as a fan from its first vertex, fan triangles with
    area < :data:`MIN_AREA` × reference area are skipped, and the rule (defined on the
    reference triangle) is mapped into every fan triangle.

    Canonical polygon: vertices whose two adjacent edges are collinear or that duplicate
    a neighbour (|cross(v_i - v_{i-1}, v_{i+1} - v_i)| <= :data:`COLLINEAR_TOL`) are
    removed one at a time (first such vertex in cyclic order, repeat), then the polygon
    is rotated to start at the vertex minimising ξ₁ + 0.618…·ξ₂ (a generic direction, so
    no ties for vertices lying on reference edges). The fan, hence the point set, then
    depends only on the clipped region and not on how the clipping was computed, which
    lets :mod:`.segment_reference` reproduce the points.

Facing test (both dimensions): a segment is kept only when n_s·ν_m < 0, with n_s the
slave unit normal (``ssign``) at the segment's midpoint / the polygon's vertex mean ξ̄,
and ν_m the master unit normal (``msign``) at the closest-point projection of x_s(ξ̄)
onto the master facet, clamped to the master reference facet.

Weights: ``qp_w = rule weight × |det ∂ξ/∂r| × J₀(ξ)`` with r the rule's reference cell
coordinates and J₀ the surface Jacobian of the slave facet in the REFERENCE configuration
``Xs`` (full, possibly P2 geometry) at ξ, i.e. integrals are over the reference slave
surface, as in element-based integration.

What is exact and what is approximate
-------------------------------------
* Exact (to round-off): flat slave facets with an affine parametrisation (P1 intervals,
  straight P2 intervals, triangles, parallelogram quads, P2 facets with straight edges
  and mid-edge nodes at the edge midpoints) against a conforming flat master surface
  (any facet shapes, any offset along the normal): the segments tile the covered part of
  the slave facet, and a polynomial integrand of degree <= the rule's degree (after
  multiplication by J₀ and the segment map) is integrated exactly. In 2D the segment
  boundaries are exact also for curved P2 slaves (closest-point definition).
* Approximate (3D): curved / warped slave facets (P2, non-planar bilinear) and
  non-parallelogram bilinear slave quads — segment boundaries are straight lines in the
  slave reference plane and are computed on the vertex geometry projected along one
  normal n₀, whereas the true boundaries are the (curved) preimages of the master edges.
  The segments still tile the slave facet (shared master vertices map to the same ξ), so
  Σ qp_w is still the area of the covered part; only the assignment of area near master
  edges to master facets is approximate. Curved master facets are represented by their
  vertex polygon in the same way.
* Not handled: overlapping projections of candidate master facets (non-conforming or
  folded master surfaces, both sides of a thin body among the candidates with a wrong
  ``msign``): every candidate that faces the slave contributes its full overlap, so
  overlapping parts are counted more than once. Self-intersecting (bow-tie) projected
  master quads are split at a reflex vertex and pieces of negative orientation dropped.

Buffer overflow
---------------
The caller preallocates ``qp_xi`` (nsf, nqmax, k), ``qp_w`` and ``qp_m`` (nsf, nqmax). When
a slave facet needs more than nqmax points, the first nqmax are written and
``count[f] = -needed`` is returned; the caller should enlarge nqmax to at least
``max(abs(count))`` and call again.
"""

import math

import numba
import numpy as np

from .gap import project, unit_normal
from .shape import (
    QUAD1,
    TRIANGLE1,
    TRIANGLE2,
    clamp_to_reference,
    num_nodes,
    reference_centre,
    shape,
    tdim,
)

#: Closest-point / inverse-map Newton tolerance (reference units) and iteration cap.
PROJ_TOL = 1.0e-13
PROJ_MAXIT = 50
#: 2D: overlaps shorter than this (slave reference units) are skipped.
MIN_LENGTH = 1.0e-14
#: 3D: polygons / fan triangles with area below MIN_AREA × reference facet area are skipped.
MIN_AREA = 1.0e-14
#: 3D: vertices with |cross(v_i - v_{i-1}, v_{i+1} - v_i)| <= this are removed.
COLLINEAR_TOL = 1.0e-13
#: 3D: direction (1, KEY) whose minimum selects the first polygon vertex.
KEY = 0.6180339887498949

# Sutherland-Hodgman buffer: each half-plane clip at most doubles the vertex count.
_POLY_MAX = 64


@numba.njit(cache=True)
def _emit(f, cnt, k, xi, w, m, qp_xi, qp_w, qp_m):
    """Write one point into slot ``cnt`` of facet f if it fits; return cnt + 1."""
    if cnt < qp_w.shape[1]:
        for a in range(k):
            qp_xi[f, cnt, a] = xi[a]
        qp_w[f, cnt] = w
        qp_m[f, cnt] = m
    return cnt + 1


@numba.njit(cache=True)
def _faces(ftype_s, xsf, ss, ftype_m, xmm, ms, xi):
    """Facing test n_s(xi)·nu_m(zeta) < 0, zeta = clamped projection of x_s(xi) on the master."""
    ns = xsf.shape[0]
    d = xsf.shape[1]
    ks = tdim(ftype_s)
    km = tdim(ftype_m)
    N = np.empty(ns)
    dN = np.empty((ns, ks))
    ddN = np.empty((ns, ks, ks))
    shape(ftype_s, xi, N, dN, ddN)
    x = np.zeros(d)
    for a in range(ns):
        for c in range(d):
            x[c] += N[a] * xsf[a, c]
    nus = np.empty(d)
    unit_normal(xsf, ftype_s, ss, xi, nus)
    z0 = np.full(km, np.nan)
    z = np.empty(km)
    project(x, xmm, ftype_m, z0, z, PROJ_TOL, PROJ_MAXIT)
    for a in range(km):
        if not math.isfinite(z[a]):
            reference_centre(ftype_m, z)
            break
    clamp_to_reference(ftype_m, z)
    num = np.empty(d)
    unit_normal(xmm, ftype_m, ms, z, num)
    dot = 0.0
    for c in range(d):
        dot += nus[c] * num[c]
    return dot < 0.0


@numba.njit(cache=True)
def _segments_1d(
    f,
    ftype_s,
    xs,
    Xs,
    ssign,
    ftype_m,
    xm,
    msign,
    cand_off,
    cand,
    rule_pts,
    rule_w,
    qp_xi,
    qp_w,
    qp_m,
):
    """Points of slave interval facet f (see module docstring); returns the number needed."""
    d = xs.shape[2]
    xsf = xs[f]
    Xsf = Xs[f]
    z0 = np.full(1, np.nan)
    t = np.empty(1)
    xi = np.empty(1)
    tmp = np.empty(d)
    cnt = 0
    for j in range(cand_off[f], cand_off[f + 1]):
        m = cand[j]
        project(xm[m, 0], xsf, ftype_s, z0, t, PROJ_TOL, PROJ_MAXIT)
        t0 = t[0]
        project(xm[m, 1], xsf, ftype_s, z0, t, PROJ_TOL, PROJ_MAXIT)
        t1 = t[0]
        if not (math.isfinite(t0) and math.isfinite(t1)):
            continue
        lo = max(min(t0, t1), 0.0)
        hi = min(max(t0, t1), 1.0)
        length = hi - lo
        if not (length > MIN_LENGTH):
            continue
        xi[0] = 0.5 * (lo + hi)
        if not _faces(ftype_s, xsf, ssign[f], ftype_m, xm[m], msign[m], xi):
            continue
        for q in range(rule_w.shape[0]):
            xi[0] = lo + length * rule_pts[q, 0]
            j0 = unit_normal(Xsf, ftype_s, 1.0, xi, tmp)
            cnt = _emit(f, cnt, 1, xi, rule_w[q] * length * j0, m, qp_xi, qp_w, qp_m)
    return cnt


@numba.njit(cache=True)
def _plane_map(vt, P, xi, N, dN, ddN, r, J):
    """Projected vertex map: r = sum_a N_a(xi) P_a (2,), J[i, alpha] = dr_i/dxi_alpha."""
    shape(vt, xi, N, dN, ddN)
    for i in range(2):
        s = 0.0
        s0 = 0.0
        s1 = 0.0
        for a in range(P.shape[0]):
            s += N[a] * P[a, i]
            s0 += dN[a, 0] * P[a, i]
            s1 += dN[a, 1] * P[a, i]
        r[i] = s
        J[i, 0] = s0
        J[i, 1] = s1


@numba.njit(cache=True)
def _invert_plane_map(vt, P, q, xic, Ainv, out):
    """xi with sum_a N_a(xi) P_a = q (Newton from the centre; affine fallback)."""
    nv = P.shape[0]
    N = np.empty(nv)
    dN = np.empty((nv, 2))
    ddN = np.empty((nv, 2, 2))
    r = np.empty(2)
    J = np.empty((2, 2))
    x0 = xic[0]
    x1 = xic[1]
    ok = False
    for _it in range(PROJ_MAXIT):
        out[0] = x0
        out[1] = x1
        _plane_map(vt, P, out, N, dN, ddN, r, J)
        det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
        if not (abs(det) > 0.0):
            break
        r0 = r[0] - q[0]
        r1 = r[1] - q[1]
        s0 = (J[1, 1] * r0 - J[0, 1] * r1) / det
        s1 = (-J[1, 0] * r0 + J[0, 0] * r1) / det
        if not (math.isfinite(s0) and math.isfinite(s1)):
            break
        x0 -= s0
        x1 -= s1
        if max(abs(s0), abs(s1)) <= PROJ_TOL:
            ok = True
            break
        if max(abs(x0), abs(x1)) > 1.0e8:
            break
    if ok:
        out[0] = x0
        out[1] = x1
    else:
        # affine map of the centre tangents (the centre maps to q = 0)
        out[0] = xic[0] + Ainv[0, 0] * q[0] + Ainv[0, 1] * q[1]
        out[1] = xic[1] + Ainv[1, 0] * q[0] + Ainv[1, 1] * q[1]


@numba.njit(cache=True)
def _signed_area2(poly, n):
    """Twice the signed area (shoelace) of the polygon poly[:n]."""
    s = 0.0
    for i in range(n):
        j = (i + 1) % n
        s += poly[i, 0] * poly[j, 1] - poly[j, 0] * poly[i, 1]
    return s


@numba.njit(cache=True)
def _clip_halfplane(inp, nin, out, ax, ay, bx, by):
    """Sutherland-Hodgman step: the part of polygon inp[:nin] left of the line a -> b."""
    nout = 0
    ex = bx - ax
    ey = by - ay
    for i in range(nin):
        ip = (i - 1 + nin) % nin
        cx = inp[i, 0]
        cy = inp[i, 1]
        px = inp[ip, 0]
        py = inp[ip, 1]
        dc = ex * (cy - ay) - ey * (cx - ax)
        dp = ex * (py - ay) - ey * (px - ax)
        if dc >= 0.0:
            if dp < 0.0:
                s = dp / (dp - dc)
                out[nout, 0] = px + s * (cx - px)
                out[nout, 1] = py + s * (cy - py)
                nout += 1
            out[nout, 0] = cx
            out[nout, 1] = cy
            nout += 1
        elif dp >= 0.0:
            s = dp / (dp - dc)
            out[nout, 0] = px + s * (cx - px)
            out[nout, 1] = py + s * (cy - py)
            nout += 1
    return nout


@numba.njit(cache=True)
def _clip_reference(vt, subj, nsub, buf_a, buf_b):
    """Clip the CCW polygon subj[:nsub] against the reference triangle / unit square.

    Returns (polygon array, vertex count); the result lives in buf_a or buf_b.
    """
    if vt == TRIANGLE1:
        cx = np.array([0.0, 1.0, 0.0])
        cy = np.array([0.0, 0.0, 1.0])
    else:
        cx = np.array([0.0, 1.0, 1.0, 0.0])
        cy = np.array([0.0, 0.0, 1.0, 1.0])
    nc = cx.shape[0]
    for i in range(nsub):
        buf_a[i, 0] = subj[i, 0]
        buf_a[i, 1] = subj[i, 1]
    n = nsub
    src = buf_a
    dst = buf_b
    for e in range(nc):
        if n == 0:
            break
        e1 = (e + 1) % nc
        n = _clip_halfplane(src, n, dst, cx[e], cy[e], cx[e1], cy[e1])
        src, dst = dst, src
    return src, n


@numba.njit(cache=True)
def _canonical(poly, n, out):
    """Canonical form (module docstring) of the convex CCW polygon poly[:n] into out.

    Returns the vertex count (< 3: empty polygon).
    """
    tmp = np.empty((n, 2))
    for i in range(n):
        tmp[i, 0] = poly[i, 0]
        tmp[i, 1] = poly[i, 1]
    changed = True
    while changed and n >= 3:
        changed = False
        for i in range(n):
            ip = (i - 1 + n) % n
            iq = (i + 1) % n
            ux = tmp[i, 0] - tmp[ip, 0]
            uy = tmp[i, 1] - tmp[ip, 1]
            vx = tmp[iq, 0] - tmp[i, 0]
            vy = tmp[iq, 1] - tmp[i, 1]
            if abs(ux * vy - uy * vx) <= COLLINEAR_TOL:
                for l in range(i, n - 1):
                    tmp[l, 0] = tmp[l + 1, 0]
                    tmp[l, 1] = tmp[l + 1, 1]
                n -= 1
                changed = True
                break
    if n < 3:
        return n
    i0 = 0
    best = tmp[0, 0] + KEY * tmp[0, 1]
    for i in range(1, n):
        v = tmp[i, 0] + KEY * tmp[i, 1]
        if v < best:
            best = v
            i0 = i
    for i in range(n):
        out[i, 0] = tmp[(i0 + i) % n, 0]
        out[i, 1] = tmp[(i0 + i) % n, 1]
    return n


@numba.njit(cache=True)
def _segments_2d(
    f,
    ftype_s,
    xs,
    Xs,
    ssign,
    ftype_m,
    xm,
    msign,
    cand_off,
    cand,
    rule_pts,
    rule_w,
    qp_xi,
    qp_w,
    qp_m,
):
    """Points of slave triangle / quad facet f (see module docstring); returns the number needed."""
    d = 3
    xsf = xs[f]
    Xsf = Xs[f]
    tri_s = ftype_s == TRIANGLE1 or ftype_s == TRIANGLE2
    vt = TRIANGLE1 if tri_s else QUAD1
    nv = 3 if tri_s else 4
    ref_area = 0.5 if tri_s else 1.0
    tri_m = ftype_m == TRIANGLE1 or ftype_m == TRIANGLE2
    nvm = 3 if tri_m else 4
    order = np.array([0, 1, 2]) if tri_m else np.array([0, 1, 3, 2])

    # vertex geometry of the slave facet: centre, normal, in-plane basis, projected vertices
    xv = np.empty((nv, d))
    for a in range(nv):
        for c in range(d):
            xv[a, c] = xsf[a, c]
    N = np.empty(nv)
    dN = np.empty((nv, 2))
    ddN = np.empty((nv, 2, 2))
    xic = np.empty(2)
    reference_centre(vt, xic)
    shape(vt, xic, N, dN, ddN)
    cen = np.zeros(d)
    a1 = np.zeros(d)
    a2 = np.zeros(d)
    for a in range(nv):
        for c in range(d):
            cen[c] += N[a] * xv[a, c]
            a1[c] += dN[a, 0] * xv[a, c]
            a2[c] += dN[a, 1] * xv[a, c]
    n0 = np.empty(d)
    n0[0] = a1[1] * a2[2] - a1[2] * a2[1]
    n0[1] = a1[2] * a2[0] - a1[0] * a2[2]
    n0[2] = a1[0] * a2[1] - a1[1] * a2[0]
    nn = math.sqrt(n0[0] ** 2 + n0[1] ** 2 + n0[2] ** 2)
    la = math.sqrt(a1[0] ** 2 + a1[1] ** 2 + a1[2] ** 2)
    t1 = np.empty(d)
    t2 = np.empty(d)
    for c in range(d):
        n0[c] /= nn
        t1[c] = a1[c] / la
    t2[0] = n0[1] * t1[2] - n0[2] * t1[1]
    t2[1] = n0[2] * t1[0] - n0[0] * t1[2]
    t2[2] = n0[0] * t1[1] - n0[1] * t1[0]
    P = np.empty((nv, 2))
    for a in range(nv):
        s1 = 0.0
        s2 = 0.0
        for c in range(d):
            s1 += (xv[a, c] - cen[c]) * t1[c]
            s2 += (xv[a, c] - cen[c]) * t2[c]
        P[a, 0] = s1
        P[a, 1] = s2
    # affine fallback of the inverse map: inverse of the projected centre tangents
    r = np.empty(2)
    J = np.empty((2, 2))
    _plane_map(vt, P, xic, N, dN, ddN, r, J)
    det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
    Ainv = np.empty((2, 2))
    Ainv[0, 0] = J[1, 1] / det
    Ainv[1, 1] = J[0, 0] / det
    Ainv[0, 1] = -J[0, 1] / det
    Ainv[1, 0] = -J[1, 0] / det

    mpoly = np.empty((4, 2))
    subj = np.empty((4, 2))
    buf_a = np.empty((_POLY_MAX, 2))
    buf_b = np.empty((_POLY_MAX, 2))
    canon = np.empty((_POLY_MAX, 2))
    q = np.empty(2)
    xi = np.empty(2)
    xbar = np.empty(2)
    tmp = np.empty(d)
    cnt = 0
    for j in range(cand_off[f], cand_off[f + 1]):
        m = cand[j]
        # master vertex polygon in the slave reference plane
        for i in range(nvm):
            node = order[i]
            s1 = 0.0
            s2 = 0.0
            for c in range(d):
                s1 += (xm[m, node, c] - cen[c]) * t1[c]
                s2 += (xm[m, node, c] - cen[c]) * t2[c]
            q[0] = s1
            q[1] = s2
            _invert_plane_map(vt, P, q, xic, Ainv, xi)
            mpoly[i, 0] = xi[0]
            mpoly[i, 1] = xi[1]
        area2 = _signed_area2(mpoly, nvm)
        if not (abs(area2) >= 2.0 * MIN_AREA * ref_area):
            continue
        if area2 < 0.0:
            for i in range(nvm // 2):
                i2 = nvm - 1 - i
                for c in range(2):
                    v = mpoly[i, c]
                    mpoly[i, c] = mpoly[i2, c]
                    mpoly[i2, c] = v
        # convex pieces: the polygon itself, or two triangles split at a reflex vertex
        reflex = -1
        if nvm == 4:
            for i in range(4):
                ip = (i + 3) % 4
                iq = (i + 1) % 4
                cr = (mpoly[i, 0] - mpoly[ip, 0]) * (mpoly[iq, 1] - mpoly[i, 1]) - (
                    mpoly[i, 1] - mpoly[ip, 1]
                ) * (mpoly[iq, 0] - mpoly[i, 0])
                if cr < 0.0:
                    reflex = i
                    break
        npieces = 1 if reflex < 0 else 2
        facing = -1  # unknown yet
        for piece in range(npieces):
            if reflex < 0:
                nsub = nvm
                for i in range(nvm):
                    subj[i, 0] = mpoly[i, 0]
                    subj[i, 1] = mpoly[i, 1]
            else:
                nsub = 3
                for i in range(3):
                    src = (reflex + piece + i) % 4 if i > 0 else reflex
                    subj[i, 0] = mpoly[src, 0]
                    subj[i, 1] = mpoly[src, 1]
                if _signed_area2(subj, 3) <= 0.0:
                    continue
            poly, npoly = _clip_reference(vt, subj, nsub, buf_a, buf_b)
            if npoly < 3:
                continue
            nc = _canonical(poly, npoly, canon)
            if nc < 3:
                continue
            if facing < 0:
                xbar[0] = 0.0
                xbar[1] = 0.0
                for i in range(nc):
                    xbar[0] += canon[i, 0] / nc
                    xbar[1] += canon[i, 1] / nc
                facing = 1 if _faces(ftype_s, xsf, ssign[f], ftype_m, xm[m], msign[m], xbar) else 0
            if facing == 0:
                break
            v0x = canon[0, 0]
            v0y = canon[0, 1]
            for i in range(1, nc - 1):
                e1x = canon[i, 0] - v0x
                e1y = canon[i, 1] - v0y
                e2x = canon[i + 1, 0] - v0x
                e2y = canon[i + 1, 1] - v0y
                jac = e1x * e2y - e1y * e2x
                if not (0.5 * jac >= MIN_AREA * ref_area):
                    continue
                for qq in range(rule_w.shape[0]):
                    r1 = rule_pts[qq, 0]
                    r2 = rule_pts[qq, 1]
                    xi[0] = v0x + r1 * e1x + r2 * e2x
                    xi[1] = v0y + r1 * e1y + r2 * e2y
                    j0 = unit_normal(Xsf, ftype_s, 1.0, xi, tmp)
                    cnt = _emit(f, cnt, 2, xi, rule_w[qq] * jac * j0, m, qp_xi, qp_w, qp_m)
    return cnt


@numba.njit(cache=True)
def segment_points(
    ftype_s, xs, Xs, ssign, ftype_m, xm, msign, cand_off, cand, rule_pts, rule_w, qp_xi, qp_w, qp_m
):
    """Segment-based integration points of all slave facets (see the module docstring).

    Parameters
    ----------
    ftype_s, ftype_m : int
        Slave / master facet type codes (same topological dimension k).
    xs, Xs : float64 (nsf, ns, d)
        Current / reference slave facet node coordinates (basix order), d = k + 1.
    ssign : float64 (nsf,)
        ±1: ``unit_normal(xs[f], ftype_s, ssign[f], xi, nu)`` is the slave outward normal.
    xm : float64 (nmf, nm, d)
        Current master facet node coordinates.
    msign : float64 (nmf,)
        ±1 making the master normal outward.
    cand_off : int64 (nsf + 1,), cand : int64 (ncand,)
        Candidate master facets of slave facet f: ``cand[cand_off[f]:cand_off[f + 1]]``.
    rule_pts : float64 (nr, k), rule_w : float64 (nr,)
        Quadrature rule on the reference segment cell: [0, 1] (k = 1) or the reference
        triangle {r >= 0, r1 + r2 <= 1} (k = 2, weights summing to 1/2).
    qp_xi : float64 (nsf, nqmax, k)
        Output: slave reference coordinates of the points (0 in unused slots).
    qp_w : float64 (nsf, nqmax)
        Output: rule weight × |segment map Jacobian| × J₀(ξ) (0 in unused slots).
    qp_m : int64 (nsf, nqmax)
        Output: the master facet (index into xm) of each point (-1 in unused slots).

    Returns
    -------
    int64 (nsf,)
        Number of points of each facet; ``-needed`` when needed > nqmax (then only the
        first nqmax points were written: call again with nqmax >= max(abs(count))).
    """
    nsf = xs.shape[0]
    k = tdim(ftype_s)
    if tdim(ftype_m) != k:
        raise ValueError("slave and master facets must have the same dimension")
    if xs.shape[1] != num_nodes(ftype_s) or xs.shape[2] != k + 1:
        raise ValueError("xs must have shape (nsf, num_nodes(ftype_s), tdim + 1)")
    if Xs.shape[0] != nsf or Xs.shape[1] != xs.shape[1] or Xs.shape[2] != xs.shape[2]:
        raise ValueError("Xs must have the shape of xs")
    if xm.shape[1] != num_nodes(ftype_m) or xm.shape[2] != k + 1:
        raise ValueError("xm must have shape (nmf, num_nodes(ftype_m), tdim + 1)")
    if rule_pts.shape[1] != k or rule_pts.shape[0] != rule_w.shape[0]:
        raise ValueError("rule_pts must have shape (nr, tdim) and rule_w (nr,)")
    if qp_xi.shape[0] != nsf or qp_w.shape[0] != nsf or qp_m.shape[0] != nsf:
        raise ValueError("output arrays must have nsf rows")
    if qp_xi.shape[2] != k or qp_xi.shape[1] != qp_w.shape[1] or qp_m.shape[1] != qp_w.shape[1]:
        raise ValueError("qp_xi must be (nsf, nqmax, tdim), qp_w and qp_m (nsf, nqmax)")
    nqmax = qp_w.shape[1]
    count = np.zeros(nsf, dtype=np.int64)
    for f in range(nsf):
        for j in range(nqmax):
            qp_w[f, j] = 0.0
            qp_m[f, j] = -1
            for a in range(k):
                qp_xi[f, j, a] = 0.0
        if k == 1:
            cnt = _segments_1d(
                f,
                ftype_s,
                xs,
                Xs,
                ssign,
                ftype_m,
                xm,
                msign,
                cand_off,
                cand,
                rule_pts,
                rule_w,
                qp_xi,
                qp_w,
                qp_m,
            )
        else:
            cnt = _segments_2d(
                f,
                ftype_s,
                xs,
                Xs,
                ssign,
                ftype_m,
                xm,
                msign,
                cand_off,
                cand,
                rule_pts,
                rule_w,
                qp_xi,
                qp_w,
                qp_m,
            )
        count[f] = cnt if cnt <= nqmax else -cnt
    return count


@numba.njit(cache=True)
def segment_end_derivatives(ftype_s, xs, Xs, xm, qp_xi, qp_w, qp_m, dxi, dw):
    r"""2D: derivatives of the segment points ξ_q and weights w_q with respect to the local
    dofs [slave facet nodes, master facet nodes] (× d) of each paired point.

    Rows are the paired points (qp_m >= 0) in (facet, point) order, as in
    :func:`dolfinx_mortar.kernels.mortar.contact_terms`. A segment of slave facet f on
    master facet m is [lo, hi] = [max(min(t₀, t₁), 0), min(max(t₀, t₁), 1)], with t_e the
    closest-point parameter of the master END node x_e on the slave facet,
    (x_s(t_e) − x_e)·x_s'(t_e) = 0 (see the module docstring), so that

        dt_e = −[(x_s − x_e)·δx_s'(t_e) + (δx_s(t_e) − δx_e)·x_s'(t_e)]
               / [x_s'·x_s' + (x_s − x_e)·x_s''],

    both end nodes being dofs of the point's own master facet. A point
    ξ = lo + r (hi − lo) with weight w = ŵ (hi − lo) J₀(ξ) (J₀ on the reference facet Xs)
    moves by

        dξ = (1 − r) dlo + r dhi,    dw = w [(dhi − dlo)/(hi − lo) + (J₀'/J₀)(ξ) dξ];

    a clamped end (0 or 1) does not move.

    Inputs: xs, Xs (nsf, ns, d) current / reference slave nodes (interval facets), xm
    (nmf, nm, d) current master nodes, qp_xi (nsf, nq, 1), qp_w, qp_m (nsf, nq) from
    :func:`segment_points` at the same xs, xm. Outputs dxi, dw (n_paired, (ns + nm)·d).
    """
    nsf, ns, d = xs.shape
    nm = xm.shape[1]
    nloc = (ns + nm) * d
    N = np.empty(ns)
    dN = np.empty((ns, 1))
    ddN = np.empty((ns, 1, 1))
    z0 = np.full(1, np.nan)
    t = np.empty(1)
    dt = np.zeros((2, nloc))
    tt = np.zeros(2)
    xv = np.empty(d)
    xp = np.empty(d)
    xpp = np.empty(d)
    row = -1
    for f in range(nsf):
        for q in range(qp_w.shape[1]):
            m = qp_m[f, q]
            if m < 0:
                continue
            row += 1
            for e in range(2):
                project(xm[m, e], xs[f], ftype_s, z0, t, PROJ_TOL, PROJ_MAXIT)
                tt[e] = t[0]
                shape(ftype_s, t, N, dN, ddN)
                for c in range(d):
                    xv[c] = 0.0
                    xp[c] = 0.0
                    xpp[c] = 0.0
                    for a in range(ns):
                        xv[c] += N[a] * xs[f, a, c]
                        xp[c] += dN[a, 0] * xs[f, a, c]
                        xpp[c] += ddN[a, 0, 0] * xs[f, a, c]
                den = 0.0
                for c in range(d):
                    den += xp[c] * xp[c] + (xv[c] - xm[m, e, c]) * xpp[c]
                for j in range(nloc):
                    dt[e, j] = 0.0
                for a in range(ns):
                    for c in range(d):
                        dt[e, a * d + c] = -((xv[c] - xm[m, e, c]) * dN[a, 0] + N[a] * xp[c]) / den
                for c in range(d):
                    dt[e, (ns + e) * d + c] = xp[c] / den
            ilo = 0 if tt[0] <= tt[1] else 1
            ihi = 1 - ilo
            lo, hi = tt[ilo], tt[ihi]
            lo_moves, hi_moves = lo > 0.0, hi < 1.0
            lo, hi = max(lo, 0.0), min(hi, 1.0)
            length = hi - lo
            r = (qp_xi[f, q, 0] - lo) / length
            shape(ftype_s, qp_xi[f, q], N, dN, ddN)
            j0 = 0.0
            dj0 = 0.0
            for c in range(d):
                xp[c] = 0.0
                xpp[c] = 0.0
                for a in range(ns):
                    xp[c] += dN[a, 0] * Xs[f, a, c]
                    xpp[c] += ddN[a, 0, 0] * Xs[f, a, c]
                j0 += xp[c] * xp[c]
                dj0 += xp[c] * xpp[c]
            j0 = math.sqrt(j0)
            dj0 /= j0
            for j in range(nloc):
                dlo = dt[ilo, j] if lo_moves else 0.0
                dhi = dt[ihi, j] if hi_moves else 0.0
                dx = (1.0 - r) * dlo + r * dhi
                dxi[row, j] = dx
                dw[row, j] = qp_w[f, q] * ((dhi - dlo) / length + dj0 / j0 * dx)
