r"""Closest-point projection and normal gap with exact first and second derivatives.

All functions are ``numba.njit(cache=True)`` kernels working on plain float64 arrays;
they can be called from Python or from other numba code.

Conventions
-----------
* Spatial dimension d = 2 (interval master facets) or d = 3 (triangle / quadrilateral
  master facets); k = d - 1 is the facet's topological dimension.
* ``xm`` (n_m, d): current coordinates of the master facet nodes, basix node order (see
  :mod:`dolfinx_mortar.kernels.shape`). ``x1`` (d,): current position of the slave point.
* Master surface :math:`S(\zeta) = \sum_a N_a(\zeta)\, x^m_a`, covariant basis
  :math:`a_\alpha = \partial S / \partial \zeta^\alpha`, metric
  :math:`m_{\alpha\beta} = a_\alpha\cdot a_\beta`.
* Unnormalised normal :math:`n = s\,(a_{1,y}, -a_{1,x})` in 2D and
  :math:`n = s\, a_1 \times a_2` in 3D, unit normal :math:`\nu = n/|n|`. The sign
  :math:`s = \pm 1` is supplied by the caller so that :math:`\nu` is the OUTWARD normal of
  the master body. :math:`|n|` is the surface Jacobian (length / area per reference unit).
* Closest-point projection :math:`\bar\zeta = \arg\min_\zeta \tfrac12 |x_1 - S(\zeta)|^2`,
  i.e. :math:`r_\alpha(\zeta) = -(x_1 - S)\cdot a_\alpha = 0`.
* Normal gap :math:`g = (x_1 - S(\bar\zeta))\cdot\nu(\bar\zeta)`: positive when the slave
  point is outside the master body, negative for penetration. Same length unit as the
  coordinates.
* Derivative variables :math:`y = [x_1, x^m_0, \dots, x^m_{n_m-1}]` (flattened,
  ``y = concatenate([x1, xm.ravel()])``), length :math:`n_y = d(1 + n_m)`; the component
  i of node a sits at index ``d + a*d + i``.

Projection validity (is :math:`\bar\zeta` inside the facet?) is the caller's decision:
use :func:`dolfinx_mortar.kernels.shape.inside`.
"""

import math

import numpy as np

from ._numba import numba
from .shape import INTERVAL1, QUAD1, TRIANGLE1, num_nodes, reference_centre, shape, tdim

#: Facing rule of every pairing (element and node integration: ``mortar.pair_points``,
#: which also pairs the friction's t_n points and the master frames' points; segment
#: integration: ``segment._faces``): a master facet takes part for a slave point only
#: where the angle between the slave's outward normal n_s and the master's inward normal
#: −ν is below MAX_FACING_ANGLE (degrees), n_s·ν < −cos θ_max (:func:`faces`). At the
#: angle θ the closest-point gap is cos θ times the distance the point travels along n_s
#: to the master's tangent plane; at 90° it measures a sideways distance only. The old
#: rule n_s·ν < 0 had its threshold where a side of the master body sits at rest: tilted
#: by ~2° under the load, the side paired with the slave points over the void beside the
#: master (their horizontal distance as the gap), and a slave node straddling the
#: master's edge averaged those with its penetration and read open (p = 0 while 6.5e-3
#: deep on a block pressed by 0.02 onto a narrower base; contact force −4.6 %). 85°: a
#: side takes part only once it has turned 5° towards the slave (the probe's turned 2°).
#: Newton iterates pair at up to 88° (ironing2d), and a lower threshold changes their
#: paths: at 45° ironing2d's (22 → 23 per solve, 25 → 30 per step), at 60° three tests'
#: (ironing2d's first press, the energy line search's, the chattering control's), at 75°
#: ironing2d's first press cut back; at 85° the full suite and the demos ran as before
#: (docs/method-notes.md, "Pairing", "Facing"). The callers' numba caches hold the
#: value: after changing it, ``touch dolfinx_mortar/kernels/*.py``.
MAX_FACING_ANGLE = 85.0
#: cos θ_max of :data:`MAX_FACING_ANGLE`
FACING_COS = math.cos(math.radians(MAX_FACING_ANGLE))


@numba.njit(cache=True)
def faces(nus, num):
    """Whether a master facet faces a slave point (the facing rule of :data:`MAX_FACING_ANGLE`):
    n_s·ν < −cos θ_max, with ``nus`` (d,) the slave's and ``num`` (d,) the master's
    outward unit normals (the master's at the point's projection)."""
    dot = 0.0
    for c in range(nus.shape[0]):
        dot += nus[c] * num[c]
    return dot < -FACING_COS


