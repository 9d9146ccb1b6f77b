r"""Slow, obviously-correct NumPy/SciPy reference implementations of the contact kernels.

Used by the tests to validate the numba kernels of :mod:`.shape` and :mod:`.gap`, the
point kernels of :mod:`.mortar` (:func:`facet_mass`, :func:`contact_terms`,
:func:`compress_rows`, :func:`jacobian_terms`, :func:`point_xi_terms`) and
:func:`.friction.slip_motion_blocks` (:func:`slip_motion_blocks`; the other references
of :mod:`.friction` live there); same conventions (see :mod:`dolfinx_mortar.kernels.gap`).
The point kernels' references are written from the kernels' docstring equations, with the
gap derivatives of :func:`gap_derivatives` and the chain rule to the local dofs as one
matrix product. The derivatives are obtained by a route independent of the numba code:

* shape functions are written once as polynomial expressions (:func:`shape_expressions`,
  N and its first derivatives); second derivatives come from automatic differentiation;
* :class:`Jet` is a small second-order forward-mode AD number (value, gradient, Hessian);
* the gap derivatives are computed by differentiating f(zeta, y) = (x1 - S).nu and the
  projection condition r(zeta, y) = -(x1 - S).a = 0 with jets in z = (y, zeta), then by
  full second-order implicit differentiation of zeta(y) (no envelope theorem, no
  differential-geometry identities):

  .. math::
     \zeta_y = -r_\zeta^{-1} r_y,\qquad
     r_\zeta \zeta_{y_i y_j} = -(r_{y_i y_j} + r_{y_i\zeta}\zeta_{y_j}
       + r_{y_j\zeta}\zeta_{y_i} + \zeta_{y_i}^T r_{\zeta\zeta}\zeta_{y_j}),

     g_{y y} = f_{yy} + f_{y\zeta}\zeta_y + \zeta_y^T f_{\zeta y}
       + \zeta_y^T f_{\zeta\zeta}\zeta_y + f_\zeta\cdot\zeta_{yy}.

* the projection minimises 0.5 |x1 - S(zeta)|^2 from the best point of a dense grid with
  :func:`scipy.optimize.minimize` (trust-exact, jet gradient and Hessian), then polishes
  with a few plain Newton steps.
"""

import math

import numpy as np
import scipy.optimize

from .shape import (
    INTERVAL1,
    INTERVAL2,
    QUAD1,
    QUAD2,
    TRIANGLE1,
    TRIANGLE2,
)

_TDIM = {INTERVAL1: 1, INTERVAL2: 1, TRIANGLE1: 2, TRIANGLE2: 2, QUAD1: 2, QUAD2: 2}


class Jet:
    """Second-order forward-mode AD number: value ``v``, gradient ``g`` (m,), Hessian ``h`` (m, m)."""

    __slots__ = ("v", "g", "h")

    def __init__(self, v, g, h):
        self.v = float(v)
        self.g = g
        self.h = h

    @classmethod
    def variable(cls, value, index, m):
        """Independent variable number ``index`` out of ``m``."""
        g = np.zeros(m)
        g[index] = 1.0
        return cls(value, g, np.zeros((m, m)))

    @classmethod
    def constant(cls, value, m):
        return cls(value, np.zeros(m), np.zeros((m, m)))

    def __add__(self, o):
        if isinstance(o, Jet):
            return Jet(self.v + o.v, self.g + o.g, self.h + o.h)
        return Jet(self.v + o, self.g, self.h)

    __radd__ = __add__

    def __neg__(self):
        return Jet(-self.v, -self.g, -self.h)

    def __sub__(self, o):
        return self + (-o)

    def __rsub__(self, o):
        return (-self) + o

    def __mul__(self, o):
        if isinstance(o, Jet):
            gg = np.outer(self.g, o.g)
            return Jet(
                self.v * o.v,
                self.g * o.v + o.g * self.v,
                self.h * o.v + o.h * self.v + gg + gg.T,
            )
        return Jet(self.v * o, self.g * o, self.h * o)

    __rmul__ = __mul__

    def reciprocal(self):
        v = 1.0 / self.v
        return Jet(v, -self.g * v**2, -self.h * v**2 + 2.0 * v**3 * np.outer(self.g, self.g))

    def __truediv__(self, o):
        if isinstance(o, Jet):
            return self * o.reciprocal()
        return self * (1.0 / o)

    def __rtruediv__(self, o):
        return self.reciprocal() * o

    def sqrt(self):
        s = math.sqrt(self.v)
        return Jet(
            s, self.g / (2.0 * s), self.h / (2.0 * s) - np.outer(self.g, self.g) / (4.0 * s**3)
        )


