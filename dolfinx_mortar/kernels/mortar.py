"""Mortar integrals over slave facets (numba): pairing, weighted gaps, residual and tangent entries.

Quadrature points live on the slave reference facet, per facet: ``qp_xi``
(nsf, nq, k) and weights ``qp_w`` (nsf, nq) that already include the reference
surface Jacobian J₀ (a slot of weight 0 is unused). The element rule
(:func:`reference_weights`) puts the same Gauss rule on every facet; segment
integration (:mod:`dolfinx_mortar.kernels.segment`) puts a rule on each
overlap of the slave facet with a master facet.

Element-based pairing (:func:`pair_points`, the paper's choice): every point is
projected onto its candidate master facets; the closest valid projection pairs
it with one master facet. A projection is valid when ζ lies in the master
reference facet (or, when no candidate contains it, at most ``OUTSIDE_TOL`` in ζ, or
``BLIND_SPOT_SLOPE`` g in distance for a point outside the master, outside the nearest
one: the neighbourhood of a concave kink, and the blind spot of a convex vertex), the
slave and master normals face each other (n_s·ν < −cos θ_max, θ_max = 85°: the one
facing rule of every pairing, :func:`.gap.faces`, :data:`.gap.MAX_FACING_ANGLE`) and
the penetration is not deeper than ``max_depth``. Unpaired points contribute to
nothing (neither A^I nor G^I), in residual and tangent alike. Segment points
come paired (:func:`forced_points`).

With mixed-field shape functions Φ_I on the slave facet (element ``ftype_phi``)
and integrals over the reference slave surface (the mixed pressure is a
nominal traction):

    A^I = Σ_q w_q J₀ Φ_I(ξ_q) [q paired],     G^I = Σ_q w_q J₀ Φ_I(ξ_q) g(ξ_q),
    B^I = ∂G^I/∂u = Σ_q w_q J₀ Φ_I ∂g/∂u,    ∂²G^I/∂u² = Σ_q w_q J₀ Φ_I ∂²g/∂u²,

with the exact derivatives of the closest-point gap
(:func:`dolfinx_mortar.kernels.gap.gap_and_derivatives`, x¹ = Σ_a N_a x_a).
For segment integration the points and weights also move with u; those terms of
the tangent come from :func:`dolfinx_mortar.kernels.segment.segment_derivatives` and
:func:`point_xi_terms` (assembled in :mod:`dolfinx_mortar.contact`).

Local dof vector of a paired point: [slave facet dofs (ns·d), master facet dofs
(nm·d)], node-major (see :mod:`dolfinx_mortar.layout`).
"""

from __future__ import annotations

import numpy as np

from ._numba import numba
from .gap import (
    _normal,
    _project_affine,
    _surface_in,
    faces,
    gap_and_derivatives,
    gap_only_in,
    project_in,
    unit_normal,
    unit_normal_in,
    work,
)
from .shape import INTERVAL1, TRIANGLE1, TRIANGLE2, clamp_to_reference, shape, tdim

#: Newton iterations of the closest-point projection of a slave point
PROJECT_MAXIT = 30


@numba.njit(cache=True)
def reference_weights(ftype_s, Xs, qpts, qw, qp_xi, qp_w):
    """Element rule on every slave facet: qp_xi[f, q] = qpts[q], qp_w[f, q] = w_q J₀(ξ_q).

    Xs (nsf, ns, d) reference slave coordinates; qpts (nq, k), qw (nq,).
    """
    nsf, ns, d = Xs.shape
    nq, k = qpts.shape
    tmp = np.empty(d)
    for f in range(nsf):
        for q in range(nq):
            for a in range(k):
                qp_xi[f, q, a] = qpts[q, a]
            qp_w[f, q] = qw[q] * unit_normal(Xs[f], ftype_s, 1.0, qpts[q], tmp)


@numba.njit(cache=True)
def paired_fraction(ftype_s, Xs, qp_xi, qp_w, qp_m, out):
    """out[f] = (Σ_q w_q / J₀(ξ_q) over the points with qp_m[f, q] ≥ 0) / |reference facet|:
    the fraction of slave facet f that its paired points cover (out (nsf,)).

    Xs (nsf, ns, d) reference slave coordinates, qp_xi (nsf, nq, k), qp_w, qp_m (nsf, nq).
    Every point's weight is ŵ J₀(ξ) times a piece of the reference facet (the element
    rule, or a segment's length or a fan triangle's area), so the quotients sum to the
    reference measure of the pieces, exactly up to round-off, whatever the quadrature
    error of J₀ on a curved facet. (Summing the weights against the facet's area from
    the element rule compares two quadratures of J₀; they agreed to 1.4e-15 on hertz2d's
    coarse P2 facets, but nothing bounds that in general.)
    """
    nsf, nq = qp_w.shape
    d = Xs.shape[2]
    tri = ftype_s == TRIANGLE1 or ftype_s == TRIANGLE2
    ref = 0.5 if tri else 1.0
    tmp = np.empty(d)
    for f in range(nsf):
        s = 0.0
        for q in range(nq):
            if qp_m[f, q] >= 0 and qp_w[f, q] != 0.0:
                s += qp_w[f, q] / unit_normal(Xs[f], ftype_s, 1.0, qp_xi[f, q], tmp)
        out[f] = s / ref


@numba.njit(cache=True)
def _slave_point(ftype_s, xs_f, xi, N, dN, ddN, x1):
    ns, d = xs_f.shape
    shape(ftype_s, xi, N, dN, ddN)
    for c in range(d):
        x1[c] = 0.0
        for a in range(ns):
            x1[c] += N[a] * xs_f[a, c]


#: ζ-tolerance of "inside the master facet"
INSIDE_TOL = 1e-9
#: largest ζ-distance outside a master facet still accepted when no facet contains the
#: projection, for a point on the master surface (g = 0); see BLIND_SPOT_SLOPE
OUTSIDE_TOL = 1e-3
#: A point outside the master (g > 0) near a convex vertex (3D: edge) of the faceted
#: master projects outside both neighbouring facets, by up to g sin(kink angle): it is
#: paired with the facet it lies least outside when its projection onto the facet's
#: extension lies at most BLIND_SPOT_SLOPE × g from the facet (kinks up to about 6°: a
#: curved master faceted at h ≤ R/10). Without it an open point at the edge of the
#: contact zone (g ≈ 0.06 h on the ironing2d die, 0.033 rad between die facets) dropped
#: out of the pairing in the vertex's blind spot, and with it its share of its nodes'
#: lumped A^I, G^I: the nodal gap of the active neighbour node jumped (p̂ 0.28 → 0.65),
#: so did the residual, and the l2 line search crawled at λ ≈ 0.25 for 10 iterations.
#: Penetrating points (g ≤ 0) keep OUTSIDE_TOL: with |g| in place of g the hertz2d bench
#: at level 2 (element) took 54 Newton iterations instead of 45.
BLIND_SPOT_SLOPE = 0.1
#: OUTSIDE_TOL of node integration, whose points are the slave facets' vertices: a slave
#: node on the edge of the master surface (same-size blocks, matching sides) moves off
#: the master's edge chord by the difference of the two bodies' deformations, on a
#: patch3d slide (n = 4, μ = 0.3, slide 0.1–0.2) by 0.01–0.02 in ζ while it presses
#: into the master. With OUTSIDE_TOL such nodes left the pairing and came back at
#: γ = −0.009 (p = 145) from iterate to iterate, and the slide failed; at 0.01 it failed
#: at t = 1.76, at 0.02 and 0.05 it completes. A node that slides off the master's end
#: stays paired until it is this far beyond it (h/20 on a [0, 1] facet). Element
#: integration keeps OUTSIDE_TOL: its points lie inside the slave facets.
NODE_OUTSIDE_TOL = 5e-2
#: Ties of the pairing (relative to the ``reach`` of :func:`pair_points`: the slave facet
#: size h in the current pairing, 2 h in the t_n pairings of friction): two valid projections whose ζ-distances outside their facets
#: differ by at most INSIDE_TOL and whose |g| differ by at most PAIR_TIE_TOL × h are a
#: tie, and the facet with the smaller key (its reference centroid, lexicographically)
#: wins. A slave point over a master vertex (3D: edge) of a nearly flat master projects
#: into both (all) facets around it with gaps equal to round-off; the closest one was
#: decided by that round-off and by the facets' local order, both of which depend on the
#: partition: on the patch3d press with node integration (matching 4 × 4 faces) the
#: Newton iterations of the first step were 12, 9 and 8 on 1, 2 and 3 ranks.
PAIR_TIE_TOL = 1e-10