# line search parameters of the projection
_ARMIJO_C = 1.0e-4
_MAX_HALVINGS = 40
# full Newton steps smaller than this (reference units, max norm) skip the line search
_NEWTON_REGION = 1.0e-3
# |zeta| beyond this (reference units) is treated as divergence
_ZETA_MAX = 1.0e8


@numba.njit(cache=True)
def _carve_surface(buf, n, k, d):
    """Views N (n,), dN (n,k), ddN (n,k,k), S (d,), A (k,d), SS (k,k,d) at the start of the
    1D work buffer ``buf``; also returns the offset of the first unused entry."""
    o = 0
    N = buf[o : o + n]
    o += n
    dN = buf[o : o + n * k].reshape((n, k))
    o += n * k
    ddN = buf[o : o + n * k * k].reshape((n, k, k))
    o += n * k * k
    S = buf[o : o + d]
    o += d
    A = buf[o : o + k * d].reshape((k, d))
    o += k * d
    SS = buf[o : o + k * k * d].reshape((k, k, d))
    o += k * k * d
    return N, dN, ddN, S, A, SS, o


@numba.njit(cache=True)
def _surface_quad1(xm, zeta, N, dN, ddN, S, A, SS, want_ss):
    """:func:`_surface_in` (and with ``want_ss`` :func:`_surface`) of a QUAD1 facet, xm
    (4, d), unrolled over its 4 nodes: the same numbers, bit for bit, as the generic
    path (:func:`.shape.shape`'s products of the 1D functions 1 − x, x and their
    derivatives ∓1, 0, then the sums over the nodes in node order, from 0.0), which
    spends most of a projection's time on the loops and the 1D functions' dispatch (a
    t_n pairing of friction makes ~250 000 projections onto quads per call).

    Fills N (4,), dN (4, 2), ddN (4, 2, 2), S (d,), A (2, d) and, with ``want_ss``,
    SS (2, 2, d).
    """
    x = zeta[0]
    y = zeta[1]
    fx0 = 1.0 - x
    fy0 = 1.0 - y
    # basix order (x, y) = (0, 0), (1, 0), (0, 1), (1, 1): N_a = fx fy, dN_a = (dfx fy,
    # fx dfy), ddN_a = (ddfx fy, dfx dfy; dfx dfy, fx ddfy) with dfx = -1 (0) or 1 (1)
    # and ddfx = 0, written as the generic path's products (0 × f is ±0, or NaN)
    N[0] = fx0 * fy0
    N[1] = x * fy0
    N[2] = fx0 * y
    N[3] = x * y
    dN[0, 0] = -1.0 * fy0
    dN[1, 0] = 1.0 * fy0
    dN[2, 0] = -1.0 * y
    dN[3, 0] = 1.0 * y
    dN[0, 1] = fx0 * -1.0
    dN[1, 1] = x * -1.0
    dN[2, 1] = fx0 * 1.0
    dN[3, 1] = x * 1.0
    ddN[0, 0, 0] = 0.0 * fy0
    ddN[1, 0, 0] = 0.0 * fy0
    ddN[2, 0, 0] = 0.0 * y
    ddN[3, 0, 0] = 0.0 * y
    ddN[0, 1, 1] = fx0 * 0.0
    ddN[1, 1, 1] = x * 0.0
    ddN[2, 1, 1] = fx0 * 0.0
    ddN[3, 1, 1] = x * 0.0
    for a in range(4):
        v = (-1.0 if a == 0 or a == 2 else 1.0) * (-1.0 if a < 2 else 1.0)
        ddN[a, 0, 1] = v
        ddN[a, 1, 0] = v
    for i in range(xm.shape[1]):
        x0 = xm[0, i]
        x1 = xm[1, i]
        x2 = xm[2, i]
        x3 = xm[3, i]
        s = 0.0
        s += N[0] * x0
        s += N[1] * x1
        s += N[2] * x2
        s += N[3] * x3
        S[i] = s
        for al in range(2):
            t = 0.0
            t += dN[0, al] * x0
            t += dN[1, al] * x1
            t += dN[2, al] * x2
            t += dN[3, al] * x3
            A[al, i] = t
        if want_ss:
            for al in range(2):
                for be in range(2):
                    u = 0.0
                    u += ddN[0, al, be] * x0
                    u += ddN[1, al, be] * x1
                    u += ddN[2, al, be] * x2
                    u += ddN[3, al, be] * x3
                    SS[al, be, i] = u