def tdim(ftype):
    """Topological dimension of the facet type."""
    return _TDIM[ftype]


def _lagrange_1d(degree, x):
    """1D Lagrange functions (nodes 0, 1[, 0.5]) and derivatives, as expressions in x."""
    if degree == 1:
        return [1 - x, x], [-1.0 + 0 * x, 1.0 + 0 * x]
    return (
        [(1 - x) * (1 - 2 * x), x * (2 * x - 1), 4 * x * (1 - x)],
        [4 * x - 3, 4 * x - 1, 4 - 8 * x],
    )


def shape_expressions(ftype, xi):
    """Shape functions N_a and derivatives dN_a/dxi_alpha as expressions in ``xi``.

    ``xi`` is a sequence of k numbers (floats or :class:`Jet`); returns (N, dN) as nested
    lists, N[a] and dN[a][alpha], basix node order.
    """
    if ftype in (INTERVAL1, INTERVAL2):
        N, dN = _lagrange_1d(1 if ftype == INTERVAL1 else 2, xi[0])
        return N, [[v] for v in dN]
    x, y = xi[0], xi[1]
    if ftype == TRIANGLE1:
        z = 0 * x
        return [1 - x - y, x, y], [[z - 1, z - 1], [z + 1, z], [z, z + 1]]
    if ftype == TRIANGLE2:
        L = 1 - x - y
        z = 0 * x
        N = [L * (2 * L - 1), x * (2 * x - 1), y * (2 * y - 1), 4 * x * y, 4 * L * y, 4 * L * x]
        dN = [
            [1 - 4 * L, 1 - 4 * L],
            [4 * x - 1, z],
            [z, 4 * y - 1],
            [4 * y, 4 * x],
            [-4 * y, 4 * L - 4 * y],
            [4 * L - 4 * x, -4 * x],
        ]
        return N, dN
    if ftype in (QUAD1, QUAD2):
        deg = 1 if ftype == QUAD1 else 2
        fx, dfx = _lagrange_1d(deg, x)
        fy, dfy = _lagrange_1d(deg, y)
        if deg == 1:
            ij = [(0, 0), (1, 0), (0, 1), (1, 1)]
        else:
            ij = [(0, 0), (1, 0), (0, 1), (1, 1), (2, 0), (0, 2), (1, 2), (2, 1), (2, 2)]
        N = [fx[i] * fy[j] for i, j in ij]
        dN = [[dfx[i] * fy[j], fx[i] * dfy[j]] for i, j in ij]
        return N, dN
    raise ValueError(f"unknown facet type {ftype}")


def shape(ftype, xi):
    """NumPy shape functions at ``xi`` (k,): returns N (n,), dN (n, k), ddN (n, k, k)."""
    k = tdim(ftype)
    xi = np.asarray(xi, dtype=float)
    N, dN = shape_expressions(ftype, [float(v) for v in xi])
    jets = [Jet.variable(xi[al], al, k) for al in range(k)]
    _, dNj = shape_expressions(ftype, jets)
    ddN = np.array([[_as_jet(v, k).g for v in row] for row in dNj])
    return np.array(N, dtype=float), np.array(dN, dtype=float), ddN


def _as_jet(v, m):
    return v if isinstance(v, Jet) else Jet.constant(v, m)


def surface(xm, ftype, zeta):
    """S(zeta) (d,) and tangents A (k, d) (A[alpha] = dS/dzeta_alpha)."""
    N, dN, _ = shape(ftype, zeta)
    return N @ xm, dN.T @ xm


def normal(xm, ftype, sign, zeta):
    """Unit normal nu (d,) at zeta: sign*(a1_y, -a1_x) (2D) or sign*a1 x a2 (3D), normalised."""
    _, A = surface(xm, ftype, zeta)
    if xm.shape[1] == 2:
        n = sign * np.array([A[0, 1], -A[0, 0]])
    else:
        n = sign * np.cross(A[0], A[1])
    return n / np.linalg.norm(n)