@numba.njit(cache=True)
def _distance_outside(ftype, xm_f, zeta, N, dN, ddN, zc, xa, xb):
    """Distance from the point x(ζ) of the facet's extension to the facet's point at the
    closest reference point (clamp_to_reference); xm_f (nm, d). N, dN, ddN, zc, xa, xb:
    work arrays."""
    for a in range(zeta.shape[0]):
        zc[a] = zeta[a]
    clamp_to_reference(ftype, zc)
    _slave_point(ftype, xm_f, zeta, N, dN, ddN, xa)
    _slave_point(ftype, xm_f, zc, N, dN, ddN, xb)
    e = 0.0
    for c in range(xa.shape[0]):
        e += (xa[c] - xb[c]) ** 2
    return np.sqrt(e)


@numba.njit(cache=True)
def _outside(ftype, zeta):
    """How far ζ lies outside the reference facet (≤ 0 inside), in reference coordinates."""
    if tdim(ftype) == 1:
        return max(-zeta[0], zeta[0] - 1.0)
    if ftype == 2 or ftype == 3:  # triangles
        return max(-zeta[0], -zeta[1], zeta[0] + zeta[1] - 1.0)
    return max(-zeta[0], zeta[0] - 1.0, -zeta[1], zeta[1] - 1.0)


def facet_keys(X: np.ndarray) -> np.ndarray:
    """Tie-break keys of facets (:func:`pair_points`): their reference centroids, shape
    (nf, d) from the reference node coordinates X (nf, nn, d). Partition-independent
    (global node numbers are not), and distinct for distinct facets of a surface."""
    return np.ascontiguousarray(X.mean(axis=1)) if X.size else np.zeros((0, X.shape[-1]))


@numba.njit(cache=True)
def _better(out, dist, keys, m, best_out, best_dist, b, tie):
    """Whether a projection onto facet m (ζ-distance ``out`` outside its facet, |g| =
    ``dist``) beats the best so far, onto facet b: less outside, then closer, then the
    smaller key (``keys[m]`` against ``keys[b]``: :func:`facet_keys`), with ties within
    INSIDE_TOL in ζ and ``tie`` in distance (PAIR_TIE_TOL). Facets by index, not as rows:
    a row is a view, whose reference count costs more than the test."""
    if best_dist == np.inf:
        return True
    if out < best_out - INSIDE_TOL:
        return True
    if out > best_out + INSIDE_TOL:
        return False
    if dist < best_dist - tie:
        return True
    if dist > best_dist + tie:
        return False
    for c in range(keys.shape[1]):
        if keys[m, c] != keys[b, c]:
            return keys[m, c] < keys[b, c]
    return False


@numba.njit(cache=True)
def _facet_boxes(xm):
    """The axis-aligned bounding boxes (nmf, 2, d) of the facets xm (nmf, nodes, d): their
    lowest and highest coordinates."""
    nmf, nn, d = xm.shape
    box = np.empty((nmf, 2, d))
    for m in range(nmf):
        for c in range(d):
            lo = xm[m, 0, c]
            hi = lo
            for a in range(1, nn):
                lo = min(lo, xm[m, a, c])
                hi = max(hi, xm[m, a, c])
            box[m, 0, c] = lo
            box[m, 1, c] = hi
    return box


@numba.njit(cache=True)
def _box_distance2(boxes, m, x):
    """The squared distance from the point x (d,) to the box ``boxes[m]`` (boxes (n, 2, d):
    lowest, highest coordinates; 0 inside)."""
    e2 = 0.0
    for c in range(x.shape[0]):
        e = max(boxes[m, 0, c] - x[c], x[c] - boxes[m, 1, c], 0.0)
        e2 += e * e
    return e2


@numba.njit(cache=True)
def _box_box_distance2(boxes, m, pbox):
    """The squared distance between the boxes ``boxes[m]`` and pbox (2, d) (lowest,
    highest coordinates; 0 where they overlap): for every point x of ``pbox``, at most
    :func:`_box_distance2` (boxes, m, x), in floating point too (each difference, square
    and sum is rounded monotonically)."""
    e2 = 0.0
    for c in range(pbox.shape[1]):
        e = max(boxes[m, 0, c] - pbox[1, c], pbox[0, c] - boxes[m, 1, c], 0.0)
        e2 += e * e
    return e2


#: The margin, relative to ``reach``, by which a master facet that :func:`pair_points`
#: did not project (its bounding box farther than the winner's |g| + PAIR_TIE_TOL reach)
#: must lie beyond the winner for the nearest-first order to count as deciding the
#: point (``nearest_first``): a projection within OUTSIDE_TOL of its facet may lie just
#: outside the facet's bounding box, so its |g| is bounded below by the box distance
#: only up to a few INSIDE_TOL facet sizes.
NEAREST_MARGIN = 1e-6


@numba.njit(cache=True)
def _affine_frames(ftype, x, sign):
    """The unit normal (nf, d), the unnormalised normal n = ±a_1 (× a_2) (nf, d) and |n|
    (nf,) of each facet x (nf, nodes, d) of an affine type (INTERVAL1, TRIANGLE1), whose
    tangents, hence normals, do not depend on the reference point: evaluated once per
    facet at the reference centre, with :func:`.gap.unit_normal_in`'s operations (the
    tangents by :func:`.gap._surface_in`, n and |n| by :func:`.gap._normal`, ν = n / |n|),
    they are the values :func:`.gap.unit_normal_in` and :func:`.gap.gap_only_in` use at
    every point, bit for bit (the tangents Σ_a ∂N_a x_a sum constant shape derivatives).
    Empty (0, d), (0, d), (0,) arrays for other types: the callers then evaluate at each
    point. sign (nf,): ±1 per facet."""
    nf, _, d = x.shape
    if not (ftype == INTERVAL1 or ftype == TRIANGLE1):
        return np.empty((0, d)), np.empty((0, d)), np.empty(0)
    nu, nv, jn = np.empty((nf, d)), np.empty((nf, d)), np.empty(nf)
    N, dN, ddN, S, A, SS = work(ftype)[:6]
    zc = np.full(tdim(ftype), 1.0 / (tdim(ftype) + 1))
    for f in range(nf):
        _surface_in(x[f], ftype, zc, N, dN, ddN, S, A, SS)
        jn[f] = _normal(A, sign[f], nv[f])
        for c in range(d):
            nu[f, c] = nv[f, c] / jn[f]
    return nu, nv, jn


@numba.njit(cache=True)
def _affine_normal(m, mnu, num):
    """num (d,) ← ``mnu[m]``, the unit normal of the affine master facet m
    (:func:`_affine_frames`)."""
    for c in range(num.shape[0]):
        num[c] = mnu[m, c]


@numba.njit(cache=True)
def _affine_gap(ftype_m, x1, xm, m, zeta, mnv, mjn):
    """g = (x1 − S(ζ))·ν on the affine master facet m (INTERVAL1, TRIANGLE1), with the
    normal of :func:`_affine_frames`: :func:`.gap.gap_only_in`'s operations in its order,
    the same bits (N(ζ) written as :func:`.shape.shape` writes it: 1 − ζ, ζ; 1 − ζ₁ − ζ₂,
    ζ₁, ζ₂; S summed as :func:`.gap._surface_in` sums it)."""
    x = zeta[0]
    tri = ftype_m == TRIANGLE1
    y = zeta[1] if tri else 0.0
    n0 = 1.0 - x - y if tri else 1.0 - x
    g = 0.0
    for i in range(x1.shape[0]):
        s = 0.0
        s += n0 * xm[m, 0, i]
        s += x * xm[m, 1, i]
        if tri:
            s += y * xm[m, 2, i]
        g += (x1[i] - s) * mnv[m, i]
    return g / mjn[m]