@numba.njit(cache=True)
def _surface_in(xm, ftype, zeta, N, dN, ddN, S, A, SS):
    """Shape functions at ``zeta``, the surface point and its tangents (no second
    derivatives: SS is left as it was).

    Fills N (n,), dN (n,k), ddN (n,k,k), S (d,) = S(zeta) and A (k,d) with A[alpha] =
    a_alpha.
    """
    if ftype == QUAD1:
        _surface_quad1(xm, zeta, N, dN, ddN, S, A, SS, False)
        return
    shape(ftype, zeta, N, dN, ddN)
    n = xm.shape[0]
    d = xm.shape[1]
    k = A.shape[0]
    for i in range(d):
        s = 0.0
        for a in range(n):
            s += N[a] * xm[a, i]
        S[i] = s
        for al in range(k):
            t = 0.0
            for a in range(n):
                t += dN[a, al] * xm[a, i]
            A[al, i] = t


@numba.njit(cache=True)
def _surface(xm, ftype, zeta, N, dN, ddN, S, A, SS):
    """:func:`_surface_in` and the second derivatives: SS (k,k,d) with SS[alpha, beta] =
    d2S / dzeta_alpha dzeta_beta."""
    if ftype == QUAD1:
        _surface_quad1(xm, zeta, N, dN, ddN, S, A, SS, True)
        return
    _surface_in(xm, ftype, zeta, N, dN, ddN, S, A, SS)
    n = xm.shape[0]
    d = xm.shape[1]
    k = A.shape[0]
    for i in range(d):
        for al in range(k):
            for be in range(k):
                u = 0.0
                for a in range(n):
                    u += ddN[a, al, be] * xm[a, i]
                SS[al, be, i] = u


@numba.njit(cache=True)
def _normal(A, sign, nv):
    """Unnormalised normal n (written to nv, (d,)) from the tangents A (k,d); returns |n|."""
    d = nv.shape[0]
    if d == 2:
        nv[0] = sign * A[0, 1]
        nv[1] = -sign * A[0, 0]
    else:
        nv[0] = sign * (A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1])
        nv[1] = sign * (A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2])
        nv[2] = sign * (A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0])
    s = 0.0
    for i in range(d):
        s += nv[i] * nv[i]
    return math.sqrt(s)


@numba.njit(cache=True)
def _inv_small(k, M, Minv):
    """Inverse of a k x k matrix (k = 1 or 2) into Minv; returns the determinant."""
    if k == 1:
        det = M[0, 0]
        Minv[0, 0] = 1.0 / det
        return det
    det = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
    Minv[0, 0] = M[1, 1] / det
    Minv[1, 1] = M[0, 0] / det
    Minv[0, 1] = -M[0, 1] / det
    Minv[1, 0] = -M[1, 0] / det
    return det


@numba.njit(cache=True)
def _is_spd(k, M, scale):
    """Numerically symmetric positive definite test of a k x k matrix (k = 1, 2)."""
    eps = 1.0e-12 * scale
    if k == 1:
        return M[0, 0] > eps
    return M[0, 0] > eps and M[1, 1] > eps and M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0] > eps * scale


@numba.njit(cache=True)
def _check_dims(xm, ftype):
    """Raise ValueError unless xm is (num_nodes(ftype), tdim(ftype) + 1)."""
    if xm.shape[0] != num_nodes(ftype) or xm.shape[1] != tdim(ftype) + 1:
        raise ValueError("xm must have shape (num_nodes(ftype), tdim(ftype) + 1)")