def _phi_jet(x1, xm, ftype, zeta):
    """0.5 |x1 - S(zeta)|^2 as a Jet in zeta (k variables)."""
    k = tdim(ftype)
    z = [Jet.variable(zeta[al], al, k) for al in range(k)]
    N, _ = shape_expressions(ftype, z)
    phi = Jet.constant(0.0, k)
    for i in range(xm.shape[1]):
        s = x1[i] - sum((N[a] * xm[a, i] for a in range(len(N))), Jet.constant(0.0, k))
        phi = phi + 0.5 * s * s
    return phi


def project(x1, xm, ftype, zeta0=None, box=(0.0, 1.0), ngrid=41, newton_polish=5):
    """Reference closest-point projection of x1 onto the (extrapolated) facet.

    Starts from ``zeta0`` or from the best point of an ``ngrid``^k grid on ``box``^k (by
    default the reference square, i.e. the local minimum "belonging" to the facet is
    sought, not a global one of the extrapolated polynomial surface), minimises
    0.5|x1 - S|^2 without bounds with scipy's trust-exact method and polishes with plain
    Newton steps. Returns zeta (k,), possibly outside the reference facet.
    """
    x1 = np.asarray(x1, dtype=float)
    xm = np.asarray(xm, dtype=float)
    k = tdim(ftype)
    if zeta0 is None:
        t = np.linspace(box[0], box[1], ngrid)
        if k == 1:
            cand = t[:, None]
        else:
            cand = np.array(np.meshgrid(t, t, indexing="ij")).reshape(2, -1).T
        vals = [np.sum((x1 - surface(xm, ftype, c)[0]) ** 2) for c in cand]
        zeta0 = cand[int(np.argmin(vals))]

    def fun(z):
        return _phi_jet(x1, xm, ftype, z).v

    def jac(z):
        return _phi_jet(x1, xm, ftype, z).g

    def hess(z):
        return _phi_jet(x1, xm, ftype, z).h

    res = scipy.optimize.minimize(
        fun, np.asarray(zeta0, float), jac=jac, hess=hess, method="trust-exact",
        options={"gtol": 1e-13},
    )  # fmt: skip
    z = np.array(res.x, dtype=float)
    for _ in range(newton_polish):
        p = _phi_jet(x1, xm, ftype, z)
        z = z - np.linalg.solve(p.h, p.g)
    return z


def gap(x1, xm, ftype, sign, zeta):
    """Normal gap (x1 - S(zeta)) . nu(zeta)."""
    S, _ = surface(np.asarray(xm, float), ftype, zeta)
    return float((np.asarray(x1) - S) @ normal(np.asarray(xm, float), ftype, sign, zeta))


def _f_r_jets(x1, xm, ftype, sign, zeta):
    """f = (x1 - S).nu and r_alpha = -(x1 - S).a_alpha as Jets in z = (y, zeta)."""
    d = xm.shape[1]
    n = xm.shape[0]
    k = tdim(ftype)
    ny = d * (1 + n)
    m = ny + k
    y = np.concatenate([x1, xm.ravel()])
    yj = [Jet.variable(y[i], i, m) for i in range(ny)]
    zj = [Jet.variable(zeta[al], ny + al, m) for al in range(k)]
    x1j = yj[:d]
    xmj = [yj[d + a * d : d + (a + 1) * d] for a in range(n)]
    N, dN = shape_expressions(ftype, zj)
    N = [_as_jet(v, m) for v in N]
    dN = [[_as_jet(v, m) for v in row] for row in dN]
    zero = Jet.constant(0.0, m)
    S = [sum((N[a] * xmj[a][i] for a in range(n)), zero) for i in range(d)]
    A = [
        [sum((dN[a][al] * xmj[a][i] for a in range(n)), zero) for i in range(d)] for al in range(k)
    ]
    w = [x1j[i] - S[i] for i in range(d)]
    if d == 2:
        nv = [sign * A[0][1], -sign * A[0][0]]
    else:
        a1, a2 = A
        nv = [
            sign * (a1[1] * a2[2] - a1[2] * a2[1]),
            sign * (a1[2] * a2[0] - a1[0] * a2[2]),
            sign * (a1[0] * a2[1] - a1[1] * a2[0]),
        ]
    norm = sum((v * v for v in nv), zero).sqrt()
    f = sum((w[i] * nv[i] for i in range(d)), zero) / norm
    r = [-sum((w[i] * A[al][i] for i in range(d)), zero) for al in range(k)]
    return f, r, ny, k