@numba.njit(cache=True)
def _first_sweep_test(
    ftype_m, x1, nus, xm, msign_m, max_depth, outside_tol, z0, k, done, valid, vout,
    vdist, vgap, vz, num, wm, m, mnu, mnv, mjn,
):  # fmt: skip
    """The tests of :func:`pair_points`' first sweep that do not depend on the best so
    far, for the projection of x1 onto the master facet m (xm (nmf, nm, d); its normals
    in mnu, mnv, mjn where affine: :func:`_affine_frames`), recorded in slot k: done[k];
    valid[k], and where valid vout[k] = max(ζ-distance outside, INSIDE_TOL), vdist[k] =
    |g|, vgap[k] = g, vz[k] = ζ."""
    zeta = vz[k]
    xm_m = xm[m]
    affine = mnu.shape[0] > 0
    if not (affine and _project_affine(x1, xm_m, zeta)):  # project_in's closed form
        project_in(x1, xm_m, ftype_m, z0, zeta, 1e-13, np.int64(PROJECT_MAXIT), wm)
    done[k] = True
    valid[k] = False
    out = _outside(ftype_m, zeta)
    if out > outside_tol:
        return
    if affine:
        _affine_normal(m, mnu, num)
    else:
        unit_normal_in(xm_m, ftype_m, msign_m, zeta, num, wm)
    if not faces(nus, num):
        return
    if affine:
        g = _affine_gap(ftype_m, x1, xm, m, zeta, mnv, mjn)
    else:
        g = gap_only_in(x1, xm_m, ftype_m, msign_m, zeta, wm)
    if g < -max_depth:
        return
    valid[k] = True
    vout[k] = max(out, INSIDE_TOL)
    vdist[k] = abs(g)
    vgap[k] = g


@numba.njit(cache=True)
def _pair_nearest(
    ftype_m, x1, nus, xm, mbox, msign, mkey, cand, lo, hi, max_depth, reach, outside_tol,
    z0, num, wm, dbox, order, done, valid, vout, vdist, vgap, vz, forder, mnu, mnv, mjn,
):  # fmt: skip
    """The first sweep of :func:`pair_points` for one slave point (x1 (d,), unit normal
    nus (d,)) and its candidates ``cand[lo:hi]``, projecting only the master facets it
    must. Returns the slot k of the winner (its facet ``cand[lo + k]``, ζ ``vz[k]``, gap
    ``vgap[k]``), or −1 where the sweep pairs nothing (the caller then runs both sweeps).

    The result is that of the sweep in the candidates' own order, where every
    candidate whose bounding box lies within the pruning distance is projected: the
    projections are the same (the same start, state-independent tests, recorded per
    slot by :func:`_first_sweep_test`), only fewer are made.

    1. Nearest first: the candidates sorted by the distance of x1 to their bounding
       boxes (``dbox``, squared) and swept with :func:`pair_points`' pruning, which,
       once the best contains the point, projects only the facets as near as its |g|.
    2. Where that winner W contains the point, the sweep in the candidates' order is
       certain to end at W when: W is within its own pruning distance; every valid
       projected candidate before W in that order loses to W in :func:`_better` and,
       had it been the best when W's turn came, would not have pruned W; every valid
       one after W does not beat W; and every candidate within ``reach`` not projected
       lies beyond W's |g| + PAIR_TIE_TOL reach by NEAREST_MARGIN reach (those nearer
       are projected now and checked as the others): its |g| then exceeds W's by more
       than the tie, so it loses to W whenever it is met, and W, once met, prunes it.
    3. Otherwise (a tie, a point that no facet contains: in step 1 the best never
       contained it, so every candidate within ``reach`` was projected) the sweep in
       the candidates' order is replayed from the recorded projections, projecting
       the few it reaches that step 1 did not.

    mbox (nmf, 2, d): the master facets' bounding boxes (lowest, highest coordinates);
    mnu, mnv, mjn: their normals where affine (:func:`_affine_frames`).
    forder (≥ hi − lo,) int64: the slots 0 … hi − lo − 1 in the order step 1 inserts them
    into its sort (:func:`pair_points` passes the slave facet's own nearest-first order,
    by the box distances from the facet's centroid: the points' orders differ little
    from it, and the insertion sort has little to move). Which of equally near
    candidates comes first does not change the result, only which projections are made.
    Work arrays dbox, vout, vdist, vgap (float), order (int64), done, valid (bool) hold
    at least hi − lo entries, vz (≥ hi − lo, km).
    """
    K = hi - lo
    for i in range(K):
        k = forder[i]
        m = cand[lo + k]
        e2 = _box_distance2(mbox, m, x1)
        dbox[k] = e2
        done[k] = False
        valid[k] = False
        # insertion sort by box distance (a few dozen candidates, nearly in order)
        j = i
        while j > 0 and dbox[order[j - 1]] > e2:
            order[j] = order[j - 1]
            j -= 1
        order[j] = k
    tie = PAIR_TIE_TOL * reach
    # 1. nearest first
    kb = -1
    best_dist, best_out = np.inf, np.inf
    for j in range(K):
        k = order[j]
        limit = best_dist + tie if best_out <= INSIDE_TOL else np.inf
        if dbox[k] > min(limit, reach) ** 2:
            continue
        m = cand[lo + k]
        _first_sweep_test(
            ftype_m, x1, nus, xm, msign[m], max_depth, outside_tol, z0, k, done, valid,
            vout, vdist, vgap, vz, num, wm, m, mnu, mnv, mjn,
        )  # fmt: skip
        if valid[k] and _better(
            vout[k], vdist[k], mkey, m, best_out, best_dist, cand[lo + max(kb, 0)], tie
        ):
            kb, best_out, best_dist = k, vout[k], vdist[k]
    if kb < 0:
        return -1
    # 2. certain?
    certain = best_out <= INSIDE_TOL and dbox[kb] <= min(best_dist + tie, reach) ** 2
    if certain:
        w = cand[lo + kb]
        far = (best_dist + tie + NEAREST_MARGIN * reach) ** 2
        for k in range(K):
            m = cand[lo + k]
            if m == w or dbox[k] > reach**2:
                continue
            if not done[k]:
                if dbox[k] > far:
                    continue
                _first_sweep_test(
                    ftype_m, x1, nus, xm, msign[m], max_depth, outside_tol, z0, k, done,
                    valid, vout, vdist, vgap, vz, num, wm, m, mnu, mnv, mjn,
                )  # fmt: skip
            if not valid[k]:
                continue
            if k < kb:
                beats = _better(best_out, best_dist, mkey, w, vout[k], vdist[k], m, tie)
                prunes = vout[k] <= INSIDE_TOL and dbox[kb] > min(vdist[k] + tie, reach) ** 2
                if not beats or prunes:
                    certain = False
                    break
            elif _better(vout[k], vdist[k], mkey, m, best_out, best_dist, w, tie):
                certain = False
                break
    if certain:
        return kb
    # 3. the sweep in the candidates' order, replayed
    kb = -1
    best_dist, best_out = np.inf, np.inf
    for k in range(K):
        limit = best_dist + tie if best_out <= INSIDE_TOL else np.inf
        if dbox[k] > min(limit, reach) ** 2:
            continue
        m = cand[lo + k]
        if not done[k]:
            _first_sweep_test(
                ftype_m, x1, nus, xm, msign[m], max_depth, outside_tol, z0, k, done,
                valid, vout, vdist, vgap, vz, num, wm, m, mnu, mnv, mjn,
            )  # fmt: skip
        if not valid[k] or vout[k] > best_out + INSIDE_TOL:
            continue
        if _better(vout[k], vdist[k], mkey, m, best_out, best_dist, cand[lo + max(kb, 0)], tie):
            kb, best_out, best_dist = k, vout[k], vdist[k]
    return kb