@numba.njit(cache=True)
def project(x1, xm, ftype, zeta0, zeta_out, tol, maxit):
    r"""Closest-point projection of ``x1`` onto the (extrapolated) master facet.

    Minimises :math:`\phi(\zeta) = \tfrac12 |x_1 - S(\zeta)|^2` by Newton's method on
    :math:`r_\alpha = -(x_1 - S)\cdot a_\alpha = 0` with the full Hessian
    :math:`H_{\alpha\beta} = a_\alpha\cdot a_\beta - (x_1 - S)\cdot S_{,\alpha\beta}`.
    Safeguards: when H is not positive definite the Gauss-Newton step (metric
    :math:`a_\alpha\cdot a_\beta` instead of H; steepest descent if that is singular too)
    is used, and steps outside the quadratic-convergence region (max-norm > 1e-3) are
    controlled by an Armijo backtracking line search on :math:`\phi`.

    Parameters
    ----------
    x1 : float64 (d,)
        Slave point.
    xm : float64 (n_m, d)
        Master facet node coordinates.
    ftype : int
        Master facet type code.
    zeta0 : float64 (k,)
        Initial guess; if any entry is NaN the reference facet centre is used.
    zeta_out : float64 (k,)
        Output: last iterate (may be the same array as ``zeta0``). It may lie outside the
        reference facet (points beyond an edge): check with ``inside``.
    tol : float
        Convergence tolerance on the max-norm of the Newton step in reference coordinates
        (e.g. 1e-12; quadratic convergence makes the result accurate to ~tol**2).
    maxit : int
        Maximum number of iterations.

    Returns
    -------
    bool
        True when converged; False on ``maxit`` exhausted, failed line search, non-finite
        values or divergence (|zeta| > 1e8). ``zeta_out`` always holds the last iterate.
    """
    _check_dims(xm, ftype)
    return project_in(x1, xm, ftype, zeta0, zeta_out, tol, maxit, work(ftype))


@numba.njit(cache=True)
def work(ftype):
    """Work arrays of :func:`project_in`, :func:`unit_normal_in` and :func:`gap_only_in`
    for master facets of type ``ftype`` (d = tdim + 1), as one tuple (N, dN, ddN, S, A,
    SS, nv, z, zt, p, r, H, G, Minv) of views into one allocation. Made once per kernel
    call: carving the views costs more than the affine projection itself."""
    n = num_nodes(ftype)
    k = tdim(ftype)
    d = k + 1
    buf = np.empty(n * (1 + k + k * k) + d * (2 + k + k * k) + 4 * k + 3 * k * k)
    N, dN, ddN, S, A, SS, o = _carve_surface(buf, n, k, d)
    nv = buf[o : o + d]
    o += d
    z = buf[o : o + k]
    zt = buf[o + k : o + 2 * k]
    p = buf[o + 2 * k : o + 3 * k]
    r = buf[o + 3 * k : o + 4 * k]
    o += 4 * k
    H = buf[o : o + k * k].reshape((k, k))
    G = buf[o + k * k : o + 2 * k * k].reshape((k, k))
    Minv = buf[o + 2 * k * k : o + 3 * k * k].reshape((k, k))
    return N, dN, ddN, S, A, SS, nv, z, zt, p, r, H, G, Minv


@numba.njit(cache=True)
def _project_affine(x1, xm, zeta_out):
    r"""Closest-point projection onto an affine facet, S(ζ) = x_0 + Σ_α ζ_α a_α with
    a_α = x_{α+1} − x_0 (INTERVAL1, TRIANGLE1; basix node order): the normal equations
    :math:`m_{\alpha\beta}\,\zeta_\beta = a_\alpha\cdot(x_1 - x_0)` with the constant
    metric m, solved in closed form (what Newton's first step from any start gives).
    Returns False, ``zeta_out`` untouched, where m is singular by the test of
    :func:`_is_spd` (a degenerate facet: the caller iterates)."""
    d = xm.shape[1]
    if xm.shape[0] == 2:
        m00 = 0.0
        r0 = 0.0
        for i in range(d):
            a0 = xm[1, i] - xm[0, i]
            m00 += a0 * a0
            r0 += a0 * (x1[i] - xm[0, i])
        if not m00 > 0.0:
            return False
        zeta_out[0] = r0 / m00
        return True
    m00 = m01 = m11 = r0 = r1 = 0.0
    for i in range(d):
        a0 = xm[1, i] - xm[0, i]
        a1 = xm[2, i] - xm[0, i]
        e = x1[i] - xm[0, i]
        m00 += a0 * a0
        m01 += a0 * a1
        m11 += a1 * a1
        r0 += a0 * e
        r1 += a1 * e
    tr = m00 + m11
    det = m00 * m11 - m01 * m01
    if not (m00 > 1.0e-12 * tr and m11 > 1.0e-12 * tr and det > 1.0e-12 * tr * tr):
        return False
    zeta_out[0] = (m11 * r0 - m01 * r1) / det
    zeta_out[1] = (m00 * r1 - m01 * r0) / det
    return True


