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

Facing test (both dimensions): a segment is kept only when n_s·ν_m < −cos θ_max
(:func:`.gap.faces`, θ_max = :data:`.gap.MAX_FACING_ANGLE` = 85°, the rule of element
integration's pairing too), with n_s the slave unit normal (``ssign``) at the segment's
midpoint / the polygon's vertex mean ξ̄, and ν_m the master unit normal (``msign``) at
the closest-point projection of x_s(ξ̄) onto the master facet, clamped to the master
reference facet. A master facet at right angles to the slave (a side of the master
body) projects onto a thin sliver of the slave facet and, tilted towards the slave by
the load, was counted there as well as the master's top above it.

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

Derivatives
-----------
:func:`segment_derivatives` recomputes the points with their derivatives with respect to
the local dofs [slave facet nodes, master facet nodes] carried forward (forward-mode
differentiation of the same code path, so the points are identical): in 2D through the
closest-point parameters of the master end nodes, in 3D through the slave frame (c, n₀,
t₁, t₂), the inverse vertex map, the Sutherland–Hodgman intersections, the canonical
form and the fan. The discrete choices (which candidates face, which vertices are
clipped or dropped as collinear, clamped segment ends) are piecewise constant and not
differentiated. Checked against central differences of :func:`segment_points`
(``tests/test_kernels_segment.py``).

Buffer overflow
---------------
The caller preallocates ``qp_xi`` (nsf, nqmax, k), ``qp_w`` and ``qp_m`` (nsf, nqmax). When
a slave facet needs more than nqmax points, the first nqmax are written and
``count[f] = -needed`` is returned; the caller should enlarge nqmax to at least
``max(abs(count))`` and call again.
"""

import math

import numpy as np

from ._numba import numba
from .gap import faces, project, unit_normal
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
#: Derivatives: a segment end (2D) within this distance (reference units) of the slave
#: facet's end counts as clamped there and does not move; a polygon vertex (3D) that close
#: to a reference edge counts as lying on it and only slides along it (where both surfaces
#: end together; :func:`_clip_halfplane`).
ON_EDGE_TOL = 1.0e-10

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
    """Facing test n_s(xi)·nu_m(zeta) < −cos θ_max (:func:`.gap.faces`), zeta = clamped projection
    of x_s(xi) on the master."""
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
    project(x, xmm, ftype_m, z0, z, PROJ_TOL, np.int64(PROJ_MAXIT))
    for a in range(km):
        if not math.isfinite(z[a]):
            reference_centre(ftype_m, z)
            break
    clamp_to_reference(ftype_m, z)
    num = np.empty(d)
    unit_normal(xmm, ftype_m, ms, z, num)
    return faces(nus, num)


@numba.njit(cache=True)
def _end_derivative(ftype_s, xsf, xe, t, node, dt):
    """dt (nloc,) of the closest-point parameter t of the master node ``xe`` (local master
    node ``node``) on the slave interval xsf, (x_s(t) − x_e)·x_s'(t) = 0:

        dt = −[(x_s − x_e)·δx_s'(t) + (δx_s(t) − δx_e)·x_s'(t)] / [x_s'·x_s' + (x_s − x_e)·x_s''].
    """
    ns, d = xsf.shape
    N = np.empty(ns)
    dN = np.empty((ns, 1))
    ddN = np.empty((ns, 1, 1))
    tt = np.empty(1)
    tt[0] = t
    shape(ftype_s, tt, N, dN, ddN)
    xv = np.zeros(d)
    xp = np.zeros(d)
    xpp = np.zeros(d)
    for c in range(d):
        for a in range(ns):
            xv[c] += N[a] * xsf[a, c]
            xp[c] += dN[a, 0] * xsf[a, c]
            xpp[c] += ddN[a, 0, 0] * xsf[a, c]
    den = 0.0
    for c in range(d):
        den += xp[c] * xp[c] + (xv[c] - xe[c]) * xpp[c]
    for j in range(dt.size):
        dt[j] = 0.0
    for a in range(ns):
        for c in range(d):
            dt[a * d + c] = -((xv[c] - xe[c]) * dN[a, 0] + N[a] * xp[c]) / den
    for c in range(d):
        dt[(ns + node) * d + c] = xp[c] / den


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
    row0,
    dxi,
    dw,
):
    """Points of slave interval facet f (see module docstring); returns the number needed.

    With non-empty ``dxi`` (rows, 1, nloc) and ``dw`` (rows, nloc), also the derivatives of
    each point with respect to its local dofs, point n of the facet in row ``row0 + n``: a
    point ξ = lo + r (hi − lo) with weight w = ŵ (hi − lo) J₀(ξ) moves with the segment
    ends (:func:`_end_derivative`; a clamped end, 0 or 1, or one within ON_EDGE_TOL of it,
    does not move),

        dξ = (1 − r) dlo + r dhi,    dw = w [(dhi − dlo)/(hi − lo) + (J₀'/J₀)(ξ) dξ].
    """
    d = xs.shape[2]
    xsf = xs[f]
    Xsf = Xs[f]
    ns = xsf.shape[0]
    want = dxi.shape[0] > 0
    nd = (ns + xm.shape[1]) * d if want else 0
    dt = np.zeros((2, nd))
    ilo = 0
    lo_moves = hi_moves = False
    N = np.empty(ns)
    dN = np.empty((ns, 1))
    ddN = np.empty((ns, 1, 1))
    z0 = np.full(1, np.nan)
    t = np.empty(1)
    xi = np.empty(1)
    tmp = np.empty(d)
    cnt = 0
    for j in range(cand_off[f], cand_off[f + 1]):
        m = cand[j]
        project(xm[m, 0], xsf, ftype_s, z0, t, PROJ_TOL, np.int64(PROJ_MAXIT))
        t0 = t[0]
        project(xm[m, 1], xsf, ftype_s, z0, t, PROJ_TOL, np.int64(PROJ_MAXIT))
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
        if want:
            _end_derivative(ftype_s, xsf, xm[m, 0], t0, np.int64(0), dt[0])
            _end_derivative(ftype_s, xsf, xm[m, 1], t1, np.int64(1), dt[1])
            ilo = 0 if t0 <= t1 else 1
            lo_moves = min(t0, t1) > ON_EDGE_TOL
            hi_moves = max(t0, t1) < 1.0 - ON_EDGE_TOL
        for q in range(rule_w.shape[0]):
            r = rule_pts[q, 0]
            xi[0] = lo + length * r
            j0 = unit_normal(Xsf, ftype_s, 1.0, xi, tmp)
            w = rule_w[q] * length * j0
            if want and cnt < qp_w.shape[1] and row0 + cnt < dxi.shape[0]:
                # (J₀'/J₀)(ξ) on the reference facet: J₀ = |X'|, J₀' = X'·X''/J₀
                shape(ftype_s, xi, N, dN, ddN)
                j1 = 0.0
                for c in range(d):
                    xp = 0.0
                    xpp = 0.0
                    for a in range(ns):
                        xp += dN[a, 0] * Xsf[a, c]
                        xpp += ddN[a, 0, 0] * Xsf[a, c]
                    j1 += xp * xpp
                j1 /= j0 * j0
                row = row0 + cnt
                for jj in range(nd):
                    dlo = dt[ilo, jj] if lo_moves else 0.0
                    dhi = dt[1 - ilo, jj] if hi_moves else 0.0
                    dx = (1.0 - r) * dlo + r * dhi
                    dxi[row, 0, jj] = dx
                    dw[row, jj] = w * ((dhi - dlo) / length + j1 * dx)
            cnt = _emit(f, cnt, 1, xi, w, m, qp_xi, qp_w, qp_m)
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
    """xi with sum_a N_a(xi) P_a = q (Newton from the centre; affine fallback).

    Returns True when Newton converged, False when the affine fallback was taken."""
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
    return ok


@numba.njit(cache=True)
def _signed_area2(poly, n):
    """Twice the signed area (shoelace) of the polygon poly[:n]."""
    s = 0.0
    for i in range(n):
        j = (i + 1) % n
        s += poly[i, 0] * poly[j, 1] - poly[j, 0] * poly[i, 1]
    return s


@numba.njit(cache=True)
def _cut(inp, din, ip, i, s, ds, out, dout, nout):
    """out[nout] = inp[ip] + s (inp[i] − inp[ip]) and, when derivatives are carried
    (din non-empty), its derivative from those of the two vertices and ds."""
    for c in range(2):
        out[nout, c] = inp[ip, c] + s * (inp[i, c] - inp[ip, c])
    if din.shape[0]:
        for c in range(2):
            e = inp[i, c] - inp[ip, c]
            for j in range(din.shape[2]):
                dout[nout, c, j] = din[ip, c, j] + s * (din[i, c, j] - din[ip, c, j]) + ds[j] * e


@numba.njit(cache=True)
def _copy_vertex(inp, din, i, out, dout, nout):
    out[nout, 0] = inp[i, 0]
    out[nout, 1] = inp[i, 1]
    if din.shape[0]:
        dout[nout] = din[i]


@numba.njit(cache=True)
def _on_line_motion(inp, din, nin, k, dout, nout, ax, ay, ex, ey, el, w):
    """dout[nout] += w u, u the motion of vertex k of inp[:nin], on the line
    a + t (ex, ey) (within ON_EDGE_TOL |e|, el = |e|), where the vertex is kept or
    replaced by a cut that coincides with it: the one-sided derivative of the clipped
    polygon for the vertex moving OUT of the half-plane (see :func:`_clip_halfplane`).
    Its neighbours k − 1 and k + 1 decide: both inside (beyond ON_EDGE_TOL), the polygon
    only touches the line there and u is the full motion; one inside, the vertex moving
    out is replaced by the cut of the edge to that neighbour, which slides along the line
    as that edge crosses it (the projection along the edge, not the orthogonal one
    unless the edge is perpendicular to the line); none inside, the orthogonal
    projection (a degenerate polygon)."""
    q = -1
    nq = 0
    for kk in ((k - 1 + nin) % nin, (k + 1) % nin):
        if ex * (inp[kk, 1] - ay) - ey * (inp[kk, 0] - ax) > ON_EDGE_TOL * el:
            q = kk
            nq += 1
    if nq == 1:
        tx = inp[q, 0] - inp[k, 0]
        ty = inp[q, 1] - inp[k, 1]
    else:
        tx = -ey
        ty = ex
    den = ex * ty - ey * tx  # δ_q − δ_k > 0
    for j in range(dout.shape[2]):
        t = 0.0 if nq == 2 else (ex * din[k, 1, j] - ey * din[k, 0, j]) / den
        dout[nout, 0, j] += w * (din[k, 0, j] - t * tx)
        dout[nout, 1, j] += w * (din[k, 1, j] - t * ty)


@numba.njit(cache=True)
def _on_edge(x, y, refx, refy, l):
    """Whether the point (x, y) lies on the line of reference edge l (from corner l to
    corner l + 1 of the reference polygon refx, refy), within ON_EDGE_TOL as in
    :func:`_clip_halfplane`."""
    l1 = (l + 1) % refx.shape[0]
    ex = refx[l1] - refx[l]
    ey = refy[l1] - refy[l]
    return abs(ex * (y - refy[l]) - ey * (x - refx[l])) <= ON_EDGE_TOL * math.sqrt(
        ex * ex + ey * ey
    )


@numba.njit(cache=True)
def _corner_edge(x, y, refx, refy, e):
    """For a point (x, y) on reference edge e: the other reference edge it also lies on
    (:func:`_on_edge`; the point is then a corner of the slave facet), or -1."""
    for l in range(refx.shape[0]):
        if l != e and _on_edge(x, y, refx, refy, l):
            return l
    return -1


@numba.njit(cache=True)
def _clip_halfplane(inp, din, nin, out, dout, refx, refy, e, ds):
    """Sutherland-Hodgman step: the part of polygon inp[:nin] left of the line a -> b,
    a = (refx[e], refy[e]), b the next corner: reference edge e of the reference polygon
    (refx, refy).

    The line is fixed (a reference-element edge). With a non-empty ``din`` (nin, 2, nloc)
    the vertex derivatives are carried into ``dout``: an intersection point
    v = v_p + s (v_c − v_p), s = δ_p / (δ_p − δ_c), δ = e × (v − a), moves by
    dv_p + s (dv_c − dv_p) + ds (v_c − v_p) with ds = (δ_p dδ_c − δ_c dδ_p) / (δ_p − δ_c)²;
    ``ds`` (nloc,) is scratch.

    A kept vertex ON the line (δ ≤ ON_EDGE_TOL |e|: a master vertex on the slave facet's
    edge, as where the two surfaces end together) may sit on a kink of the clipped
    region: moving out, it is clipped; moving in, the region shrinks. Of the two
    one-sided derivatives the first is taken, in every pair alike, so that the pairs
    add up to the exact derivative wherever their sum is differentiable
    (:func:`_on_line_motion`): the vertex moves as the crossing of the line with its
    polygon edge to the neighbour inside the half-plane (the projection of dv onto the
    line along that edge), with its full motion where both neighbours are inside (the
    polygon only touches the line) and slid orthogonally where none is. The orthogonal
    slide (dv − n (n·dv), n the edge normal) taken before for every such vertex adds up
    right only where the master surface continues across the line: along a master
    BOUNDARY edge that crosses the line obliquely (in reference coordinates) the covered
    region's corner moved wrongly. A master edge lying ON the line (both
    |δ| ≤ ON_EDGE_TOL |e|) makes s a ratio of round-off: its intersection point gets
    ds = 0 and moves as its end vertices do (weighted by s).

    A vertex of the output on the line that also lies on another reference edge
    (:func:`_corner_edge`) is a corner of the slave facet and is fixed (zero derivative):
    a vertex on a slave edge may only slide along it, and at a corner along both. The
    per-line rules above do not give that by themselves where the two edges are not
    perpendicular (at the ends of the triangle's hypotenuse): a kept vertex slid along
    one edge and then along the other keeps a part of its motion, and a master edge
    lying on a LATER edge's line is cut here with its full motion (that line's rule has
    not been applied to it yet), so the corner moves along this line. Either way the
    covered region would grow or shrink at a corner that the neighbouring segments
    cover with a fixed corner. The one exception keeps the generic derivatives bit for
    bit: the cut of an edge lying on an EARLIER reference edge's line (a master facet
    covering the corner: the cut of its clipped boundary) is left as computed, as its
    end points only slide along that line and the cut is fixed up to round-off.
    """
    e1 = (e + 1) % refx.shape[0]
    ax = refx[e]
    ay = refy[e]
    bx = refx[e1]
    by = refy[e1]
    nout = 0
    ex = bx - ax
    ey = by - ay
    el = math.sqrt(ex * ex + ey * ey)
    want = din.shape[0] > 0
    for i in range(nin):
        ip = (i - 1 + nin) % nin
        cx = inp[i, 0]
        cy = inp[i, 1]
        px = inp[ip, 0]
        py = inp[ip, 1]
        dc = ex * (cy - ay) - ey * (cx - ax)
        dp = ex * (py - ay) - ey * (px - ax)
        cut = (dc >= 0.0 and dp < 0.0) or (dc < 0.0 and dp >= 0.0)
        if cut:
            s = dp / (dp - dc)
            along = max(abs(dp), abs(dc)) <= ON_EDGE_TOL * el  # the edge lies on the line
            if want:
                den = (dp - dc) * (dp - dc)
                for j in range(din.shape[2]):
                    ddc = ex * din[i, 1, j] - ey * din[i, 0, j]
                    ddp = ex * din[ip, 1, j] - ey * din[ip, 0, j]
                    ds[j] = 0.0 if along else (dp * ddc - dc * ddp) / den
            _cut(inp, din, ip, i, s, ds, out, dout, nout)
            if want:
                l = _corner_edge(out[nout, 0], out[nout, 1], refx, refy, e)
                if l >= 0 and not (
                    l < e and _on_edge(px, py, refx, refy, l) and _on_edge(cx, cy, refx, refy, l)
                ):
                    dout[nout] = 0.0
                elif along:
                    # a cut at a round-off ratio along the edge: it moves as the end
                    # vertices on the line do (weighted by where it lies), since the
                    # canonical form may keep it for the end vertex it coincides with
                    dout[nout] = 0.0
                    _on_line_motion(inp, din, nin, ip, dout, nout, ax, ay, ex, ey, el, 1.0 - s)
                    _on_line_motion(inp, din, nin, i, dout, nout, ax, ay, ex, ey, el, s)
                elif abs(dc) <= ON_EDGE_TOL * el or abs(dp) <= ON_EDGE_TOL * el:
                    # the cut is (up to round-off) the end vertex on the line: it moves
                    # as that vertex does where it is kept
                    k = i if abs(dc) <= ON_EDGE_TOL * el else ip
                    dout[nout] = 0.0
                    _on_line_motion(inp, din, nin, k, dout, nout, ax, ay, ex, ey, el, 1.0)
            nout += 1
        if dc >= 0.0:
            _copy_vertex(inp, din, i, out, dout, nout)
            if want and dc <= ON_EDGE_TOL * el:
                if _corner_edge(cx, cy, refx, refy, e) >= 0:
                    dout[nout] = 0.0
                else:
                    dout[nout] = 0.0
                    _on_line_motion(inp, din, nin, i, dout, nout, ax, ay, ex, ey, el, 1.0)
            nout += 1
    return nout


@numba.njit(cache=True)
def _clip_reference(vt, subj, dsubj, nsub, buf_a, buf_b, dbuf_a, dbuf_b, ds):
    """Clip the CCW polygon subj[:nsub] against the reference triangle / unit square.

    Returns (polygon, its derivatives, vertex count); they live in buf_a/dbuf_a or
    buf_b/dbuf_b (derivatives only with a non-empty ``dsubj``, see :func:`_clip_halfplane`).
    """
    if vt == TRIANGLE1:
        cx = np.array([0.0, 1.0, 0.0])
        cy = np.array([0.0, 0.0, 1.0])
    else:
        cx = np.array([0.0, 1.0, 1.0, 0.0])
        cy = np.array([0.0, 0.0, 1.0, 1.0])
    nc = cx.shape[0]
    for i in range(nsub):
        _copy_vertex(subj, dsubj, i, buf_a, dbuf_a, i)
    n = nsub
    src, dsrc = buf_a, dbuf_a
    dst, ddst = buf_b, dbuf_b
    for e in range(nc):
        if n == 0:
            break
        n = _clip_halfplane(src, dsrc, n, dst, ddst, cx, cy, e, ds)
        src, dst = dst, src
        dsrc, ddst = ddst, dsrc
    return src, dsrc, n


@numba.njit(cache=True)
def _canonical(poly, dpoly, n, out, dout):
    """Canonical form (module docstring) of the convex CCW polygon poly[:n] into out
    (and the vertex derivatives dpoly into dout, when dpoly is non-empty).

    Returns the vertex count (< 3: empty polygon).
    """
    want = dpoly.shape[0] > 0
    keep = np.arange(n)  # the vertices of poly still in the polygon, in order
    changed = True
    while changed and n >= 3:
        changed = False
        for i in range(n):
            ip = keep[(i - 1 + n) % n]
            iq = keep[(i + 1) % n]
            ii = keep[i]
            ux = poly[ii, 0] - poly[ip, 0]
            uy = poly[ii, 1] - poly[ip, 1]
            vx = poly[iq, 0] - poly[ii, 0]
            vy = poly[iq, 1] - poly[ii, 1]
            if abs(ux * vy - uy * vx) <= COLLINEAR_TOL:
                for l in range(i, n - 1):
                    keep[l] = keep[l + 1]
                n -= 1
                changed = True
                break
    if n < 3:
        return n
    i0 = 0
    best = poly[keep[0], 0] + KEY * poly[keep[0], 1]
    for i in range(1, n):
        v = poly[keep[i], 0] + KEY * poly[keep[i], 1]
        if v < best:
            best = v
            i0 = i
    for i in range(n):
        src = keep[(i0 + i) % n]
        out[i, 0] = poly[src, 0]
        out[i, 1] = poly[src, 1]
        if want:
            dout[i] = dpoly[src]
    return n


@numba.njit(cache=True)
def _cross(u, v, out):
    out[0] = u[1] * v[2] - u[2] * v[1]
    out[1] = u[2] * v[0] - u[0] * v[2]
    out[2] = u[0] * v[1] - u[1] * v[0]


@numba.njit(cache=True)
def _frame_derivatives(nv, N, dN, a1, a2, n0, t1, t2, dcen, dt1, dt2):
    """Derivatives of the clipping frame of :func:`_segments_2d` with respect to the slave
    vertex dofs j = a·3 + c (a < nv; the other columns are left untouched):

        dc = N_a(ξ_c) e_c,  dt₁ = (I − t₁t₁ᵀ) da₁ / |a₁|,  dn₀ = (I − n₀n₀ᵀ) dm / |m|,
        dt₂ = dn₀ × t₁ + n₀ × dt₁,

    with a_α = Σ_a ∂_α N_a(ξ_c) x_a, m = a₁ × a₂, n₀ = m/|m|, t₁ = a₁/|a₁|, t₂ = n₀ × t₁.
    Outputs dcen, dt1, dt2 (3, nloc).
    """
    la = math.sqrt(a1[0] ** 2 + a1[1] ** 2 + a1[2] ** 2)
    m = np.empty(3)
    _cross(a1, a2, m)
    nn = math.sqrt(m[0] ** 2 + m[1] ** 2 + m[2] ** 2)
    da1 = np.empty(3)
    da2 = np.empty(3)
    dm = np.empty(3)
    tmp = np.empty(3)
    dn = np.empty(3)
    dt = np.empty(3)
    for a in range(nv):
        for c in range(3):
            j = a * 3 + c
            for i in range(3):
                da1[i] = 0.0
                da2[i] = 0.0
                dcen[i, j] = 0.0
            da1[c] = dN[a, 0]
            da2[c] = dN[a, 1]
            dcen[c, j] = N[a]
            s = t1[c] * da1[c]
            for i in range(3):
                dt[i] = (da1[i] - t1[i] * s) / la
                dt1[i, j] = dt[i]
            _cross(da1, a2, dm)
            _cross(a1, da2, tmp)
            s = 0.0
            for i in range(3):
                dm[i] += tmp[i]
                s += n0[i] * dm[i]
            for i in range(3):
                dn[i] = (dm[i] - n0[i] * s) / nn
            _cross(dn, t1, dm)
            _cross(n0, dt, tmp)
            for i in range(3):
                dt2[i, j] = dm[i] + tmp[i]


@numba.njit(cache=True)
def _area_gradient(ftype, X, xi, grad):
    """∂J₀/∂ξ_β (β < 2) of the surface Jacobian J₀ = |a₁ × a₂| of facet X (n, 3) at ξ:
    n·(a₁,β × a₂ + a₁ × a₂,β) with n = a₁ × a₂ / J₀ and a_α,β = Σ_a ∂²_αβ N_a X_a."""
    n = X.shape[0]
    N = np.empty(n)
    dN = np.empty((n, 2))
    ddN = np.empty((n, 2, 2))
    shape(ftype, xi, N, dN, ddN)
    a = np.zeros((2, 3))
    aa = np.zeros((2, 2, 3))
    for k in range(n):
        for c in range(3):
            for al in range(2):
                a[al, c] += dN[k, al] * X[k, c]
                for be in range(2):
                    aa[al, be, c] += ddN[k, al, be] * X[k, c]
    m = np.empty(3)
    _cross(a[0], a[1], m)
    j0 = math.sqrt(m[0] ** 2 + m[1] ** 2 + m[2] ** 2)
    u = np.empty(3)
    v = np.empty(3)
    for be in range(2):
        _cross(aa[0, be], a[1], u)
        _cross(a[0], aa[1, be], v)
        grad[be] = ((u[0] + v[0]) * m[0] + (u[1] + v[1]) * m[1] + (u[2] + v[2]) * m[2]) / j0


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
    row0,
    dxi,
    dw,
):
    """Points of slave triangle / quad facet f (see module docstring); returns the number needed.

    With non-empty ``dxi`` (rows, 2, nloc) and ``dw`` (rows, nloc), also the derivatives
    of each point's ξ and weight with respect to its local dofs [slave facet nodes, master
    facet nodes] (× 3), point n of the facet in row ``row0 + n`` (forward mode through the
    frame, the master vertex map, the clipping, the canonical form and the fan; see
    :func:`segment_derivatives`).
    """
    d = 3
    want = dxi.shape[0] > 0
    xsf = xs[f]
    Xsf = Xs[f]
    ns = xsf.shape[0]
    nm = xm.shape[1]
    nloc = (ns + nm) * d if want else 0
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
    _cross(a1, a2, n0)
    nn = math.sqrt(n0[0] ** 2 + n0[1] ** 2 + n0[2] ** 2)
    la = math.sqrt(a1[0] ** 2 + a1[1] ** 2 + a1[2] ** 2)
    t1 = np.empty(d)
    t2 = np.empty(d)
    for c in range(d):
        n0[c] /= nn
        t1[c] = a1[c] / la
    _cross(n0, t1, t2)
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

    # derivatives of the frame, of P and of Ainv with respect to the slave vertex dofs
    nd = nloc if want else 0
    dcen = np.zeros((d, nd))
    dt1 = np.zeros((d, nd))
    dt2 = np.zeros((d, nd))
    dP = np.zeros((nv, 2, nd))
    dAinv = np.zeros((2, 2, nd))
    if want:
        _frame_derivatives(nv, N, dN, a1, a2, n0, t1, t2, dcen, dt1, dt2)
        for a in range(nv):
            for j in range(nv * d):
                s1 = 0.0
                s2 = 0.0
                for c in range(d):
                    dx = (1.0 if j == a * d + c else 0.0) - dcen[c, j]
                    s1 += dx * t1[c] + (xv[a, c] - cen[c]) * dt1[c, j]
                    s2 += dx * t2[c] + (xv[a, c] - cen[c]) * dt2[c, j]
                dP[a, 0, j] = s1
                dP[a, 1, j] = s2
        # dAinv = −Ainv dJ Ainv, dJ = Σ_a dP_a ⊗ ∂N_a(ξ_c)
        for j in range(nv * d):
            dJ = np.zeros((2, 2))
            for a in range(nv):
                for i in range(2):
                    for al in range(2):
                        dJ[i, al] += dP[a, i, j] * dN[a, al]
            for i in range(2):
                for k2 in range(2):
                    s = 0.0
                    for l1 in range(2):
                        for l2 in range(2):
                            s += Ainv[i, l1] * dJ[l1, l2] * Ainv[l2, k2]
                    dAinv[i, k2, j] = -s

    mpoly = np.empty((4, 2))
    subj = np.empty((4, 2))
    buf_a = np.empty((_POLY_MAX, 2))
    buf_b = np.empty((_POLY_MAX, 2))
    canon = np.empty((_POLY_MAX, 2))
    dmpoly = np.zeros((4 if want else 0, 2, nd))
    dsubj = np.zeros((4 if want else 0, 2, nd))
    dbuf_a = np.zeros((_POLY_MAX if want else 0, 2, nd))
    dbuf_b = np.zeros((_POLY_MAX if want else 0, 2, nd))
    dcanon = np.zeros((_POLY_MAX if want else 0, 2, nd))
    ds = np.zeros(nd)
    dq = np.zeros((2, nd))
    Nq = np.empty(nv)
    dNq = np.empty((nv, 2))
    ddNq = np.empty((nv, 2, 2))
    jgrad = np.zeros(2)
    q = np.empty(2)
    xi = np.empty(2)
    xbar = np.empty(2)
    tmp = np.empty(d)
    dvec = np.zeros(nd)
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
            ok = _invert_plane_map(vt, P, q, xic, Ainv, xi)
            mpoly[i, 0] = xi[0]
            mpoly[i, 1] = xi[1]
            if want:
                # dq_α = (dx_m − dc)·t_α + (x_m − c)·dt_α
                for jj in range(nloc):
                    s1 = 0.0
                    s2 = 0.0
                    for c in range(d):
                        s1 += -dcen[c, jj] * t1[c] + (xm[m, node, c] - cen[c]) * dt1[c, jj]
                        s2 += -dcen[c, jj] * t2[c] + (xm[m, node, c] - cen[c]) * dt2[c, jj]
                    dq[0, jj] = s1
                    dq[1, jj] = s2
                for c in range(d):
                    dq[0, (ns + node) * d + c] += t1[c]
                    dq[1, (ns + node) * d + c] += t2[c]
                if ok:
                    # Σ_a N_a(ξ) P_a = q: dξ = J(ξ)⁻¹ (dq − Σ_a N_a(ξ) dP_a)
                    _plane_map(vt, P, xi, Nq, dNq, ddNq, r, J)
                    det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
                    for jj in range(nloc):
                        r0 = dq[0, jj]
                        r1 = dq[1, jj]
                        for a in range(nv):
                            r0 -= Nq[a] * dP[a, 0, jj]
                            r1 -= Nq[a] * dP[a, 1, jj]
                        dmpoly[i, 0, jj] = (J[1, 1] * r0 - J[0, 1] * r1) / det
                        dmpoly[i, 1, jj] = (-J[1, 0] * r0 + J[0, 0] * r1) / det
                else:
                    # ξ = ξ_c + Ainv q
                    for jj in range(nloc):
                        for al in range(2):
                            dmpoly[i, al, jj] = (
                                dAinv[al, 0, jj] * q[0]
                                + dAinv[al, 1, jj] * q[1]
                                + Ainv[al, 0] * dq[0, jj]
                                + Ainv[al, 1] * dq[1, jj]
                            )
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
                    if want:
                        for jj in range(nloc):
                            v = dmpoly[i, c, jj]
                            dmpoly[i, c, jj] = dmpoly[i2, c, jj]
                            dmpoly[i2, c, jj] = v
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
                    _copy_vertex(mpoly, dmpoly, i, subj, dsubj, i)
            else:
                nsub = 3
                for i in range(3):
                    src = (reflex + piece + i) % 4 if i > 0 else reflex
                    _copy_vertex(mpoly, dmpoly, src, subj, dsubj, i)
                if _signed_area2(subj, 3) <= 0.0:
                    continue
            poly, dpoly, npoly = _clip_reference(
                vt, subj, dsubj, nsub, buf_a, buf_b, dbuf_a, dbuf_b, ds
            )
            if npoly < 3:
                continue
            nc = _canonical(poly, dpoly, npoly, canon, dcanon)
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
                if want:
                    # djac = de1 × e2 + e1 × de2, de = dv_i − dv_0
                    for jj in range(nloc):
                        de1x = dcanon[i, 0, jj] - dcanon[0, 0, jj]
                        de1y = dcanon[i, 1, jj] - dcanon[0, 1, jj]
                        de2x = dcanon[i + 1, 0, jj] - dcanon[0, 0, jj]
                        de2y = dcanon[i + 1, 1, jj] - dcanon[0, 1, jj]
                        dvec[jj] = de1x * e2y + e1x * de2y - de1y * e2x - e1y * de2x
                for qq in range(rule_w.shape[0]):
                    r1 = rule_pts[qq, 0]
                    r2 = rule_pts[qq, 1]
                    xi[0] = v0x + r1 * e1x + r2 * e2x
                    xi[1] = v0y + r1 * e1y + r2 * e2y
                    j0 = unit_normal(Xsf, ftype_s, 1.0, xi, tmp)
                    if want and cnt < qp_w.shape[1] and row0 + cnt < dxi.shape[0]:
                        # ξ = (1 − r₁ − r₂) v₀ + r₁ v_i + r₂ v_{i+1},  w = ŵ jac J₀(ξ)
                        row = row0 + cnt
                        _area_gradient(ftype_s, Xsf, xi, jgrad)
                        r0 = 1.0 - r1 - r2
                        for jj in range(nloc):
                            gj = 0.0
                            for al in range(2):
                                dx = (
                                    r0 * dcanon[0, al, jj]
                                    + r1 * dcanon[i, al, jj]
                                    + r2 * dcanon[i + 1, al, jj]
                                )
                                dxi[row, al, jj] = dx
                                gj += jgrad[al] * dx
                            dw[row, jj] = rule_w[qq] * (dvec[jj] * j0 + jac * gj)
                    cnt = _emit(f, cnt, 2, xi, rule_w[qq] * jac * j0, m, qp_xi, qp_w, qp_m)
    return cnt


@numba.njit(cache=True)
def _facet_points(
    k,
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
    row0,
    dxi,
    dw,
):
    """:func:`_segments_1d` (k = 1) or :func:`_segments_2d` (k = 2) of slave facet f."""
    if k == 1:
        return _segments_1d(
            f, ftype_s, xs, Xs, ssign, ftype_m, xm, msign, cand_off, cand, rule_pts, rule_w,
            qp_xi, qp_w, qp_m, row0, dxi, dw,
        )  # fmt: skip
    return _segments_2d(
        f, ftype_s, xs, Xs, ssign, ftype_m, xm, msign, cand_off, cand, rule_pts, rule_w,
        qp_xi, qp_w, qp_m, row0, dxi, dw,
    )  # fmt: skip


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
    no_dxi = np.zeros((0, k, 0))
    no_dw = np.zeros((0, 0))
    for f in range(nsf):
        for j in range(nqmax):
            qp_w[f, j] = 0.0
            qp_m[f, j] = -1
            for a in range(k):
                qp_xi[f, j, a] = 0.0
        cnt = _facet_points(
            k,
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
            np.int64(0),  # not the literal 0: one compiled chain for both callers
            no_dxi,
            no_dw,
        )
        count[f] = cnt if cnt <= nqmax else -cnt
    return count


@numba.njit(cache=True)
def segment_derivatives(
    ftype_s, xs, Xs, ssign, ftype_m, xm, msign, cand_off, cand, rule_pts, rule_w, qp_m, dxi, dw
):
    r"""Derivatives of the segment points ξ_q and weights w_q of :func:`segment_points`
    with respect to the local dofs [slave facet nodes, master facet nodes] (× d) of each
    paired point, for the linearisation of segment integration.

    The arguments up to ``rule_w`` must be those of the :func:`segment_points` call that
    produced ``qp_m`` (nsf, nq): the points are computed again, with the derivatives
    carried forward through every step that depends on the coordinates. Rows are the
    paired points (qp_m >= 0) in (facet, point) order, as in
    :func:`dolfinx_mortar.kernels.mortar.contact_terms`.

    2D: the segment ends are the closest-point parameters of the master END nodes on the
    slave facet (:func:`_segments_1d`). 3D: a point ξ = (1 − r₁ − r₂) v₀ + r₁ v_i + r₂
    v_{i+1} of the fan triangle (v₀, v_i, v_{i+1}) of a clipped polygon, with weight
    w = ŵ jac J₀(ξ), jac = (v_i − v₀) × (v_{i+1} − v₀), moves with the polygon's vertices:
    a reference-element corner is fixed; a master vertex mapped into the slave reference
    plane moves with the master node and with the slave frame (c, t₁, t₂, P_a; the
    inverse map Σ_a N_a(ξ) P_a = q gives dξ = J⁻¹(dq − Σ_a N_a dP_a)); an intersection
    of a master edge with a reference edge moves with the edge's two end vertices
    (:func:`_clip_halfplane`). Vertices dropped by the canonical form, the facing test
    and the clamping of the ends are discrete choices (not differentiated).

    Outputs: dxi (n_paired, k, nloc), dw (n_paired, nloc). Returns the number of rows
    written (= n_paired when the points are those of ``qp_m``).
    """
    nsf, nq = qp_m.shape
    k = tdim(ftype_s)
    sxi = np.zeros((nsf, nq, k))
    sw = np.zeros((nsf, nq))
    sm = np.full((nsf, nq), -1, dtype=np.int64)
    row = np.int64(0)  # not the literal 0 (see segment_points)
    for f in range(nsf):
        cnt = _facet_points(
            k,
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
            sxi,
            sw,
            sm,
            row,
            dxi,
            dw,
        )
        paired = 0
        for q in range(nq):
            if qp_m[f, q] >= 0:
                paired += 1
        if cnt != paired:
            raise ValueError("segment_derivatives: the points differ from those of qp_m")
        row += cnt
    return row