@numba.njit(cache=True)
def pair_points(
    ftype_s,
    ftype_m,
    xs,
    ssign,
    qp_xi,
    qp_w,
    xm,
    msign,
    mkey,
    cand_off,
    cand,
    max_depth,
    reach,
    qp_m,
    qp_zeta,
    qp_g,
    outside_tol,
    nearest_first,
):
    """Pair every slave quadrature point with its closest valid master facet (or none: -1).

    Inputs: xs (nsf, ns, d) current slave nodes, ssign (nsf,), qp_xi (nsf, nq, ks),
    qp_w (nsf, nq), xm (nmf, nm, d) current master nodes, msign (nmf,), mkey (nmf, k)
    the tie-break key of each master facet (:func:`facet_keys`: the same on every
    partition; see PAIR_TIE_TOL), max_depth (nsf,)
    deepest accepted penetration and reach (nsf,) largest accepted distance per slave
    facet, candidates of
    facet f in cand[cand_off[f]:cand_off[f+1]], and outside_tol the largest ζ-distance
    outside a facet accepted when no candidate contains the projection (OUTSIDE_TOL;
    NODE_OUTSIDE_TOL for node integration). Outputs qp_m (nsf, nq), qp_zeta
    (nsf, nq, km), qp_g (nsf, nq).

    With ``nearest_first`` the first sweep of each point projects only the candidates
    it must (:func:`_pair_nearest`: nearest first, then a check that the sweep in the
    candidates' order ends at the same facet, or that sweep replayed from the
    projections made): the same result, bit for bit, where the candidates are many (the
    t_n pairings of friction reach 2 h: 25–36 master facets per slave facet on a 3D
    block, where a point now takes 2.3 projections on average instead of 11.6). A point
    it pairs with nothing (no valid projection: every candidate within ``reach`` was
    projected) runs both sweeps below on those projections, recorded per slot, instead of
    making them again, twice (6 % of the points of the 3D friction patch's t_n pairings,
    whose projections made again were 39 % of all).

    On affine masters (INTERVAL1, TRIANGLE1) the closed-form projection
    (:func:`.gap._project_affine`) is called directly and the facets' normals come from
    :func:`_affine_frames`: the results of :func:`.gap.project_in`,
    :func:`.gap.unit_normal_in` and :func:`.gap.gap_only_in` bit for bit, without their
    calls' reference counts of 14 work arrays (BENCHMARKS.md §99). Local (not collective).
    """
    nsf, ns, d = xs.shape
    nq = qp_xi.shape[1]
    ks = tdim(ftype_s)
    km = tdim(ftype_m)
    N = np.empty(ns)
    dN = np.empty((ns, ks))
    ddN = np.empty((ns, ks, ks))
    nus = np.empty(d)
    num = np.empty(d)
    zeta = np.empty(km)
    z0 = np.full(km, np.nan)
    best_z = np.zeros(km)
    nm = xm.shape[1]
    Nm, dNm, ddNm = np.empty(nm), np.empty((nm, km)), np.empty((nm, km, km))
    zc, xa, xb = np.empty(km), np.empty(d), np.empty(d)
    wm, ws = work(ftype_m), work(ftype_s)  # no allocation per point
    mbox = _facet_boxes(xm)
    mnu, mnv, mjn = _affine_frames(ftype_m, xm, msign)
    affine = mnu.shape[0] > 0
    s_affine = ftype_s == INTERVAL1 or ftype_s == TRIANGLE1
    kmax = 0
    for f in range(nsf):
        kmax = max(kmax, cand_off[f + 1] - cand_off[f])
    box2, vout, vdist, vgap = np.empty(kmax), np.empty(kmax), np.empty(kmax), np.empty(kmax)
    vz, order = np.empty((kmax, km)), np.empty(kmax, np.int64)
    done, valid = np.empty(kmax, np.bool_), np.empty(kmax, np.bool_)
    forder, fc = np.empty(kmax, np.int64), np.empty(d)
    near = np.empty(kmax, np.int64)  # the facet's candidates that some point may reach
    xq, pbox = np.empty((nq, d)), np.empty((2, d))
    for f in range(nsf):
        # the facet's points x1 and their bounding box; a candidate whose box lies beyond
        # ``reach`` from it is beyond reach from every point (the per-point test below
        # skips it: rounding is monotone, so no point's box distance is shorter than the
        # boxes' distance, bit for bit) and is dropped for the whole facet, keeping the
        # candidates' order (the sweep's result is that of the full list)
        pbox[0, :] = np.inf
        pbox[1, :] = -np.inf
        for q in range(nq):
            if qp_w[f, q] != 0.0:
                _slave_point(ftype_s, xs[f], qp_xi[f, q], N, dN, ddN, xq[q])
                for c in range(d):
                    pbox[0, c] = min(pbox[0, c], xq[q, c])
                    pbox[1, c] = max(pbox[1, c], xq[q, c])
        nc = 0
        for j in range(cand_off[f], cand_off[f + 1]):
            if _box_box_distance2(mbox, cand[j], pbox) <= reach[f] ** 2:
                near[nc] = cand[j]
                nc += 1
        if nearest_first:  # the facet's own nearest-first order (_pair_nearest's forder)
            for c in range(d):
                fc[c] = 0.0
                for a in range(ns):
                    fc[c] += xs[f, a, c] / ns
            for i in range(nc):
                box2[i] = _box_distance2(mbox, near[i], fc)
                j = i
                while j > 0 and box2[forder[j - 1]] > box2[i]:
                    forder[j] = forder[j - 1]
                    j -= 1
                forder[j] = i
        normal_done = False
        for q in range(nq):
            qp_m[f, q] = -1
            qp_g[f, q] = 0.0
            if qp_w[f, q] == 0.0:
                continue
            xi = qp_xi[f, q]
            x1 = xq[q]
            if not (s_affine and normal_done):  # an affine facet's normal: once
                unit_normal_in(xs[f], ftype_s, ssign[f], xi, nus, ws)
                normal_done = True
            if nearest_first:
                k = _pair_nearest(
                    ftype_m, x1, nus, xm, mbox, msign, mkey, near, 0, nc, max_depth[f],
                    reach[f], outside_tol, z0, num, wm, box2, order, done, valid, vout, vdist,
                    vgap, vz, forder, mnu, mnv, mjn,
                )  # fmt: skip
                if k >= 0:
                    qp_m[f, q] = near[k]
                    qp_g[f, q] = vgap[k]
                    for a in range(km):
                        qp_zeta[f, q, a] = vz[k, a]
                    continue
            # prefer facets containing the projection (closest |g|); failing that, the facet
            # whose projection lies least outside it (≤ outside_tol in ζ): a point near a
            # concave kink of the deformed master projects just outside both neighbours;
            # only for a point left unpaired, a second sweep: the blind spot of a convex
            # vertex (g > 0, the extended projection within BLIND_SPOT_SLOPE g of the facet)
            best = -1
            best_dist = np.inf
            best_g = 0.0
            best_out = np.inf
            for sweep in range(2):
                if sweep == 1 and best >= 0:
                    break
                for k in range(nc):
                    m = near[k]
                    # cheap rejection: distance from x1 to the facet's bounding box
                    dbox = _box_distance2(mbox, m, x1)
                    # a facet farther than the best one cannot win while the best contains
                    # the point (``_better`` ranks "less outside" first); while the best
                    # lies outside its facet, a farther facet that contains the point must
                    # still be projected, or the winner depends on the candidates' order
                    tie = PAIR_TIE_TOL * reach[f]
                    limit = best_dist + tie if best_out <= INSIDE_TOL else np.inf
                    if dbox > min(limit, reach[f]) ** 2:
                        continue
                    xm_m = xm[m]
                    if nearest_first and done[k]:
                        # the same projection, made by _pair_nearest for this point
                        for a in range(km):
                            zeta[a] = vz[k, a]
                    elif not (affine and _project_affine(x1, xm_m, zeta)):
                        # project_in takes that closed form first: called for it, its
                        # array arguments' reference counts cost 7 times the projection
                        project_in(x1, xm_m, ftype_m, z0, zeta, 1e-13, np.int64(PROJECT_MAXIT), wm)
                    out = _outside(ftype_m, zeta)
                    if out > best_out + INSIDE_TOL or (sweep == 0 and out > outside_tol):
                        continue
                    if affine:
                        _affine_normal(m, mnu, num)
                    else:
                        unit_normal_in(xm_m, ftype_m, msign[m], zeta, num, wm)
                    if not faces(nus, num):
                        continue
                    if affine:
                        g = _affine_gap(ftype_m, x1, xm, m, zeta, mnv, mjn)
                    else:
                        g = gap_only_in(x1, xm_m, ftype_m, msign[m], zeta, wm)
                    if g < -max_depth[f]:
                        continue
                    if out > outside_tol and (
                        g <= 0.0
                        or _distance_outside(ftype_m, xm_m, zeta, Nm, dNm, ddNm, zc, xa, xb)
                        > BLIND_SPOT_SLOPE * g
                    ):
                        continue
                    out = max(out, INSIDE_TOL)
                    if _better(out, abs(g), mkey, m, best_out, best_dist, max(best, 0), tie):
                        best_out = out
                        best_dist = abs(g)
                        best = m
                        best_g = g
                        for a in range(km):
                            best_z[a] = zeta[a]
            qp_m[f, q] = best
            qp_g[f, q] = best_g
            for a in range(km):
                qp_zeta[f, q, a] = best_z[a] if best >= 0 else np.nan