@numba.njit(cache=True)
def project_in(x1, xm, ftype, zeta0, zeta_out, tol, maxit, w):
    """:func:`project` with the caller's work arrays ``w`` (:func:`work`; overwritten):
    no allocation, for loops over many projections. xm's shape is not checked. Affine
    facets (INTERVAL1, TRIANGLE1) take the closed form (:func:`_project_affine`), the
    same point to round-off (it is Newton's first step: not with ``maxit`` = 0)."""
    affine = ftype == INTERVAL1 or ftype == TRIANGLE1
    if affine and maxit >= 1 and _project_affine(x1, xm, zeta_out):
        return True
    k = tdim(ftype)
    d = xm.shape[1]
    N, dN, ddN, S, A, SS, nv, z, zt, p, r, H, G, Minv = w
    use_centre = False
    for al in range(k):
        if math.isnan(zeta0[al]):
            use_centre = True
    if use_centre:
        reference_centre(ftype, z)
    else:
        for al in range(k):
            z[al] = zeta0[al]

    converged = False
    for _it in range(maxit):
        _surface(xm, ftype, z, N, dN, ddN, S, A, SS)
        phi = 0.0
        for i in range(d):
            phi += 0.5 * (x1[i] - S[i]) ** 2
        trG = 0.0
        for al in range(k):
            s = 0.0
            for i in range(d):
                s -= (x1[i] - S[i]) * A[al, i]
            r[al] = s
            for be in range(k):
                gab = 0.0
                wss = 0.0
                for i in range(d):
                    gab += A[al, i] * A[be, i]
                    wss += (x1[i] - S[i]) * SS[al, be, i]
                G[al, be] = gab
                H[al, be] = gab - wss
            trG += G[al, al]

        newton = _is_spd(k, H, trG)
        if newton:
            _inv_small(k, H, Minv)
        elif _is_spd(k, G, trG):
            _inv_small(k, G, Minv)
        else:
            for al in range(k):
                for be in range(k):
                    Minv[al, be] = 1.0 if al == be else 0.0
        pmax = 0.0
        slope = 0.0
        for al in range(k):
            s = 0.0
            for be in range(k):
                s -= Minv[al, be] * r[be]
            p[al] = s
            slope += r[al] * s
            pmax = max(pmax, abs(s))
        if not (pmax < np.inf):  # NaN or inf
            break
        if pmax <= tol:
            for al in range(k):
                z[al] += p[al]
            converged = True
            break
        if newton and pmax <= _NEWTON_REGION:
            for al in range(k):
                z[al] += p[al]
        else:
            alpha = 1.0
            ok = False
            for _ls in range(_MAX_HALVINGS):
                for al in range(k):
                    zt[al] = z[al] + alpha * p[al]
                _surface(xm, ftype, zt, N, dN, ddN, S, A, SS)
                phit = 0.0
                for i in range(d):
                    phit += 0.5 * (x1[i] - S[i]) ** 2
                if phit <= phi + _ARMIJO_C * alpha * slope + 1.0e-15 * phi:
                    ok = True
                    break
                alpha *= 0.5
            if not ok:
                break
            for al in range(k):
                z[al] = zt[al]
        zmax = 0.0
        for al in range(k):
            zmax = max(zmax, abs(z[al]))
        if not (zmax < _ZETA_MAX):
            break
    for al in range(k):
        zeta_out[al] = z[al]
    return converged


@numba.njit(cache=True)
def _surface_at(xm, ftype, zeta):
    """Check xm's shape, then allocate and fill (N, dN, ddN, S, A, SS) at ``zeta`` (see
    :func:`_surface` for the shapes)."""
    _check_dims(xm, ftype)
    n = num_nodes(ftype)
    k = tdim(ftype)
    d = xm.shape[1]
    N = np.empty(n)
    dN = np.empty((n, k))
    ddN = np.empty((n, k, k))
    S = np.empty(d)
    A = np.empty((k, d))
    SS = np.empty((k, k, d))
    _surface(xm, ftype, zeta, N, dN, ddN, S, A, SS)
    return N, dN, ddN, S, A, SS


@numba.njit(cache=True)
def unit_normal(xm, ftype, sign, zeta, nu):
    """Unit normal nu(zeta) (written to ``nu``, (d,)); returns the surface Jacobian |n|.

    ``sign`` (+1 or -1) selects the orientation, see the module docstring.
    """
    _check_dims(xm, ftype)
    return unit_normal_in(xm, ftype, sign, zeta, nu, work(ftype))


@numba.njit(cache=True)
def unit_normal_in(xm, ftype, sign, zeta, nu, w):
    """:func:`unit_normal` with the caller's work arrays (:func:`work`)."""
    d = xm.shape[1]
    N, dN, ddN, S, A, SS = w[:6]
    _surface_in(xm, ftype, zeta, N, dN, ddN, S, A, SS)
    jn = _normal(A, sign, nu)
    for i in range(d):
        nu[i] /= jn
    return jn