def gap_derivatives(x1, xm, ftype, sign, zeta):
    """Reference g, dg/dy (n_y,), d2g/dy2 (n_y, n_y) by AD + implicit differentiation.

    ``zeta`` must be the converged projection of x1; y = [x1, xm.ravel()].
    """
    x1 = np.asarray(x1, dtype=float)
    xm = np.asarray(xm, dtype=float)
    f, r, ny, k = _f_r_jets(x1, xm, ftype, sign, np.asarray(zeta, float))
    Y = slice(0, ny)
    Z = slice(ny, ny + k)
    f_y, f_z = f.g[Y], f.g[Z]
    f_yy, f_yz, f_zz = f.h[Y, Y], f.h[Y, Z], f.h[Z, Z]
    r_z = np.array([ra.g[Z] for ra in r])  # (k, k)
    r_y = np.array([ra.g[Y] for ra in r])  # (k, ny)
    zeta_y = -np.linalg.solve(r_z, r_y)  # (k, ny)
    # second derivatives of zeta(y)
    rhs = np.empty((k, ny, ny))
    for ga, ra in enumerate(r):
        t = ra.h[Y, Z] @ zeta_y  # (ny, ny)
        rhs[ga] = ra.h[Y, Y] + t + t.T + zeta_y.T @ ra.h[Z, Z] @ zeta_y
    zeta_yy = -np.einsum("ag,gij->aij", np.linalg.inv(r_z), rhs)
    dg = f_y + zeta_y.T @ f_z
    t = f_yz @ zeta_y
    d2g = f_yy + t + t.T + zeta_y.T @ f_zz @ zeta_y + np.einsum("a,aij->ij", f_z, zeta_yy)
    return f.v, dg, d2g


def facet_mass(ftype_phi, qp_xi, qp_w, qp_m):
    """NumPy version of :func:`dolfinx_mortar.kernels.mortar.facet_mass`: (nsf, nphi, nphi)."""
    nsf, nq, _ = qp_xi.shape
    nphi = len(shape(ftype_phi, qp_xi[0, 0])[0]) if nsf else 0
    out = np.zeros((nsf, nphi, nphi))
    for f in range(nsf):
        for q in range(nq):
            if qp_m[f, q] >= 0:
                phi = shape(ftype_phi, qp_xi[f, q])[0]
                out[f] += qp_w[f, q] * np.outer(phi, phi)
    return out


# ------------------------------------------------------------- mortar point kernels
# References of the per-point kernels of :mod:`dolfinx_mortar.kernels.mortar` written from
# their docstrings' equations: the gap derivatives come from :func:`gap_derivatives` (AD
# and implicit differentiation, not the envelope formulas of the numba kernel), the
# normal from :func:`normal` and the chain rule to the local dofs is one matrix product.


def _dof_map(N, nm, d, master=1.0):
    """T = ∂y/∂u_loc (d (1 + nm), (ns + nm) d) of y = [x₁, xm.ravel()] with x₁ = Σ_a N_a x_a
    and the node-major local dofs u_loc = [slave facet nodes, master facet nodes];
    ``master = 0`` gives ∂_βT when N holds ∂_βN (the master nodes do not depend on ξ)."""
    ns = N.size
    T = np.zeros((d * (1 + nm), (ns + nm) * d))
    T[:d, : ns * d] = np.kron(N[None, :], np.eye(d))  # T[c, a d + c'] = N_a δ_cc'
    T[d:, ns * d :] = master * np.eye(nm * d)
    return T