@numba.njit(cache=True)
def forced_points(ftype_s, ftype_m, xs, qp_xi, qp_m, xm, msign, qp_zeta, qp_g):
    """Gap at points already paired with a master facet (segment integration).

    qp_m (nsf, nq) is given (−1: unused slot); the closest-point projection onto that
    master facet is used even slightly outside it (segments come from a clipping along
    the slave normal). On affine masters the closed form and :func:`_affine_frames`'
    normals, as in :func:`pair_points` (the same bits as project_in and gap_only_in).
    """
    nsf, ns, d = xs.shape
    nq = qp_xi.shape[1]
    ks = tdim(ftype_s)
    km = tdim(ftype_m)
    N = np.empty(ns)
    dN = np.empty((ns, ks))
    ddN = np.empty((ns, ks, ks))
    x1 = np.empty(d)
    zeta = np.empty(km)
    z0 = np.full(km, np.nan)
    wm = work(ftype_m)
    _, mnv, mjn = _affine_frames(ftype_m, xm, msign)
    affine = mnv.shape[0] > 0
    for f in range(nsf):
        for q in range(nq):
            m = qp_m[f, q]
            qp_g[f, q] = 0.0
            if m < 0:
                continue
            _slave_point(ftype_s, xs[f], qp_xi[f, q], N, dN, ddN, x1)
            xm_m = xm[m]
            if affine and _project_affine(x1, xm_m, zeta):
                qp_g[f, q] = _affine_gap(ftype_m, x1, xm, m, zeta, mnv, mjn)
            else:
                project_in(x1, xm_m, ftype_m, z0, zeta, 1e-13, np.int64(PROJECT_MAXIT), wm)
                qp_g[f, q] = gap_only_in(x1, xm_m, ftype_m, msign[m], zeta, wm)
            for a in range(km):
                qp_zeta[f, q, a] = zeta[a]


@numba.njit(cache=True)
def nodal_integrals(ftype_phi, qp_xi, qp_w, qp_m, qp_g, node_of, A, G):
    """A^I = Σ w J₀ Φ_I [paired] and G^I = Σ w J₀ Φ_I g over the owned nodes (node_of ≥ 0).

    node_of (nsf, nphi): owned-node index of the facet's mixed nodes, −1 if not owned.
    A, G (n_nodes,) are overwritten.
    """
    nsf, nq, k = qp_xi.shape
    nphi = node_of.shape[1]
    Phi = np.empty(9)
    dP = np.empty((9, k))
    ddP = np.empty((9, k, k))
    A[:] = 0.0
    G[:] = 0.0
    for f in range(nsf):
        for q in range(nq):
            if qp_m[f, q] < 0:
                continue
            shape(ftype_phi, qp_xi[f, q], Phi, dP, ddP)
            for i in range(nphi):
                node = node_of[f, i]
                if node >= 0:
                    A[node] += qp_w[f, q] * Phi[i]
                    G[node] += qp_w[f, q] * Phi[i] * qp_g[f, q]


@numba.njit(cache=True)
def facet_mass(ftype_phi, qp_xi, qp_w, qp_m, Mf):
    """Mortar mass matrix per slave facet, M_f[i, j] = Σ_q w J₀ Φ_i Φ_j [q paired].

    Mf (nsf, nphi, nphi) is overwritten. Summed over the facets, M_IJ = ∫ Φ_I Φ_J dA₀ over
    the paired part of the slave surface, so that Σ_J M_IJ = A^I (:func:`nodal_integrals`).
    """
    nsf, nq, k = qp_xi.shape
    nphi = Mf.shape[1]
    Phi = np.empty(9)
    dP = np.empty((9, k))
    ddP = np.empty((9, k, k))
    Mf[:] = 0.0
    for f in range(nsf):
        for q in range(nq):
            if qp_m[f, q] < 0:
                continue
            shape(ftype_phi, qp_xi[f, q], Phi, dP, ddP)
            for i in range(nphi):
                wi = qp_w[f, q] * Phi[i]
                for j in range(nphi):
                    Mf[f, i, j] += wi * Phi[j]


@numba.njit(cache=True)
def _local_derivatives(
    ftype_s,
    ftype_m,
    xs_f,
    xm_m,
    sign,
    xi,
    zeta,
    dg_loc,
    dg,
    d2g,
    x1,
    N,
    dN,
    ddN,
):
    """g, ∂g/∂u with respect to the local dofs [slave facet, master facet] of one point
    (dg_loc), and the derivatives with respect to y = [x1, xm] (dg, d2g)."""
    ns = xs_f.shape[0]
    nm = xm_m.shape[0]
    d = xs_f.shape[1]
    _slave_point(ftype_s, xs_f, xi, N, dN, ddN, x1)
    g = gap_and_derivatives(x1, xm_m, ftype_m, sign, zeta, dg, d2g)
    # T maps local dofs to y = [x1, xm]: dx1_c/dxs_{a,c} = N_a, identity on the master block
    nsd = ns * d
    for a in range(ns):
        for c in range(d):
            dg_loc[a * d + c] = N[a] * dg[c]
    for j in range(nm * d):
        dg_loc[nsd + j] = dg[d + j]
    return g


@numba.njit(cache=True)
def _local_gradient(ftype_s, ftype_m, xs_f, xm_m, sign, xi, zeta, dg_loc, dg, x1, N, dN, ddN, wm):
    """∂g/∂u of one point with respect to its local dofs [slave facet, master facet]
    (dg_loc) and to y = [x1, xm] (dg), as :func:`_local_derivatives` gives them, bit for
    bit, without the gap and its Hessian: ∂g/∂x1 = ν(ζ), ∂g/∂x^m_a = −N_a(ζ) ν(ζ)
    (:func:`.gap.gap_and_derivatives`; ν from :func:`.gap.unit_normal_in`, the same
    operations). wm: the work arrays of :func:`.gap.work` for ftype_m."""
    ns = xs_f.shape[0]
    nm = xm_m.shape[0]
    d = xs_f.shape[1]
    _slave_point(ftype_s, xs_f, xi, N, dN, ddN, x1)
    nu = wm[6]
    unit_normal_in(xm_m, ftype_m, sign, zeta, nu, wm)
    Nm = wm[0]
    for i in range(d):
        dg[i] = nu[i]
    for a in range(nm):
        for i in range(d):
            dg[d + a * d + i] = -Nm[a] * nu[i]
    nsd = ns * d
    for a in range(ns):
        for c in range(d):
            dg_loc[a * d + c] = N[a] * dg[c]
    for j in range(nm * d):
        dg_loc[nsd + j] = dg[d + j]


@numba.njit(cache=True)
def _workspace(ftype_s, ns, nm, d):
    """Work arrays of the point loops: slave shape functions (N, dN, ddN), mixed shape
    functions (Phi, dP, ddP; up to 9 nodes), the slave point x1, the gap derivatives with
    respect to y = [x1, xm] (dg, d2g) and to the local dofs (dg_loc)."""
    ks = tdim(ftype_s)
    nloc = (ns + nm) * d
    ny = d * (1 + nm)
    return (
        np.empty(ns),
        np.empty((ns, ks)),
        np.empty((ns, ks, ks)),
        np.empty(9),
        np.empty((9, ks)),
        np.empty((9, ks, ks)),
        np.empty(d),
        np.empty(ny),
        np.empty((ny, ny)),
        np.empty(nloc),
    )


@numba.njit(cache=True)
def contact_terms(
    ftype_s,
    ftype_m,
    ftype_phi,
    xs,
    xm,
    msign,
    qp_xi,
    qp_w,
    qp_m,
    qp_zeta,
    sdofs,
    mdofs,
    node_of,
    p,
    res_idx,
    res_val,
    force,
):
    """The contact residual's entries per paired point, and the contact force.

    Inputs: xs (nsf, ns, d), xm (nmf, nm, d) current nodes, msign (nmf,), qp_xi (nsf, nq,
    ks), qp_w (nsf, nq) weights w J₀, qp_m (nsf, nq) paired master facet or −1, qp_zeta
    (nsf, nq, km) the converged closest-point projections of the paired points (as
    :func:`pair_points`); node_of (nsf, nphi) owned-node index or −1; p (n_nodes,) nodal
    pressures; sdofs (nsf, ns·d), mdofs (nmf, nm·d) global dofs (−1 = ignored by PETSc);
    nloc = (ns + nm)·d.

    Per paired point (f, q) with master m, p_w = w J₀ Σ_I p^I Φ_I(ξ_q) over the owned nodes
    I of facet f (node_of ≥ 0). Outputs: res_idx, res_val (n_paired, nloc): entries of
    R_c = −Σ_I p^I B^I per PAIRED point (qp_m ≥ 0), in (facet, point) order: res_idx =
    [sdofs[f], mdofs[m]], res_val = −p_w ∂g/∂u (local dofs); a row with p_w = 0 (weight 0,
    or no pressure at its facet's owned nodes) gets res_idx −1 and its res_val row is left
    as given (pass zeros). force (d,) += Σ_q p_w ν(ζ_q) = Σ_I p^I Σ_q w J₀ Φ_I ν, the force
    of the master on the slave (ν = ∂g/∂x₁, the master's outward unit normal). The
    tangent's terms (the gap's Hessian, the rows B^I) are :func:`jacobian_terms`'.
    """
    nsf, ns, d = xs.shape
    nq = qp_xi.shape[1]
    nm = xm.shape[1]
    nphi = node_of.shape[1]
    nloc = (ns + nm) * d
    N, dN, ddN, Phi, dP, ddP, x1, dg, d2g, dg_loc = _workspace(ftype_s, ns, nm, d)
    wm = work(ftype_m)
    row = -1
    for f in range(nsf):
        for q in range(nq):
            m = qp_m[f, q]
            if m < 0:
                continue
            row += 1
            for j in range(nloc):
                res_idx[row, j] = -1
            shape(ftype_phi, qp_xi[f, q], Phi, dP, ddP)
            pw = 0.0
            for i in range(nphi):
                node = node_of[f, i]
                if node >= 0:
                    pw += p[node] * Phi[i]
            pw *= qp_w[f, q]
            if pw == 0.0:
                continue
            # no Hessian of the gap
            _local_gradient(
                ftype_s,
                ftype_m,
                xs[f],
                xm[m],
                msign[m],
                qp_xi[f, q],
                qp_zeta[f, q],
                dg_loc,
                dg,
                x1,
                N,
                dN,
                ddN,
                wm,
            )
            for c in range(d):
                force[c] += pw * dg[c]
            for j in range(ns * d):
                res_idx[row, j] = sdofs[f, j]
            for j in range(nm * d):
                res_idx[row, ns * d + j] = mdofs[m, j]
            for j in range(nloc):
                res_val[row, j] = -pw * dg_loc[j]