@numba.njit(cache=True)
def gap_only(x1, xm, ftype, sign, zeta):
    """Normal gap g = (x1 - S(zeta)) . nu(zeta) at the given (projected) ``zeta``.

    Parameters as in :func:`gap_and_derivatives`; no derivatives are computed.
    """
    _check_dims(xm, ftype)
    return gap_only_in(x1, xm, ftype, sign, zeta, work(ftype))


@numba.njit(cache=True)
def gap_only_in(x1, xm, ftype, sign, zeta, w):
    """:func:`gap_only` with the caller's work arrays (:func:`work`)."""
    d = xm.shape[1]
    N, dN, ddN, S, A, SS, nv = w[:7]
    _surface_in(xm, ftype, zeta, N, dN, ddN, S, A, SS)
    jn = _normal(A, sign, nv)
    g = 0.0
    for i in range(d):
        g += (x1[i] - S[i]) * nv[i]
    return g / jn


@numba.njit(cache=True)
def gap_and_derivatives(x1, xm, ftype, sign, zeta, dg, d2g):
    r"""Normal gap and its exact gradient and Hessian with respect to y = [x1, xm.ravel()].

    ``zeta`` must be the converged closest-point projection (see :func:`project`).

    Formulas (envelope theorem). Let :math:`f(\zeta, y) = (x_1 - S(\zeta))\cdot\nu(\zeta)`
    and :math:`r_\alpha(\zeta, y) = -(x_1 - S)\cdot a_\alpha`; :math:`g(y) = f(\bar\zeta(y), y)`
    with :math:`r(\bar\zeta(y), y) = 0`. Since :math:`\nu\perp a_\alpha`, :math:`|\nu| = 1`
    and the Weingarten relation :math:`\nu_{,\alpha} = -b_{\alpha\beta} m^{\beta\gamma}
    a_\gamma` (:math:`b_{\alpha\beta} = \nu\cdot S_{,\alpha\beta}`), one has identically
    :math:`f_\zeta = B\, r` with :math:`B = b\, m^{-1}`, so :math:`f_\zeta = 0` at the
    projection and

    * :math:`\partial g/\partial y = f_y`, i.e. :math:`\partial g/\partial x_1 = \nu`,
      :math:`\partial g/\partial x^m_a = -N_a \nu`;
    * :math:`\partial^2 g/\partial y^2 = f_{yy} + f_{y\zeta}\,\bar\zeta_{,y}
      = f_{yy} - r_y^T\, K\, r_y`, with :math:`\bar\zeta_{,y} = -H^{-1} r_y`,
      :math:`f_{\zeta y} = B r_y` and the symmetric k x k matrix
      :math:`K = B^T H^{-1} = m^{-1}\, b\, (m - g\, b)^{-1}`,
      :math:`H = m - (x_1 - S)\cdot S_{,\zeta\zeta} = m - g\,b` (projection Hessian).
      (This equals :math:`f_{yy} - f_{y\zeta} f_{\zeta\zeta}^{-1} f_{\zeta y}` whenever
      :math:`b` is invertible, and stays valid for flat facets, where
      :math:`f_{\zeta\zeta} = 0`.)

    With :math:`D_\alpha = \partial\nu/\partial a_\alpha = (I - \nu\nu^T)\,
    (\partial n/\partial a_\alpha)/|n|` and :math:`E_a = \sum_\alpha N_{a,\alpha} D_\alpha`
    (d x d), the fixed-:math:`\zeta` Hessian is (using :math:`x_1 - S = g\nu` and
    :math:`\nu\cdot\nu_{,ij} = -\nu_{,i}\cdot\nu_{,j}`)

    * :math:`f_{x_1 x_1} = 0`, :math:`f_{x_1 x^m_b} = E_b`,
    * :math:`f_{x^m_a x^m_b} = -N_a E_b - N_b E_a^T - g\, E_a^T E_b`,

    and :math:`r_y`: :math:`\partial r_\gamma/\partial x_1 = -a_\gamma`,
    :math:`\partial r_\gamma/\partial x^m_a = N_a a_\gamma - N_{a,\gamma}(x_1 - S)`.

    Parameters
    ----------
    x1 : float64 (d,)
        Slave point.
    xm : float64 (n_m, d)
        Master facet node coordinates (basix order).
    ftype : int
        Master facet type code.
    sign : float
        +1 or -1, orientation making nu the master body's outward normal.
    zeta : float64 (k,)
        Converged projection of x1.
    dg : float64 (n_y,)
        Output gradient dg/dy, n_y = d (1 + n_m).
    d2g : float64 (n_y, n_y)
        Output Hessian d2g/dy2 (symmetric). Unbounded when x1 sits at a centre of
        curvature of the master surface (H singular).

    Returns
    -------
    float
        The normal gap g.
    """
    _check_dims(xm, ftype)
    n = num_nodes(ftype)
    k = tdim(ftype)
    d = xm.shape[1]
    ny = d * (1 + n)
    # one allocation, carved into the small work arrays
    buf = np.empty(
        n * (1 + k + k * k) + d * (1 + k + k * k) + 2 * d + 2 * k * d * d + n * d * d
        + 6 * k * k + 2 * k * ny
    )  # fmt: skip
    N, dN, ddN, S, A, SS, o = _carve_surface(buf, n, k, d)
    w = buf[o : o + d]
    nu = buf[o + d : o + 2 * d]
    o += 2 * d
    dnda = buf[o : o + k * d * d].reshape((k, d, d))
    o += k * d * d
    D = buf[o : o + k * d * d].reshape((k, d, d))
    o += k * d * d
    X = buf[o : o + n * d * d].reshape((d, n * d))
    o += n * d * d
    kk = k * k
    G = buf[o : o + kk].reshape((k, k))
    b = buf[o + kk : o + 2 * kk].reshape((k, k))
    H = buf[o + 2 * kk : o + 3 * kk].reshape((k, k))
    Gi = buf[o + 3 * kk : o + 4 * kk].reshape((k, k))
    Hi = buf[o + 4 * kk : o + 5 * kk].reshape((k, k))
    K = buf[o + 5 * kk : o + 6 * kk].reshape((k, k))
    o += 6 * kk
    R = buf[o : o + k * ny].reshape((k, ny))
    T = buf[o + k * ny : o + 2 * k * ny].reshape((k, ny))

    _surface(xm, ftype, zeta, N, dN, ddN, S, A, SS)
    jn = _normal(A, sign, nu)
    g = 0.0
    for i in range(d):
        nu[i] /= jn
        w[i] = x1[i] - S[i]
        g += w[i] * nu[i]

    # dn/da_alpha, (k, d, d): dnda[alpha, i, j] = dn_i / da_alpha_j
    if d == 2:
        dnda[0, 0, 0] = 0.0
        dnda[0, 0, 1] = sign
        dnda[0, 1, 0] = -sign
        dnda[0, 1, 1] = 0.0
    else:
        # n = s a1 x a2: dn/da1 = -s [a2]_x, dn/da2 = s [a1]_x
        for al in range(2):
            v0 = A[1 - al, 0]
            v1 = A[1 - al, 1]
            v2 = A[1 - al, 2]
            s = -sign if al == 0 else sign
            dnda[al, 0, 0] = 0.0
            dnda[al, 0, 1] = -s * v2
            dnda[al, 0, 2] = s * v1
            dnda[al, 1, 0] = s * v2
            dnda[al, 1, 1] = 0.0
            dnda[al, 1, 2] = -s * v0
            dnda[al, 2, 0] = -s * v1
            dnda[al, 2, 1] = s * v0
            dnda[al, 2, 2] = 0.0
    # D_alpha = (I - nu nu^T) dnda_alpha / |n|
    for al in range(k):
        for j in range(d):
            c = 0.0
            for l in range(d):
                c += nu[l] * dnda[al, l, j]
            for i in range(d):
                D[al, i, j] = (dnda[al, i, j] - nu[i] * c) / jn
    # X (d, n*d): X[i, b*d + j] = (E_b)_ij, E_b = sum_alpha dN_b,alpha D_alpha
    # (small runtime-length inner loops are slow in numba: k and d are unrolled by hand)
    nd = n * d
    d3 = d == 3
    for bn in range(n):
        c0 = dN[bn, 0]
        c1 = dN[bn, 1] if k == 2 else 0.0
        for i in range(d):
            for j in range(d):
                v = c0 * D[0, i, j]
                if k == 2:
                    v += c1 * D[1, i, j]
                X[i, bn * d + j] = v

    # gradient
    for i in range(d):
        dg[i] = nu[i]
    for a in range(n):
        for i in range(d):
            dg[d + a * d + i] = -N[a] * nu[i]

    # fixed-zeta Hessian f_yy, upper triangle only (mirrored in the final pass):
    # x1-x1 block 0, x1-xm_b block E_b, xm_a-xm_b block -N_a E_b - N_b E_a^T - g E_a^T E_b
    for i in range(d):
        for j in range(d):
            d2g[i, j] = 0.0
        for q in range(nd):
            d2g[i, d + q] = X[i, q]
    for a in range(n):
        na = N[a]
        for i in range(d):
            p = a * d + i
            row = d + p
            xp0 = X[0, p]
            xp1 = X[1, p]
            xp2 = X[2, p] if d3 else 0.0
            bn = a
            j = i
            for q in range(p, nd):
                s = xp0 * X[0, q] + xp1 * X[1, q]
                if d3:
                    s += xp2 * X[2, q]
                d2g[row, d + q] = -na * X[i, q] - N[bn] * X[j, p] - g * s
                j += 1
                if j == d:
                    j = 0
                    bn += 1

    # projection coupling: - r_y^T K r_y, K = m^-1 b H^-1
    for al in range(k):
        for be in range(k):
            gab = 0.0
            bab = 0.0
            wss = 0.0
            for i in range(d):
                gab += A[al, i] * A[be, i]
                bab += nu[i] * SS[al, be, i]
                wss += w[i] * SS[al, be, i]
            G[al, be] = gab
            b[al, be] = bab
            H[al, be] = gab - wss
    _inv_small(k, G, Gi)
    _inv_small(k, H, Hi)
    for al in range(k):
        for be in range(k):
            s = 0.0
            for ga in range(k):
                for de in range(k):
                    s += Gi[al, ga] * b[ga, de] * Hi[de, be]
            K[al, be] = s
    if k == 2:
        s = 0.5 * (K[0, 1] + K[1, 0])
        K[0, 1] = s
        K[1, 0] = s
    for ga in range(k):
        for i in range(d):
            R[ga, i] = -A[ga, i]
        for a in range(n):
            for i in range(d):
                R[ga, d + a * d + i] = N[a] * A[ga, i] - dN[a, ga] * w[i]
    # T = K R, then subtract R^T T on the upper triangle and mirror
    if k == 1:
        for j in range(ny):
            T[0, j] = K[0, 0] * R[0, j]
        for i in range(ny):
            r0 = R[0, i]
            for j in range(i, ny):
                v = d2g[i, j] - r0 * T[0, j]
                d2g[i, j] = v
                d2g[j, i] = v
    else:
        for j in range(ny):
            T[0, j] = K[0, 0] * R[0, j] + K[0, 1] * R[1, j]
            T[1, j] = K[1, 0] * R[0, j] + K[1, 1] * R[1, j]
        for i in range(ny):
            r0 = R[0, i]
            r1 = R[1, i]
            for j in range(i, ny):
                v = d2g[i, j] - r0 * T[0, j] - r1 * T[1, j]
                d2g[i, j] = v
                d2g[j, i] = v
    return g