def _paired_rows(qp_m):
    """(facet, point) of the paired points (qp_m ≥ 0), in (facet, point) order."""
    return np.nonzero(qp_m >= 0)


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
    want_jac=False,
):
    """NumPy reference of :func:`dolfinx_mortar.kernels.mortar.contact_terms` and, with
    ``want_jac``, of the per-point Hessian blocks that :func:`jacobian_terms` sums.

    Per paired point (f, q) with master m, p_w = w_q J₀ Σ_I p^I Φ_I(ξ_q) over the owned
    nodes I of facet f; rows with p_w = 0 keep res_idx = −1. Otherwise res_idx = [sdofs[f],
    mdofs[m]], res_val = −p_w ∂g/∂u, hess_val = −p_w ∂²g/∂u² (u the local dofs, through
    x₁ = Σ_a N_a(ξ) x_a) and force += p_w ν(ζ_q).
    Returns (res_idx, res_val, hess_val or None, force).
    """
    ns, d = xs.shape[1:]
    nm = xm.shape[1]
    nloc = (ns + nm) * d
    fr, qr = _paired_rows(qp_m)
    n = fr.size
    res_idx = np.full((n, nloc), -1, np.int64)
    res_val = np.zeros((n, nloc))
    hess_val = np.zeros((n, nloc, nloc)) if want_jac else None
    force = np.zeros(d)
    for r, (f, q) in enumerate(zip(fr, qr, strict=True)):
        m = qp_m[f, q]
        xi, zeta = qp_xi[f, q], qp_zeta[f, q]
        pn = np.where(node_of[f] >= 0, p[np.maximum(node_of[f], 0)], 0.0)
        pw = qp_w[f, q] * (pn @ shape(ftype_phi, xi)[0])
        if pw == 0.0:
            continue
        N = shape(ftype_s, xi)[0]
        _, dg, d2g = gap_derivatives(N @ xs[f], xm[m], ftype_m, msign[m], zeta)
        T = _dof_map(N, nm, d)
        res_idx[r] = np.concatenate([sdofs[f], mdofs[m]])
        res_val[r] = -pw * (T.T @ dg)
        if want_jac:
            hess_val[r] = -pw * (T.T @ d2g @ T)
        force += pw * normal(xm[m], ftype_m, msign[m], zeta)
    return res_idx, res_val, hess_val, force


def node_rows(
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
    kcoef,
):
    """The rows B^I = ∂G^I/∂u = Σ_q w_q J₀ Φ_I(ξ_q) ∂g_q/∂u of the owned nodes with
    kcoef > 0 (the rows of :func:`jacobian_terms`, before compression), one block
    of nloc entries (dofs [sdofs[f], mdofs[m]], values w Φ_I ∂g/∂u_loc) per paired point of
    the node's facets, in (facet, point) order, uncompressed. Returns (b_off, b_idx, b_val).
    """
    ns, d = xs.shape[1:]
    nm = xm.shape[1]
    n_nodes = kcoef.size
    idx = [[] for _ in range(n_nodes)]
    val = [[] for _ in range(n_nodes)]
    for f, q in zip(*_paired_rows(qp_m), strict=True):
        m = qp_m[f, q]
        xi = qp_xi[f, q]
        N = shape(ftype_s, xi)[0]
        _, dg, _ = gap_derivatives(N @ xs[f], xm[m], ftype_m, msign[m], qp_zeta[f, q])
        dg_loc = _dof_map(N, nm, d).T @ dg
        phi = shape(ftype_phi, xi)[0]
        for i, node in enumerate(node_of[f]):
            if node >= 0 and kcoef[node] > 0.0:
                idx[node].append(np.concatenate([sdofs[f], mdofs[m]]))
                val[node].append(qp_w[f, q] * phi[i] * dg_loc)
    counts = [sum(v.size for v in row) for row in val]
    b_off = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    b_idx = np.concatenate([np.zeros(0, np.int64)] + [v for row in idx for v in row])
    b_val = np.concatenate([np.zeros(0)] + [v for row in val for v in row])
    return b_off, b_idx.astype(np.int64), b_val


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
    """NumPy reference of :func:`dolfinx_mortar.kernels.mortar.jacobian_terms`, from the
    references of :func:`contact_terms`, :func:`node_rows` and :func:`compress_rows`: the
    Hessian blocks of the rows with p_w ≠ 0 summed per (slave facet, master facet) pair,
    in the order of each pair's first such row, and the compressed rows B^I of the nodes
    with mask > 0. Returns (h_idx, h_val, c_off, c_idx, c_val)."""
    args = (ftype_s, ftype_m, ftype_phi, xs, xm, msign, qp_xi, qp_w, qp_m, qp_zeta)
    args += (sdofs, mdofs, node_of)
    nloc = (xs.shape[1] + xm.shape[1]) * xs.shape[2]
    h_idx, h_val = np.zeros((0, nloc), np.int64), np.zeros((0, nloc, nloc))
    if want_hess:
        r_hess = contact_terms(*args, p, True)[2]
        fr, qr = _paired_rows(qp_m)
        pws = np.array(
            [
                qp_w[f, q]
                * (
                    np.where(node_of[f] >= 0, p[np.maximum(node_of[f], 0)], 0.0)
                    @ shape(ftype_phi, qp_xi[f, q])[0]
                )
                for f, q in zip(fr, qr, strict=True)
            ]
        )
        rows = np.flatnonzero(pws != 0.0)
        key = fr[rows] * xm.shape[0] + qp_m[fr[rows], qr[rows]]
        _, first, inv = np.unique(key, return_index=True, return_inverse=True)
        order = np.argsort(first)  # the groups in the order of their first row
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        h_val = np.zeros((order.size, nloc, nloc))
        np.add.at(h_val, rank[inv.ravel()], r_hess[rows])
        f1 = fr[rows][first[order]]
        h_idx = np.concatenate([sdofs[f1], mdofs[qp_m[f1, qr[rows][first[order]]]]], axis=1)
    c_off, c_idx, c_val = compress_rows(*node_rows(*args, mask))
    return h_idx.astype(np.int64), h_val, c_off, c_idx, c_val