@numba.njit(cache=True)
def _add_point_hessian(ns, nm, d, wq, N, d2g, h):
    """h += wq T^T d2g T (nloc × nloc) for one point, T the map of the local dofs
    [slave facet, master facet] to y = [x1, xm] (x1 = Σ_a N_a x_a; :func:`_local_derivatives`)."""
    nsd = ns * d
    nmd = nm * d
    for a in range(ns):
        wa = wq * N[a]
        for b in range(ns):
            wab = wa * N[b]
            for c in range(d):
                for c2 in range(d):
                    h[a * d + c, b * d + c2] += wab * d2g[c, c2]
        for c in range(d):
            for j in range(nmd):
                h[a * d + c, nsd + j] += wa * d2g[c, d + j]
                h[nsd + j, a * d + c] += wa * d2g[d + j, c]
    for i in range(nmd):
        for j in range(nmd):
            h[nsd + i, nsd + j] += wq * d2g[d + i, d + j]


@numba.njit(cache=True)
def _moment_path(ftype_m, xm_m, zeta):
    """Whether the Hessian block of a group on master facet xm_m (nm, d) is built from its
    point moments (:func:`_add_group_hessian`): the facet is affine (INTERVAL1, TRIANGLE1)
    and not degenerate by the metric test of :func:`.gap._project_affine` (zeta (km,) is
    a work array). Otherwise the group's points add their blocks one by one."""
    if ftype_m != INTERVAL1 and ftype_m != TRIANGLE1:
        return False
    return _project_affine(xm_m[0], xm_m, zeta)


@numba.njit(cache=True)
def _add_group_hessian(
    ftype_m, xm_m, sign, ns, d, mom, cx, cz, csum, ax, az, asum, mixed, y, z, dg, d2g, d2g0, h
):
    r"""h += Σ_q c_q T_qᵀ ∂²g(x1_q, ζ_q) T_q (nloc × nloc) for the points q of one group
    on an AFFINE master facet xm_m (nm, d) (:func:`_moment_path`), from the group's
    moments instead of one gap Hessian per point (:func:`_add_point_hessian`).

    On an affine facet S(ζ) = x_0 + Σ_α ζ_α a_α the parametrisation's second derivatives
    vanish (SS = 0, hence b = K = 0 in :func:`.gap.gap_and_derivatives`), and with
    E_b = Σ_α N_{b,α} D_α constant over the facet the Hessian with respect to
    y = [x1, xm] at a point (x1, ζ) is

        ∂²g/∂x1² = 0,   ∂²g/∂x1∂x^m_b = E_b,
        ∂²g/∂x^m_a∂x^m_b = −N_a(ζ) E_b − N_b(ζ) E_aᵀ − g(x1, ζ) E_aᵀ E_b,

    g = (x1 − S(ζ))·ν: jointly affine in (x1, ζ) (these are gap_and_derivatives'
    formulas, which read ζ only through N(ζ) and S(ζ); they are g's Hessian where ζ is
    the projection onto the facet's plane, as it is at pinned and forced points too,
    :func:`forced_points`; the sum below is theirs for any ζ). With
    T_q: dx1_c/dxs_{a,c} = N_a(ξ_q), identity on the master block, the group's block is

        slave–slave 0,   slave a – master b: M_a E_b,   M_a = Σ_q c_q N_a(ξ_q),
        master–master Σ_q c_q F(y_q) = C F(ȳ) for C = Σ_q c_q, ȳ = Σ_q c_q y_q / C,

    F the master–master block, y_q = (x1_q, ζ_q). When the c_q are of one sign
    (``mixed`` False; c_q = −p_w < 0 at every point of a pressed group is the usual
    case; the caller reads it off the sums: Σ_q |c_q| and |Σ_q c_q|, summed in the same
    order, are then equal bit for bit) ȳ is a convex combination of the y_q and F is
    evaluated once there (where rounding hides a tiny term of the other sign, C ≠ 0 and
    C F(ȳ) is still the sum: F is affine). Otherwise
    (C may vanish) with s = Σ_q |c_q|, y⁰ = Σ_q |c_q| y_q / s and
    y¹ = y⁰ + (Σ_q c_q y_q − C y⁰)/s (both within the hull's size of the points),
    Σ_q c_q F(y_q) = s F(y¹) + (C − s) F(y⁰) since F is affine.

    Inputs: mom (ns,) the M_a, cx (d,) Σ c_q x1_q, cz (km,) Σ c_q ζ_q, csum = C;
    ax (d,), az (km,), asum = s the same with |c_q|; y (d,), z (km,), dg (ny,),
    d2g, d2g0 (ny, ny) work arrays (ny = d (1 + nm)).
    """
    nm = xm_m.shape[0]
    km = z.shape[0]
    nsd = ns * d
    nmd = nm * d
    if mixed:
        for i in range(d):
            y[i] = ax[i] / asum
        for a in range(km):
            z[a] = az[a] / asum
        gap_and_derivatives(y, xm_m, ftype_m, sign, z, dg, d2g0)
        r = csum / asum
        for i in range(d):
            y[i] = ax[i] / asum * (1.0 - r) + cx[i] / asum
        for a in range(km):
            z[a] = az[a] / asum * (1.0 - r) + cz[a] / asum
        gap_and_derivatives(y, xm_m, ftype_m, sign, z, dg, d2g)
        w1 = asum
        w0 = csum - asum
    else:
        for i in range(d):
            y[i] = cx[i] / csum
        for a in range(km):
            z[a] = cz[a] / csum
        gap_and_derivatives(y, xm_m, ftype_m, sign, z, dg, d2g)
        w1 = csum
        w0 = 0.0
    for a in range(ns):
        wa = mom[a]
        for c in range(d):
            for j in range(nmd):
                h[a * d + c, nsd + j] += wa * d2g[c, d + j]
                h[nsd + j, a * d + c] += wa * d2g[d + j, c]
    if mixed:
        for i in range(nmd):
            for j in range(nmd):
                h[nsd + i, nsd + j] += w1 * d2g[d + i, d + j] + w0 * d2g0[d + i, d + j]
    else:
        for i in range(nmd):
            for j in range(nmd):
                h[nsd + i, nsd + j] += w1 * d2g[d + i, d + j]