@numba.njit(cache=True)
def projection_derivative(x1, xm, ftype, zeta, dzeta):
    r"""Derivative of the closest-point projection, :math:`\partial\bar\zeta/\partial y =
    -H^{-1} r_y` (written to ``dzeta``, (k, n_y)); e.g. for tangential slip / friction.

    ``zeta`` must be the converged projection; H and r_y as in :func:`gap_and_derivatives`.
    """
    n = num_nodes(ftype)
    k = tdim(ftype)
    d = xm.shape[1]
    ny = d * (1 + n)
    N, dN, ddN, S, A, SS = _surface_at(xm, ftype, zeta)
    H = np.empty((k, k))
    Hi = np.empty((k, k))
    R = np.empty((k, ny))
    for al in range(k):
        for be in range(k):
            s = 0.0
            for i in range(d):
                s += A[al, i] * A[be, i] - (x1[i] - S[i]) * SS[al, be, i]
            H[al, be] = s
    _inv_small(k, H, Hi)
    for ga in range(k):
        for i in range(d):
            R[ga, i] = -A[ga, i]
        for a in range(n):
            for i in range(d):
                R[ga, d + a * d + i] = N[a] * A[ga, i] - dN[a, ga] * (x1[i] - S[i])
    for al in range(k):
        for j in range(ny):
            s = 0.0
            for be in range(k):
                s -= Hi[al, be] * R[be, j]
            dzeta[al, j] = s