def compress_rows(b_off, b_idx, b_val):
    """NumPy reference of :func:`dolfinx_mortar.kernels.mortar.compress_rows`: every row's
    entries with dof ≥ 0, duplicates summed, dofs sorted. Returns (c_off, c_idx, c_val)."""
    n = b_off.size - 1
    row = np.repeat(np.arange(n), np.diff(b_off))
    keep = b_idx >= 0
    pairs, inv = np.unique(np.stack([row[keep], b_idx[keep]], axis=1), axis=0, return_inverse=True)
    c_val = np.bincount(inv.ravel(), weights=b_val[keep], minlength=len(pairs))
    c_off = np.concatenate([[0], np.cumsum(np.bincount(pairs[:, 0], minlength=n))])
    return c_off.astype(np.int64), pairs[:, 1].astype(np.int64), c_val


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
):
    """NumPy reference of :func:`dolfinx_mortar.kernels.mortar.point_xi_terms`, per paired
    point: b = ∂g/∂u = Tᵀ ∂g/∂y, g, gxi_β = ν·x_s,β, db_β = (∂_βT)ᵀ ∂g/∂y + Tᵀ (∂²g/∂y∂x₁)
    x_s,β (the total ξ_β-derivative of Tᵀ ∂g/∂y with x₁(ξ)), phi = Φ(ξ), dphi = ∂Φ/∂ξ.
    Returns (b, db, g, gxi, phi, dphi)."""
    ns, d = xs.shape[1:]
    nm = xm.shape[1]
    k = qp_xi.shape[2]
    nloc = (ns + nm) * d
    fr, qr = _paired_rows(qp_m)
    n = fr.size
    nphi = node_of.shape[1]
    b, db = np.zeros((n, nloc)), np.zeros((n, k, nloc))
    g, gxi = np.zeros(n), np.zeros((n, k))
    phi, dphi = np.zeros((n, nphi)), np.zeros((n, nphi, k))
    for r, (f, q) in enumerate(zip(fr, qr, strict=True)):
        m = qp_m[f, q]
        xi, zeta = qp_xi[f, q], qp_zeta[f, q]
        N, dN, _ = shape(ftype_s, xi)
        g[r], dgy, d2gy = gap_derivatives(N @ xs[f], xm[m], ftype_m, msign[m], zeta)
        T = _dof_map(N, nm, d)
        b[r] = T.T @ dgy
        xp = dN.T @ xs[f]  # (k, d): x_s,β
        gxi[r] = xp @ normal(xm[m], ftype_m, msign[m], zeta)
        for be in range(k):
            db[r, be] = _dof_map(dN[:, be], nm, d, 0.0).T @ dgy + T.T @ (d2gy[:, :d] @ xp[be])
        phi[r], dphi[r] = shape(ftype_phi, xi)[:2]
    return b, db, g, gxi, phi, dphi