@numba.njit(cache=True)
def _add_group_rows(ftype_m, xm_m, sign, ns, d, nphi, base, off, r_s, r_t, r_z, z_0, wm, b_val):
    """The entries of a group's rows B^I from its moments, on an affine master facet
    xm_m (nm, d) (:func:`_moment_path`): there ∂g/∂x1 = ν and ∂g/∂x^m_a = −N_a(ζ) ν with
    the facet's constant unit normal ν and N_a affine in ζ (:func:`_local_gradient`), so
    Σ_q w Φ_i ∂g_q/∂u = [Σ_q w Φ_i N_a(ξ_q) ν, −(N_a(0) Σ_q w Φ_i + ∇N_a · Σ_q w Φ_i ζ_q) ν]
    for any ζ_q. r_s (nphi, ns), r_t (nphi,), r_z (nphi, km): those sums for node i of the
    slave facet; base (nphi,) where the facet's groups start in node i's row (−1: no row),
    off the group's offset there; b_val the rows' values, added to. z_0 (km,) zeros; wm the
    work arrays of :func:`.gap.work` for ftype_m."""
    nm, km = xm_m.shape[0], z_0.shape[0]
    nsd = ns * d
    nu = wm[6]
    unit_normal_in(xm_m, ftype_m, sign, z_0, nu, wm)  # ν, with N(0) and ∇N in wm[0], wm[1]
    Nm, dNm = wm[0], wm[1]
    for i in range(nphi):
        if base[i] < 0:
            continue
        o = base[i] + off
        for a in range(ns):
            for c in range(d):
                b_val[o + a * d + c] += r_s[i, a] * nu[c]
        for a in range(nm):
            na = r_t[i] * Nm[a]
            for k in range(km):
                na += r_z[i, k] * dNm[a, k]
            for c in range(d):
                b_val[o + nsd + a * d + c] -= na * nu[c]


@numba.njit(cache=True)
def jacobian_terms(
    ftype_s,
    ftype_m,
    ftype_phi,
    xs,
    xm,
    msign,
    qp_xi,
    qp_w,
    qp_m,
    qp_zeta,
    sdofs,
    mdofs,
    node_of,
    p,
    mask,
    want_hess,
):
    """The tangent's point terms in one pass, summed per (slave facet, master facet) pair:
    the Hessian blocks −p_w ∂²g/∂u² and the rows B^I = ∂G^I/∂u = Σ_q w J₀ Φ_I(ξ_q) ∂g_q/∂u,
    compressed (:func:`compress_rows`).

    The leading arguments are those of :func:`contact_terms`; p (n_nodes,) the nodal
    pressures, mask (n_nodes,) the nodes whose rows B^I are wanted (mask > 0: kcoef for
    the B^I ⊗ B^I term). The paired points of a slave facet f with the same master facet
    m (a group) share their local dofs [sdofs[f], mdofs[m]], so their terms are summed
    before they leave the kernel: one Hessian block per group instead of one per point
    (hertz3d, P1 triangles: 3.1 points a block at degree 6, 1.8 at degree 4), and nloc
    entries per group in a row B^I before compression.

    Returns (h_idx, h_val, c_off, c_idx, c_val):

    * h_idx (nh, nloc) the dofs [sdofs[f], mdofs[m]] and h_val (nh, nloc, nloc)
      −Σ_q p_w ∂²g/∂u² over the group's points, for every group with a point of p_w ≠ 0
      (p_w as in :func:`contact_terms`), in the order of their first such point
      ((facet, point) order); (0, nloc) and (0, nloc, nloc) unless ``want_hess``. The
      blocks are the per-point blocks −p_w ∂²g/∂u² (rows of :func:`contact_terms` with
      p_w ≠ 0) summed per group.
    * c_off (n_nodes + 1,), c_idx, c_val: the rows B^I of the owned nodes with mask > 0 as
      :func:`compress_rows` gives them (sorted dofs ≥ 0, each once; c_idx and c_val are
      longer than c_off[-1]): per paired point of every facet of I (weight 0 included),
      the nloc entries w J₀ Φ_I ∂g/∂u at the dofs [sdofs[f], mdofs[m]], compressed;
      values to round-off (the points of a group are summed first).

    On an affine master facet (INTERVAL1, TRIANGLE1, not degenerate: :func:`_moment_path`)
    a group's Hessian block comes from its point moments (:func:`_add_group_hessian`:
    M_a = Σ_q c_q N_a(ξ_q), Σ_q c_q x1_q, Σ_q c_q ζ_q with c_q = −p_w, and one or two
    gap Hessians per group), equal to the sum of the per-point blocks to round-off, for
    any ζ_q (pinned and forced points included). The group's entries of the rows B^I
    there come from moments too (:func:`_add_group_rows`: Σ_q w Φ_i N_a(ξ_q), Σ_q w Φ_i,
    Σ_q w Φ_i ζ_q per node i, and the facet's one normal), equal to the per-point sums to
    round-off; the cost per point is then that of the slave and mixed shape functions.
    Other master facets: one gap Hessian and one gap gradient per point
    (:func:`_add_point_hessian`, :func:`_local_gradient`).
    """
    nsf, ns, d = xs.shape
    nq = qp_xi.shape[1]
    nm = xm.shape[1]
    nphi = node_of.shape[1]
    nloc = (ns + nm) * d
    nsd = ns * d
    n_nodes = mask.shape[0]
    N, dN, ddN, Phi, dP, ddP, x1, dg, d2g, dg_loc = _workspace(ftype_s, ns, nm, d)
    wm = work(ftype_m)
    # pass 1: the groups of each facet, p_w, the Hessian blocks and the rows' lengths
    gid = np.full((nsf, nq), -1, np.int64)  # group of the point within its facet
    gm = np.empty((nsf, nq), np.int64)  # master facet of the group
    ngrp = np.zeros(nsf, np.int64)
    hslot = np.full((nsf, nq), -1, np.int64)  # Hessian block of the group
    pws = np.zeros((nsf, nq))
    need = np.zeros(nsf, np.bool_)
    b_count = np.zeros(n_nodes, np.int64)
    nh = 0
    for f in range(nsf):
        ng = 0
        for q in range(nq):
            m = qp_m[f, q]
            if m < 0:
                continue
            g = -1
            for t in range(ng):
                if gm[f, t] == m:
                    g = t
                    break
            if g < 0:
                g = ng
                gm[f, g] = m
                ng += 1
            gid[f, q] = g
            if want_hess:
                shape(ftype_phi, qp_xi[f, q], Phi, dP, ddP)
                pw = 0.0
                for i in range(nphi):
                    node = node_of[f, i]
                    if node >= 0:
                        pw += p[node] * Phi[i]
                pw *= qp_w[f, q]
                pws[f, q] = pw
                if pw != 0.0 and hslot[f, g] < 0:
                    hslot[f, g] = nh
                    nh += 1
        ngrp[f] = ng
        for i in range(nphi):
            node = node_of[f, i]
            if node >= 0 and mask[node] > 0.0:
                need[f] = True
                b_count[node] += ng * nloc
    h_idx = np.empty((nh, nloc), np.int64)
    h_val = np.zeros((nh, nloc, nloc))
    b_off = np.zeros(n_nodes + 1, np.int64)
    for r in range(n_nodes):
        b_off[r + 1] = b_off[r] + b_count[r]
    b_idx = np.empty(b_off[n_nodes], np.int64)
    b_val = np.zeros(b_off[n_nodes])
    fill = b_off[:-1].copy()
    base = np.empty(nphi, np.int64)  # where facet f's groups start in the row of its node i
    # the moments of the groups on affine master facets (_add_group_hessian), per group
    km = tdim(ftype_m)
    aff = np.zeros(nq, np.bool_)  # the group's master facet affine (_moment_path)
    mom = np.empty((nq, ns))
    cx = np.empty((nq, d))
    cz = np.empty((nq, km))
    ax = np.empty((nq, d))
    az = np.empty((nq, km))
    csum = np.empty(nq)
    asum = np.empty(nq)
    yb = np.empty(d)
    zb = np.empty(km)
    d2g0 = np.empty_like(d2g)
    # the row moments of the groups on affine master facets, per group and node i of the
    # facet: Σ_q w Φ_i N_a(ξ_q) (ns), Σ_q w Φ_i, Σ_q w Φ_i ζ_q (km)
    r_s = np.empty((nq, nphi, ns))
    r_t = np.empty((nq, nphi))
    r_z = np.empty((nq, nphi, km))
    z_0 = np.zeros(km)
    # pass 2: the derivatives of the points that add to a block or a row
    for f in range(nsf):
        ng = ngrp[f]
        if ng == 0:
            continue
        for g in range(ng):
            s = hslot[f, g]
            aff[g] = (s >= 0 or need[f]) and _moment_path(ftype_m, xm[gm[f, g]], zb)
            if need[f] and aff[g]:
                r_s[g] = 0.0
                r_t[g] = 0.0
                r_z[g] = 0.0
            if s >= 0 and aff[g]:  # a Hessian block from moments
                mom[g, :] = 0.0
                cx[g, :] = 0.0
                cz[g, :] = 0.0
                ax[g, :] = 0.0
                az[g, :] = 0.0
                csum[g] = 0.0
                asum[g] = 0.0
            if s >= 0:
                for j in range(nsd):
                    h_idx[s, j] = sdofs[f, j]
                for j in range(nloc - nsd):
                    h_idx[s, nsd + j] = mdofs[gm[f, g], j]
        if need[f]:
            for i in range(nphi):
                node = node_of[f, i]
                base[i] = -1
                if node < 0 or mask[node] <= 0.0:
                    continue
                base[i] = fill[node]
                fill[node] += ng * nloc
                for g in range(ng):
                    o = base[i] + g * nloc
                    for j in range(nsd):
                        b_idx[o + j] = sdofs[f, j]
                    for j in range(nloc - nsd):
                        b_idx[o + nsd + j] = mdofs[gm[f, g], j]
        for q in range(nq):
            g = gid[f, q]
            if g < 0:
                continue
            m = qp_m[f, q]
            pw = pws[f, q]
            s = hslot[f, g] if pw != 0.0 else -1
            if s < 0 and not need[f]:
                continue
            if s >= 0 and not aff[g]:
                _local_derivatives(
                    ftype_s,
                    ftype_m,
                    xs[f],
                    xm[m],
                    msign[m],
                    qp_xi[f, q],
                    qp_zeta[f, q],
                    dg_loc,
                    dg,
                    d2g,
                    x1,
                    N,
                    dN,
                    ddN,
                )
                _add_point_hessian(ns, nm, d, -pw, N, d2g, h_val[s])
            elif need[f] and not aff[g]:  # no Hessian of the gap (N and x1 come with it)
                _local_gradient(
                    ftype_s,
                    ftype_m,
                    xs[f],
                    xm[m],
                    msign[m],
                    qp_xi[f, q],
                    qp_zeta[f, q],
                    dg_loc,
                    dg,
                    x1,
                    N,
                    dN,
                    ddN,
                    wm,
                )
            else:  # moments only (N and x1)
                _slave_point(ftype_s, xs[f], qp_xi[f, q], N, dN, ddN, x1)
            if s >= 0 and aff[g]:
                c = -pw
                ac = abs(c)
                for a in range(ns):
                    mom[g, a] += c * N[a]
                for i in range(d):
                    cx[g, i] += c * x1[i]
                    ax[g, i] += ac * x1[i]
                zq = qp_zeta[f, q]
                for a in range(km):
                    cz[g, a] += c * zq[a]
                    az[g, a] += ac * zq[a]
                csum[g] += c
                asum[g] += ac
            if need[f]:
                shape(ftype_phi, qp_xi[f, q], Phi, dP, ddP)
                zq = qp_zeta[f, q]
                for i in range(nphi):
                    if base[i] < 0:
                        continue
                    wphi = qp_w[f, q] * Phi[i]
                    if aff[g]:
                        for a in range(ns):
                            r_s[g, i, a] += wphi * N[a]
                        r_t[g, i] += wphi
                        for a in range(km):
                            r_z[g, i, a] += wphi * zq[a]
                        continue
                    o = base[i] + g * nloc
                    for j in range(nloc):
                        b_val[o + j] += wphi * dg_loc[j]
        for g in range(ng):
            if need[f] and aff[g]:
                _add_group_rows(
                    ftype_m, xm[gm[f, g]], msign[gm[f, g]], ns, d, nphi, base, g * nloc,
                    r_s[g], r_t[g], r_z[g], z_0, wm, b_val,
                )  # fmt: skip
            if hslot[f, g] >= 0 and aff[g]:
                m = gm[f, g]
                _add_group_hessian(
                    ftype_m,
                    xm[m],
                    msign[m],
                    ns,
                    d,
                    mom[g],
                    cx[g],
                    cz[g],
                    csum[g],
                    ax[g],
                    az[g],
                    asum[g],
                    asum[g] != abs(csum[g]),  # c_q of both signs (one sign: equal, exactly)
                    yb,
                    zb,
                    dg,
                    d2g,
                    d2g0,
                    h_val[hslot[f, g]],
                )
    c_off = np.zeros(n_nodes + 1, np.int64)
    c_idx = np.empty_like(b_idx)
    c_val = np.empty_like(b_val)
    compress_rows(b_off, b_idx, b_val, c_off, c_idx, c_val)
    return h_idx, h_val, c_off, c_idx, c_val


@numba.njit(cache=True)
def compress_rows(b_off, b_idx, b_val, c_off, c_idx, c_val):
    """Merge duplicate dofs of every row (sorted), dropping dofs < 0; c_off gets the new offsets.

    b_off (n + 1,), b_idx, b_val (b_off[n],): the rows (row r in b_off[r]:b_off[r+1], any
    order, repeats). Outputs c_off (n + 1,), c_idx, c_val (at least b_off[n] long): row r
    in c_off[r]:c_off[r+1], each dof ≥ 0 once, ascending, with the sum of its values.
    """
    n = b_off.shape[0] - 1
    c_off[0] = 0
    for r in range(n):
        s, e = b_off[r], b_off[r + 1]
        order = np.argsort(b_idx[s:e])
        o = c_off[r]
        last = -2
        for t in range(e - s):
            k = s + order[t]
            i = b_idx[k]
            if i < 0:
                continue
            if i == last:
                c_val[o - 1] += b_val[k]
            else:
                c_idx[o] = i
                c_val[o] = b_val[k]
                o += 1
                last = i
        c_off[r + 1] = o


@numba.njit(cache=True)
def point_xi_terms(
    ftype_s,
    ftype_m,
    ftype_phi,
    xs,
    xm,
    msign,
    qp_xi,
    qp_w,
    qp_m,
    qp_zeta,
    sdofs,
    mdofs,
    node_of,
    b,
    db,
    g,
    gxi,
    phi,
    dphi,
):
    r"""Per paired point (rows as in :func:`contact_terms`, weight 0 included), the gap and
    its derivatives along the slave parameters ξ_β (β < k), for the linearisation of moving
    segment points:

    b = ∂g/∂u (local dofs), db_β = d(∂g/∂u)/dξ_β, g, gxi_β = dg/dξ_β = ν·x_s,β(ξ) (the
    closest point is stationary), phi = Φ_I(ξ), dphi_β = ∂Φ_I/∂ξ_β. With y = [x₁, x_m] and
    the slave point x₁ = Σ_a N_a(ξ) x_a moving by x_s,β(ξ) dξ_β (x_s,β = Σ_a ∂_βN_a x_a):

        db_β(a,c) = ∂_β N_a(ξ) ∂g/∂x₁_c + N_a(ξ) Σ_c' ∂²g/∂x₁_c∂x₁_c' x_s,β_c',
        db_β(master j) = Σ_c' ∂²g/∂xm_j∂x₁_c' x_s,β_c'.

    The leading arguments are those of :func:`contact_terms` (qp_w, sdofs, mdofs and
    node_of unused). Outputs: b (n_paired, nloc), db (n_paired, k, nloc); g (n_paired,),
    gxi (n_paired, k); phi (n_paired, nphi), dphi (n_paired, nphi, k).
    """
    nsf, ns, d = xs.shape
    nq = qp_xi.shape[1]
    nm = xm.shape[1]
    k = qp_xi.shape[2]
    nphi = phi.shape[1]
    N, dN, ddN, Phi, dP, ddP, x1, dg, d2g, dg_loc = _workspace(ftype_s, ns, nm, d)
    xp = np.empty((k, d))
    row = -1
    for f in range(nsf):
        for q in range(nq):
            m = qp_m[f, q]
            if m < 0:
                continue
            row += 1
            g[row] = _local_derivatives(
                ftype_s,
                ftype_m,
                xs[f],
                xm[m],
                msign[m],
                qp_xi[f, q],
                qp_zeta[f, q],
                dg_loc,
                dg,
                d2g,
                x1,
                N,
                dN,
                ddN,
            )
            shape(ftype_phi, qp_xi[f, q], Phi, dP, ddP)
            for i in range(nphi):
                phi[row, i] = Phi[i]
                for be in range(k):
                    dphi[row, i, be] = dP[i, be]
            for j in range(dg_loc.size):
                b[row, j] = dg_loc[j]
            for be in range(k):
                s = 0.0
                for c in range(d):
                    xp[be, c] = 0.0
                    for a in range(ns):
                        xp[be, c] += dN[a, be] * xs[f, a, c]
                    s += dg[c] * xp[be, c]
                gxi[row, be] = s
                for a in range(ns):
                    for c in range(d):
                        s = 0.0
                        for c2 in range(d):
                            s += d2g[c, c2] * xp[be, c2]
                        db[row, be, a * d + c] = dN[a, be] * dg[c] + N[a] * s
                for j in range(nm * d):
                    s = 0.0
                    for c2 in range(d):
                        s += d2g[d + j, c2] * xp[be, c2]
                    db[row, be, ns * d + j] = s