# ---------------------------------------------------------- friction point kernels
def slip_motion_blocks(
    g1,
    g2,
    slot_node,
    used,
    g_only,
    t_vec,
    w,
    dxi,
    dw,
    dg,
    dgxi,
    dgn,
    dgxin,
    Ns,
    dNs,
    Nm,
    dNm,
    psi,
    dpsi,
    vh,
    dvh,
    n_g1,
    n_g2,
):
    """NumPy reference of :func:`dolfinx_mortar.kernels.friction.slip_motion_blocks`, from
    its docstring's sums (vectorised over the rows, summed per group with ``np.add.at``).
    Returns (dS, dSn (n_g1, nphi, d, nloc), dAT (n_g1, nphi, nloc), tw (n_g2, (ns + nm) d,
    nloc), dMv (nv, n_g1, nphi, m, nloc)), the contributions alone (the kernel adds them)."""
    n, k, nloc = dxi.shape
    d = dg.shape[1]
    ns, nm, nphi = Ns.shape[1], Nm.shape[1], psi.shape[1]
    nv, m = vh.shape[0], vh.shape[3]
    # the slip integrals' rows (used) and, for the force weights tw, g_only's too
    sel_g = ((used | g_only)[:, None] & (slot_node >= 0)).astype(float)  # (n, nphi)
    sel = (used[:, None] & (slot_node >= 0)).astype(float)
    wp_g = w[:, None] * psi * sel_g  # w Ψ_i
    wp = wp_g * sel
    # dA = Ψ_i dw + w ∂_βΨ_i dξ^β
    dA_g = sel_g[:, :, None] * (
        psi[:, :, None] * dw[:, None, :] + w[:, None, None] * np.einsum("rib,rbj->rij", dpsi, dxi)
    )
    dA = dA_g * sel[:, :, None]
    dgx = np.einsum("rbc,rbj->rcj", dgxi, dxi)  # ∂_βΔg_c dξ^β
    dS_r = dg[:, None, :, None] * dA[:, :, None, :] + wp[:, :, None, None] * dgx[:, None]
    dgxn = np.einsum("rbc,rbj->rcj", dgxin, dxi)  # ∂_βd_n,c dξ^β (S_n's weights move too)
    dSn_r = dgn[:, None, :, None] * dA[:, :, None, :] + wp[:, :, None, None] * dgxn[:, None]
    # facet node weights: +(N_a dA + w Ψ ∂_βN_a dξ^β) (slave), −(…N^m_b…) (t_n master)
    Na = np.concatenate([Ns, -Nm], axis=1)
    dNa = np.einsum("rab,rbj->raj", np.concatenate([dNs, -dNm], axis=1), dxi)
    dX = Na[:, None, :, None] * dA_g[:, :, None, :] + wp_g[:, :, None, None] * dNa[:, None]
    t = t_vec[np.maximum(slot_node, 0)] * sel_g[:, :, None]  # (n, nphi, d)
    tw_r = np.einsum("ric,riaj->racj", t, dX).reshape(n, (ns + nm) * d, nloc)
    dv = np.einsum("vriba,rbj->vriaj", dvh, dxi)
    dM_r = vh[..., None] * dA[None, :, :, None, :] + wp[None, :, :, None, None] * dv
    dS = np.zeros((n_g1, nphi, d, nloc))
    dSn = np.zeros((n_g1, nphi, d, nloc))
    dAT = np.zeros((n_g1, nphi, nloc))
    tw = np.zeros((n_g2, (ns + nm) * d, nloc))
    dMv = np.zeros((nv, n_g1, nphi, m, nloc))
    np.add.at(dS, g1, dS_r)
    np.add.at(dSn, g1, dSn_r)
    np.add.at(dAT, g1, dA)
    np.add.at(tw, g2, tw_r)
    for v in range(nv):
        np.add.at(dMv[v], g1, dM_r[v])
    return dS, dSn, dAT, tw, dMv
