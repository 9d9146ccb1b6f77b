"""Weighted incremental slip of the slave nodes (numba), with a NumPy reference.

Slip of a slave quadrature point over the load step t_n → t_{n+1} (METHOD.md §1,
physical-slip rule): the point x¹(ξ) faced the master material point
x²(ζ_n) of facet m_n at t_n (closest-point projection in the t_n
configuration); its slip is its motion relative to that material point,

    Δg(ξ) = x¹_{n+1}(ξ) − x²_{n+1}(ζ_n; m_n),

evaluated with the CURRENT coordinates of the old master facet. Δg is linear in
the current nodal coordinates (ξ, ζ_n and m_n are fixed during the step), it
rotates with a superposed rigid motion, and it needs no special rule when the
projection moves to another master facet. At u = u_n it is the point's t_n gap
vector d_n(ξ) = x¹_n(ξ) − x²_n(ζ_n; m_n), along the normal of the master facet m_n,
not zero: the nodal slip is therefore measured from the start of the step,
σ^I_α = a^I_α·S^I − a^I_{α,n}·S^I_n (:mod:`dolfinx_mortar.friction`), with S_n below.

Nodal integrals over the owned mixed-field nodes I that touched at t_n (``node_ok``;
points paired now AND at t_n), with the weight functions Ψ_I (the mixed basis Φ_I, or its
dual basis on the facets flagged in ``use_dual``: ``tangential_weights``):

    A_T^I = Σ_q w_q J₀ Ψ_I(ξ_q),    S^I = Σ_q w_q J₀ Ψ_I(ξ_q) Δg(ξ_q)   (d-vector),
    S_n^I = Σ_q w_q J₀ Ψ_I(ξ_q) d_n(ξ_q)   (the same weights on the t_n coordinates),

and the constant weights W^I_k of S^I = Σ_k W^I_k x_k over the slave facet nodes
(W = w J₀ Ψ_I N_a) and the old master facet nodes (W = −w J₀ Ψ_I N^m_b(ζ_n)), one
entry per (node I, point, facet node): ``e_node``, ``e_key`` (global block of
node k), ``e_dof`` (its d global dofs, −1 where constrained), ``e_w``. The same entries
carry the force weights ``e_g`` (session 55), the test rows G^I of the residual
R_T = Σ_I (G^I)ᵀ t^I: slave part W's, master part −w J₀ Ψ_I N^m_b(ζ) at the point's
CURRENT projection (facet qp_m, ζ = qp_zeta), so that the traction acts where the slave
point is now, not at the t_n material point one step's slip behind (``at_current``
False: G = W, as before session 55). One layout for both: MortarContact merges
the entries per (node, block) into s_node, s_key, s_dof, s_w, s_g.
:func:`force_geometric_blocks` gives the tangent block of ζ's motion.

With element and node integration the weights, hence S_n, are constant in u. With
segment integration the points move with u; :func:`slip_point_terms` gives the pieces of
those derivatives along ξ (Δg and d_n, ∂Δg/∂ξ and ∂d_n/∂ξ through the t_n projection, the
shape functions and weights), which :mod:`dolfinx_mortar.contact` combines with the
motion of the points.
"""

from __future__ import annotations

import numpy as np

from ._numba import numba
from .gap import projection_derivative
from .shape import shape, tdim

#: relative shortfall of the paired area below which a facet still counts as fully paired
FULL_COVER_TOL = 1e-6

#: segment integration: relative shortfall of the paired area above which a facet that
#: chose the dual weights at a step's first evaluation falls back to Φ within the step (it
#: lost paired points for real; MortarContact fixes the choice per step attempt)
DUAL_KEEP_TOL = 1e-3


@numba.njit(cache=True)
def covered_area(qp_w, qp_m, qp_mn, out):
    """out (nsf,): the area (with J₀, the units of qp_w) of each slave facet that its points
    paired now (qp_m ≥ 0) and at t_n (qp_mn ≥ 0) cover; qp_w, qp_m, qp_mn (nsf, nq).
    A facet uses the dual weights where out ≥ (1 − FULL_COVER_TOL)·area (see
    :func:`slip_integrals`'s ``use_dual``)."""
    for f in range(qp_w.shape[0]):
        covered = 0.0
        for q in range(qp_w.shape[1]):
            if qp_m[f, q] >= 0 and qp_mn[f, q] >= 0:
                covered += qp_w[f, q]
        out[f] = covered


@numba.njit(cache=True)
def _weights(ftype_phi, xi, use_dual, dual_f, nphi, Psi, dPsi, Phi, dP, ddP):
    """Ψ_i(ξ) (nphi,) and ∂Ψ_i/∂ξ_β (nphi, k): Σ_j dual_f[i, j] Φ_j, or Φ itself."""
    shape(ftype_phi, xi, Phi, dP, ddP)
    k = dPsi.shape[1]
    for i in range(nphi):
        if use_dual:
            Psi[i] = 0.0
            for be in range(k):
                dPsi[i, be] = 0.0
            for j in range(nphi):
                Psi[i] += dual_f[i, j] * Phi[j]
                for be in range(k):
                    dPsi[i, be] += dual_f[i, j] * dP[j, be]
        else:
            Psi[i] = Phi[i]
            for be in range(k):
                dPsi[i, be] = dP[i, be]


@numba.njit(cache=True)
def _point_scratch(ns, nm, ks, km):
    """Work arrays of the friction kernels' point loops: the slave shape functions N (ns,),
    dN (ns, ks), ddN (ns, ks, ks), the master ones Nm (nm,), dNm (nm, km), ddNm
    (nm, km, km), and the mixed basis and weight functions Phi, Psi (9,), dPsi, dP (9, ks),
    ddP (9, ks, ks) (up to 9 nodes)."""
    return (
        np.empty(ns),
        np.empty((ns, ks)),
        np.empty((ns, ks, ks)),
        np.empty(nm),
        np.empty((nm, km)),
        np.empty((nm, km, km)),
        np.empty(9),
        np.empty(9),
        np.empty((9, ks)),
        np.empty((9, ks)),
        np.empty((9, ks, ks)),
    )


@numba.njit(cache=True)
def _put_entries(e, node, keys, dofs, shp, sw, sg, e_node, e_key, e_dof, e_w, e_g):
    """Write the entries of one node against the n nodes of one facet (:func:`slip_integrals`'
    layout): keys (n,) their global blocks, dofs (n·d,) their global dofs, shp (n,) their
    shape values at the point; entry e + b gets (node, keys[b], its d dofs, the S-weight
    sw·shp[b], the force weight sg·shp[b]). Returns the next free entry index."""
    d = e_dof.shape[1]
    for b in range(keys.shape[0]):
        e_node[e] = node
        e_key[e] = keys[b]
        for c in range(d):
            e_dof[e, c] = dofs[b * d + c]
        e_w[e] = sw * shp[b]
        e_g[e] = sg * shp[b]
        e += 1
    return e


@numba.njit(cache=True)
def slip_integrals(
    ftype_s,
    ftype_m,
    ftype_phi,
    xs,
    xm,
    xs_n,
    xm_n,
    qp_xi,
    qp_w,
    qp_m,
    qp_mn,
    qp_zn,
    qp_zeta,
    at_current,
    node_of,
    node_ok,
    dual,
    use_dual,
    skeys,
    sdofs,
    mkeys,
    mdofs,
    AT,
    S,
    Sn,
    e_node,
    e_key,
    e_dof,
    e_w,
    e_g,
):
    """Fill A_T (n,), S (n, d), S_n (n, d) and the weight entries; returns the number of
    entries.

    Each entry carries two weights: e_w, the S-weight W (S^I = Σ_k W_k x_k), and e_g, the
    force weight G of the traction's residual R_T = Σ_I (G^I)ᵀ t^I (session 55). G's slave
    part is W's, w J₀ Ψ_I N_a; its master part is −w J₀ Ψ_I N^m_b(ζ) at the CURRENT
    projection (facet qp_m, qp_zeta (nsf, nq, km)) where ``at_current``, else at ζ_n on
    m_n (G = W, the force on the master material point the slip is measured from, as
    before session 55). With ``at_current`` the master entries come twice: (W, 0) on
    the t_n facet m_n and (0, G) on the current facet m.

    S_n = Σ_q w_q J₀ Ψ_I(ξ_q) d_n(ξ_q) are the same S-weights applied to the t_n
    coordinates, d_n(ξ) = x¹_n(ξ) − x²_n(ζ_n; m_n) the point's t_n gap vector (module
    docstring): S = S_n at u = u_n.

    xs (nsf, ns, d), xm (nmf, nm, d) current and xs_n, xm_n (same shapes) t_n
    coordinates; qp_xi (nsf, nq, ks), qp_w
    (nsf, nq) weights with J₀; qp_m (nsf, nq) current pairing (−1: none), qp_mn, qp_zn
    (nsf, nq), (nsf, nq, km) the pairing at t_n; node_of (nsf, nphi); node_ok (n,) the nodes
    that take part (touching at t_n, see MortarContact); dual (nsf, nphi, nphi) the
    weight functions Ψ_i = Σ_j dual[f, i, j] Φ_j (identity: Ψ = Φ), used on facet f only
    where use_dual[f] (nsf,) bool: MortarContact sets it where the facet's points paired
    now and at t_n cover its whole area (:func:`covered_area`, to FULL_COVER_TOL; with
    segment integration decided once per step attempt, see DUAL_KEEP_TOL); elsewhere
    Ψ = Φ, so that no A_T^I comes from the negative part of Ψ alone; skeys (nsf, ns),
    mkeys (nmf, nm) global blocks; sdofs (nsf, ns·d), mdofs (nmf, nm·d) global dofs.
    Entry arrays must hold nsf·nq·nphi·(ns + 2 nm) rows (e_dof: (…, d)).
    """
    nsf, ns, d = xs.shape
    nq = qp_xi.shape[1]
    nm = xm.shape[1]
    nphi = node_of.shape[1]
    ks = tdim(ftype_s)
    km = tdim(ftype_m)
    N, dN, ddN, Nm, dNm, ddNm, Phi, Psi, dPsi, dP, ddP = _point_scratch(ns, nm, ks, km)
    Nc = np.empty(nm)
    dg = np.empty(d)
    dgn = np.empty(d)
    AT[:] = 0.0
    S[:, :] = 0.0
    Sn[:, :] = 0.0
    e = 0
    for f in range(nsf):
        dual_f = use_dual[f]
        for q in range(nq):
            mn = qp_mn[f, q]
            if qp_m[f, q] < 0 or qp_w[f, q] == 0.0:
                continue
            if mn < 0:
                # paired now, not at t_n (the strip a master end swept since t_n): no
                # slip reference, so no S-weight; the traction acts there all the same
                # where it acts at ζ (session 56), G only
                if not at_current:
                    continue
                shape(ftype_s, qp_xi[f, q], N, dN, ddN)
                shape(ftype_m, qp_zeta[f, q], Nc, dNm, ddNm)
                _weights(ftype_phi, qp_xi[f, q], dual_f, dual[f], nphi, Psi, dPsi, Phi, dP, ddP)
                m = qp_m[f, q]
                for i in range(nphi):
                    node = node_of[f, i]
                    if node < 0 or not node_ok[node]:
                        continue
                    wphi = qp_w[f, q] * Psi[i]
                    e = _put_entries(
                        e, node, skeys[f], sdofs[f], N, 0.0, wphi, e_node, e_key, e_dof, e_w, e_g
                    )
                    e = _put_entries(
                        e, node, mkeys[m], mdofs[m], Nc, 0.0, -wphi, e_node, e_key, e_dof, e_w, e_g
                    )
                continue
            shape(ftype_s, qp_xi[f, q], N, dN, ddN)
            shape(ftype_m, qp_zn[f, q], Nm, dNm, ddNm)
            if at_current:
                shape(ftype_m, qp_zeta[f, q], Nc, dNm, ddNm)
            _weights(ftype_phi, qp_xi[f, q], dual_f, dual[f], nphi, Psi, dPsi, Phi, dP, ddP)
            for c in range(d):
                s = 0.0
                sn = 0.0
                for a in range(ns):
                    s += N[a] * xs[f, a, c]
                    sn += N[a] * xs_n[f, a, c]
                for b in range(nm):
                    s -= Nm[b] * xm[mn, b, c]
                    sn -= Nm[b] * xm_n[mn, b, c]
                dg[c] = s
                dgn[c] = sn
            for i in range(nphi):
                node = node_of[f, i]
                if node < 0 or not node_ok[node]:
                    continue
                wphi = qp_w[f, q] * Psi[i]
                AT[node] += wphi
                for c in range(d):
                    S[node, c] += wphi * dg[c]
                    Sn[node, c] += wphi * dgn[c]
                e = _put_entries(
                    e, node, skeys[f], sdofs[f], N, wphi, wphi, e_node, e_key, e_dof, e_w, e_g
                )
                g_n = 0.0 if at_current else -wphi  # the master's G at ζ_n (m_n)
                e = _put_entries(
                    e, node, mkeys[mn], mdofs[mn], Nm, -wphi, g_n, e_node, e_key, e_dof, e_w, e_g
                )
                if at_current:
                    m = qp_m[f, q]
                    e = _put_entries(
                        e, node, mkeys[m], mdofs[m], Nc, 0.0, -wphi, e_node, e_key, e_dof, e_w, e_g
                    )
    return e


@numba.njit(cache=True)
def force_geometric_blocks(
    ftype_s,
    ftype_m,
    ftype_phi,
    xs,
    xm,
    qp_xi,
    qp_w,
    qp_m,
    qp_mn,
    qp_zeta,
    node_of,
    node_ok,
    dual,
    use_dual,
    sdofs,
    mdofs,
    t,
):
    """The geometric part of the tangential tangent with the force weights at the current
    projection (:func:`slip_integrals`' e_g, ``at_current``): the master rows of
    R_T = Σ_I (G^I)ᵀ t^I move with ζ_q, so at fixed t

        ∂R_T/∂u ∋ Σ_q Σ_I (−w_q J₀ Ψ_I(ξ_q)) t^I ⊗ ∂_γN^m_b(ζ_q) ∂ζ_q^γ/∂u

    on the rows of the current master facet m = qp_m[f, q], with ∂ζ/∂u the derivative of
    the closest-point projection (:func:`.gap.projection_derivative`: ∂ζ/∂x¹ N_a over the
    slave facet's nodes, ∂ζ/∂x^m_b over m's). The points and nodes are those of the
    force weights (paired now, whether or not at t_n: ``qp_mn`` is not read; node_ok);
    inputs as :func:`slip_integrals`, t (n, d) the nodal traction vectors.

    Returns rows (P, nm·d) (the current master facet's dofs), cols (P, (ns + nm)·d) (the
    slave facet's, then m's) and K (P, nm·d, (ns + nm)·d), one block per point with
    Σ_I Ψ_I t^I ≠ 0 (dofs −1: constrained, for ``setValuesRCV``)."""
    nsf, ns, d = xs.shape
    nq = qp_xi.shape[1]
    nm = xm.shape[1]
    nphi = node_of.shape[1]
    ks = tdim(ftype_s)
    km = tdim(ftype_m)
    nr, nc = nm * d, (ns + nm) * d
    P = 0
    for f in range(nsf):
        for q in range(nq):
            if qp_m[f, q] >= 0 and qp_w[f, q] != 0.0:
                P += 1
    rows = np.empty((P, nr), np.int64)
    cols = np.empty((P, nc), np.int64)
    K = np.zeros((P, nr, nc))
    N, dN, ddN, Nm, dNm, ddNm, Phi, Psi, dPsi, dP, ddP = _point_scratch(ns, nm, ks, km)
    x1 = np.empty(d)
    tq = np.empty(d)
    dz = np.empty((km, d * (1 + nm)))
    dzl = np.empty((km, nc))
    p = 0
    for f in range(nsf):
        for q in range(nq):
            m = qp_m[f, q]
            if m < 0 or qp_w[f, q] == 0.0:
                continue
            _weights(ftype_phi, qp_xi[f, q], use_dual[f], dual[f], nphi, Psi, dPsi, Phi, dP, ddP)
            tq[:] = 0.0
            for i in range(nphi):
                node = node_of[f, i]
                if node < 0 or not node_ok[node]:
                    continue
                for c in range(d):
                    tq[c] -= qp_w[f, q] * Psi[i] * t[node, c]
            nz = False
            for c in range(d):
                nz = nz or tq[c] != 0.0
            if not nz:
                continue
            shape(ftype_s, qp_xi[f, q], N, dN, ddN)
            shape(ftype_m, qp_zeta[f, q], Nm, dNm, ddNm)
            for c in range(d):
                s = 0.0
                for a in range(ns):
                    s += N[a] * xs[f, a, c]
                x1[c] = s
            projection_derivative(x1, xm[m], ftype_m, qp_zeta[f, q], dz)
            for ga in range(km):
                for a in range(ns):
                    for c in range(d):
                        dzl[ga, a * d + c] = dz[ga, c] * N[a]
                for j in range(nm * d):
                    dzl[ga, ns * d + j] = dz[ga, d + j]
            for j in range(ns * d):
                cols[p, j] = sdofs[f, j]
            for j in range(nm * d):
                cols[p, ns * d + j] = mdofs[m, j]
                rows[p, j] = mdofs[m, j]
            for b in range(nm):
                for j in range(nc):
                    v = 0.0
                    for ga in range(km):
                        v += dNm[b, ga] * dzl[ga, j]
                    for c in range(d):
                        K[p, b * d + c, j] = tq[c] * v
            p += 1
    return rows[:p], cols[:p], K[:p]


@numba.njit(cache=True)
def _master_shape_along_xi(
    ftype_m, zeta, xm_f, xs_f, N, dN, Nb, dNb, ddNb, x1, dzeta, dz, Nout, dNout
):
    r"""The master shape functions at the projection ζ of a slave point and their
    derivatives along the slave parameters ξ_β at fixed nodes (one configuration):
    x¹(ξ) = Σ_a N_a(ξ) xs_f[a] (N (ns,), dN (ns, k) at ξ; xs_f (ns, d)) projected at ζ
    (km,) on the master facet xm_f (nm, d),

        Nout_b = N^m_b(ζ),   dNout_bβ = ∂_γN^m_b(ζ) ∂ζ^γ/∂ξ_β,
        ∂ζ/∂ξ_β = (∂ζ/∂x¹) x¹,β   (:func:`.gap.projection_derivative`),

    Nout (nm,), dNout (nm, k) written. Scratch: Nb (nm,), dNb (nm, km), ddNb (nm, km, km),
    x1 (d,), dzeta (km, d (1 + nm)), dz (km, k)."""
    ns, d = xs_f.shape
    k = dN.shape[1]
    km = dz.shape[0]
    nm = Nb.shape[0]
    shape(ftype_m, zeta, Nb, dNb, ddNb)
    for c in range(d):
        x1[c] = 0.0
        for a in range(ns):
            x1[c] += N[a] * xs_f[a, c]
    projection_derivative(x1, xm_f, ftype_m, zeta, dzeta)
    for ga in range(km):
        for be in range(k):
            s = 0.0
            for c in range(d):
                xb = 0.0
                for a in range(ns):
                    xb += dN[a, be] * xs_f[a, c]
                s += dzeta[ga, c] * xb
            dz[ga, be] = s
    for b in range(nm):
        Nout[b] = Nb[b]
        for be in range(k):
            s = 0.0
            for ga in range(km):
                s += dNb[b, ga] * dz[ga, be]
            dNout[b, be] = s


@numba.njit(cache=True)
def slip_point_terms(
    ftype_s,
    ftype_m,
    ftype_phi,
    xs,
    xm,
    xs_n,
    xm_n,
    qp_xi,
    qp_w,
    qp_m,
    qp_mn,
    qp_zn,
    qp_zeta,
    dual,
    use_dual,
    current,
    dg,
    dgxi,
    dgn,
    dgxin,
    Ns,
    dNs,
    Nm,
    dNm,
    Nc,
    dNc,
    psi,
    dpsi,
    phi,
    dphi,
):
    r"""Per paired point (rows: qp_m >= 0, in (facet, point) order, as
    :func:`dolfinx_mortar.kernels.segment.segment_derivatives`), the pieces of the
    derivatives of the point's contributions to :func:`slip_integrals` along the slave
    parameters ξ_β, for the linearisation of moving (segment) points:

    dg = Δg(ξ) (d,) and dgxi_β = ∂Δg/∂ξ_β (k, d), with Δg(ξ) = x¹(ξ) − x²(ζ_n(ξ); m_n) and
    ζ_n(ξ) the closest-point projection of the t_n slave point x¹_n(ξ) on the t_n master
    facet m_n, so that

        ∂Δg/∂ξ_β = x¹,β(ξ) − Σ_b ∂_γ N^m_b(ζ_n) x_b · ∂ζ_n^γ/∂ξ_β,
        ∂ζ_n/∂ξ_β = (∂ζ_n/∂x¹_n) x¹_n,β(ξ)   (:func:`.gap.projection_derivative`);

    dgn = d_n(ξ) (d,) and dgxin_β = ∂d_n/∂ξ_β (k, d): the same with the t_n coordinates
    in place of the current ones, d_n(ξ) = x¹_n(ξ) − x²_n(ζ_n(ξ); m_n) (the point's t_n gap
    vector, whose weighted sum is S_n of :func:`slip_integrals`);

    Ns, dNs (ns,), (ns, k): the slave shape functions and their ξ-derivatives at ξ;
    Nm (nm,): N^m_b(ζ_n) and dNm (nm, k): ∂N^m_b(ζ_n)/∂ξ_β through ζ_n; Nc (nm,):
    N^m_b(ζ) at the point's CURRENT projection ζ = qp_zeta on facet qp_m and dNc (nm, k):
    ∂N^m_b(ζ)/∂ξ_β through ζ at fixed nodes, ∂ζ/∂ξ_β = (∂ζ/∂x¹) x¹,β(ξ) in the current
    configuration (the force weights' master part, :func:`slip_integrals`' e_g), computed
    only where ``current`` (bool: the traction acts at ζ,
    tangential.FORCE_AT_CURRENT_PROJECTION; else Nc, dNc are left as they are, one
    projection derivative per point saved); psi, dpsi (nphi,), (nphi, k): the weight
    functions Ψ_i(ξ) and ∂Ψ_i/∂ξ_β (dual where
    :func:`slip_integrals` uses them), phi, dphi: the mixed basis Φ_i(ξ) and ∂Φ_i/∂ξ_β.
    Rows of points that enter no slip integral (weight 0, or not paired at t_n) have
    psi = dpsi = 0, except, where ``current``, the points paired now but not at t_n:
    they carry the force weights only (:func:`slip_integrals`, session 56), so their psi,
    dpsi, phi, dphi, Ns, dNs, Nc, dNc are written and dg … dNm are left as they are.

    xs, xm current and xs_n (nsf, ns, d), xm_n (nmf, nm, d) t_n coordinates; the other
    inputs as :func:`slip_integrals`.
    """
    nsf, ns, d = xs.shape
    nq = qp_xi.shape[1]
    nm = xm.shape[1]
    nphi = psi.shape[1]
    k = qp_xi.shape[2]
    km = qp_zn.shape[2]
    N, dN, ddN, Nb, dNb, ddNb, Phi, Psi, dPsi, dP, ddP = _point_scratch(ns, nm, k, km)
    x1 = np.empty(d)
    dzeta = np.empty((km, d * (1 + nm)))
    dz = np.empty((km, k))
    row = -1
    for f in range(nsf):
        dual_f = use_dual[f]
        for q in range(nq):
            if qp_m[f, q] < 0:
                continue
            row += 1
            mn = qp_mn[f, q]
            for i in range(nphi):
                psi[row, i] = 0.0
                for be in range(k):
                    dpsi[row, i, be] = 0.0
            if qp_w[f, q] == 0.0 or (mn < 0 and not current):
                continue
            shape(ftype_s, qp_xi[f, q], N, dN, ddN)
            _weights(ftype_phi, qp_xi[f, q], dual_f, dual[f], nphi, Psi, dPsi, Phi, dP, ddP)
            for i in range(nphi):
                psi[row, i] = Psi[i]
                phi[row, i] = Phi[i]
                for be in range(k):
                    dpsi[row, i, be] = dPsi[i, be]
                    dphi[row, i, be] = dP[i, be]
            for a in range(ns):
                Ns[row, a] = N[a]
                for be in range(k):
                    dNs[row, a, be] = dN[a, be]
            if mn < 0:  # the force weights' own point (current): Nc, dNc; dg … dNm untouched
                _master_shape_along_xi(
                    ftype_m, qp_zeta[f, q], xm[qp_m[f, q]], xs[f], N, dN, Nb, dNb, ddNb, x1,
                    dzeta, dz, Nc[row], dNc[row],
                )  # fmt: skip
                continue
            # N^m(ζ_n) and ∂_β through ζ_n (t_n configuration), N^m(ζ) and ∂_β through ζ
            # (current configuration, the force weights: only where they act at ζ)
            _master_shape_along_xi(
                ftype_m, qp_zn[f, q], xm_n[mn], xs_n[f], N, dN, Nb, dNb, ddNb, x1, dzeta, dz,
                Nm[row], dNm[row],
            )  # fmt: skip
            if current:
                _master_shape_along_xi(
                    ftype_m, qp_zeta[f, q], xm[qp_m[f, q]], xs[f], N, dN, Nb, dNb, ddNb, x1,
                    dzeta, dz, Nc[row], dNc[row],
                )  # fmt: skip
            for c in range(d):
                s = 0.0
                sn = 0.0
                for a in range(ns):
                    s += N[a] * xs[f, a, c]
                    sn += N[a] * xs_n[f, a, c]
                for b in range(nm):
                    s -= Nm[row, b] * xm[mn, b, c]
                    sn -= Nm[row, b] * xm_n[mn, b, c]
                dg[row, c] = s
                dgn[row, c] = sn
                for be in range(k):
                    s = 0.0
                    sn = 0.0
                    for a in range(ns):
                        s += dN[a, be] * xs[f, a, c]
                        sn += dN[a, be] * xs_n[f, a, c]
                    for b in range(nm):
                        s -= dNm[row, b, be] * xm[mn, b, c]
                        sn -= dNm[row, b, be] * xm_n[mn, b, c]
                    dgxi[row, be, c] = s
                    dgxin[row, be, c] = sn


@numba.njit(cache=True)
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
    dS,
    dSn,
    dAT,
    tw,
    dMv,
):
    r"""Sums over the moving points (rows as :func:`slip_point_terms`) of the derivatives
    of the slip integrals (docs/method-notes.md, "Segment integration"), per point group.

    Per row r with ``used[r]`` and per mixed slot i with ``slot_node[r, i] >= 0`` (a node
    taking part), with dA = Ψ_i dw + w ∂_βΨ_i dξ^β:

        dAT[g1[r], i] += dA,    dS[g1[r], i, c] += Δg_c dA + w Ψ_i ∂_βΔg_c dξ^β,
        dSn[g1[r], i, c] += d_n,c dA + w Ψ_i ∂_βd_n,c dξ^β   (S_n's weights move too),
        tw[g2[r], a·d + c] += t_c (N_a dA + w Ψ_i ∂_βN_a dξ^β)            (slave node a),
        tw[g2[r], (ns + b)·d + c] −= t_c (N^m_b dA + w Ψ_i ∂_β[N^m_b] dξ^β) (master node b),
        dMv[v, g1[r], i, α] += v_h,α dA + w Ψ_i ∂_β v_h,α dξ^β          ((∂M v)^I per value v),

    t = t_vec[slot_node[r, i]]. Inputs: g1, g2 (n,) group numbers (rows of a group share
    their local dofs: (facet, master) and (facet, master, t_n master)); slot_node (n, nphi);
    used (n,) bool: the points of the slip integrals; g_only (n,) bool: the force
    weights' own points (paired now, not at t_n, the traction at ζ: session 56), whose
    rows add to tw alone (dA as above); t_vec (n_nodes, d); w (n,); dxi (n, k, nloc),
    dw (n, nloc) from :func:`.segment.segment_derivatives`; dg … dpsi (dgn, dgxin: d_n, ∂d_n/∂ξ) from
    :func:`slip_point_terms`, Nm, dNm there its N^m(ζ_n) or, for the force weights at the
    current projection (session 55), its Nc, dNc: the caller picks the master rows' facet
    (m_n or the current m); vh
    (nv, n, nphi, m), dvh (nv, n, nphi, k, m): the interpolated nodal values of the
    consistent tangential recoveries as seen by slot i (nv = 0: none). Outputs (added to):
    dS, dSn (G1, nphi, d, nloc), dAT (G1, nphi, nloc), tw (G2, (ns + nm)·d, nloc), dMv
    (nv, G1, nphi, m, nloc).
    """
    n, k, nloc = dxi.shape
    d = dg.shape[1]
    ns = Ns.shape[1]
    nm = Nm.shape[1]
    nphi = psi.shape[1]
    nv = vh.shape[0]
    m = vh.shape[3]
    dA = np.empty(nloc)
    dX = np.empty(nloc)
    for r in range(n):
        if not used[r] and not g_only[r]:
            continue
        a1 = g1[r]
        a2 = g2[r]
        for i in range(nphi):
            node = slot_node[r, i]
            if node < 0:
                continue
            wp = w[r] * psi[r, i]
            for j in range(nloc):
                s = psi[r, i] * dw[r, j]
                for be in range(k):
                    s += w[r] * dpsi[r, i, be] * dxi[r, be, j]
                dA[j] = s
                if used[r]:
                    dAT[a1, i, j] += s
            for c in range(d if used[r] else 0):
                for j in range(nloc):
                    s = dg[r, c] * dA[j]
                    sn = dgn[r, c] * dA[j]
                    for be in range(k):
                        s += wp * dgxi[r, be, c] * dxi[r, be, j]
                        sn += wp * dgxin[r, be, c] * dxi[r, be, j]
                    dS[a1, i, c, j] += s
                    dSn[a1, i, c, j] += sn
            for a in range(ns + nm):
                for j in range(nloc):
                    if a < ns:
                        s = Ns[r, a] * dA[j]
                        for be in range(k):
                            s += wp * dNs[r, a, be] * dxi[r, be, j]
                    else:
                        s = Nm[r, a - ns] * dA[j]
                        for be in range(k):
                            s += wp * dNm[r, a - ns, be] * dxi[r, be, j]
                        s = -s
                    dX[j] = s
                for c in range(d):
                    tc = t_vec[node, c]
                    if tc != 0.0:
                        for j in range(nloc):
                            tw[a2, a * d + c, j] += tc * dX[j]
            for v in range(nv if used[r] else 0):
                for al in range(m):
                    for j in range(nloc):
                        s = vh[v, r, i, al] * dA[j]
                        for be in range(k):
                            s += wp * dvh[v, r, i, be, al] * dxi[r, be, j]
                        dMv[v, a1, i, al, j] += s


@numba.njit(cache=True)
def _node_dofs(node, s_off, s_dof, f_off, f_dofs, b_lo, b_hi, b_idx):
    """Sorted unique dofs ≥ 0 of one node: its S-weights', its frame's and its B row's."""
    e0, e1, p0, p1 = s_off[node], s_off[node + 1], f_off[node], f_off[node + 1]
    d, nb = s_dof.shape[1], f_dofs.shape[1]
    buf = np.empty((e1 - e0) * d + (p1 - p0) * nb * d + (b_hi - b_lo), np.int64)
    c = 0
    for e in range(e0, e1):
        for j in range(d):
            buf[c] = s_dof[e, j]
            c += 1
    for p in range(p0, p1):
        for a in range(nb):
            for j in range(d):
                buf[c] = f_dofs[p, a, j]
                c += 1
    for t in range(b_lo, b_hi):
        buf[c] = b_idx[t]
        c += 1
    u = np.unique(buf)
    return u[u >= 0]


@numba.njit(cache=True)
def _node_slip_rates(
    i, node, Ui, a, S, AT, tau, D, Pd, kN, s_off, s_dof, s_w, f_off, f_dofs, fdA, b_lo, b_hi, b_idx,
    b_val,
):  # fmt: skip
    """(Srow (d, nu), dt (d, nu)) of listed node i over its sorted dofs Ui: the S-weights
    ∂S^I/∂u and ∂t^I/∂u (:func:`node_tangent_blocks`)."""
    m, d = a.shape[1], a.shape[2]
    nb = f_dofs.shape[1]
    nu = Ui.size
    Srow = np.zeros((d, nu))
    Frow = np.zeros((m, d, nu))
    Brow = np.zeros(nu)
    for e in range(s_off[node], s_off[node + 1]):
        for c in range(d):
            if s_dof[e, c] >= 0:
                Srow[c, np.searchsorted(Ui, s_dof[e, c])] += s_w[e]
    for p in range(f_off[node], f_off[node + 1]):
        for b in range(nb):
            for c2 in range(d):
                dof = f_dofs[p, b, c2]
                if dof < 0:
                    continue
                j = np.searchsorted(Ui, dof)
                for al in range(m):
                    for c in range(d):
                        Frow[al, c, j] += fdA[p, b, al, c, c2]
    for t in range(b_lo, b_hi):
        if b_idx[t] >= 0:
            Brow[np.searchsorted(Ui, b_idx[t])] += b_val[t]
    dgam = np.zeros((m, nu))
    for al in range(m):
        for j in range(nu):
            v = 0.0
            for c in range(d):
                v += a[node, al, c] * Srow[c, j] + S[node, c] * Frow[al, c, j]
            dgam[al, j] = v / AT[node]
    dt = np.zeros((d, nu))
    for al in range(m):
        for j in range(nu):
            dtau = -Pd[i, al] * kN[i] * Brow[j]
            for be in range(m):
                dtau += D[i, al, be] * dgam[be, j]
            for c in range(d):
                dt[c, j] += a[node, al, c] * dtau + tau[node, al] * Frow[al, c, j]
    return Srow, dt


@numba.njit(cache=True)
def node_tangent_blocks(
    all_rows,
    nodes,
    a,
    S,
    AT,
    tau,
    D,
    Pd,
    kN,
    s_off,
    s_dof,
    s_w,
    s_g,
    f_off,
    f_dofs,
    fdA,
    b_off,
    b_idx,
    b_val,
):
    """The nodal friction tangents K_I = (G^I)ᵀ ∂t^I/∂u of the listed nodes, packed
    (numba; :func:`dolfinx_mortar.friction.node_tangent` is the NumPy reference, one node
    at a time, and the module docstring there has the equations):

        ∂γ = (a ∂S + S·∂a)/A_T,   ∂τ = D ∂γ − Pd kN B,   ∂t = aᵀ ∂τ + τ_α ∂a_α

    (γ = σ/A_T, σ = a·S − a_n·S_n: at fixed points a_n·S_n does not depend on u).

    nodes (k,): node indices into a (n, m, d) frames, S (n, d) weighted slips, AT (n,),
    tau (n, m); per listed node D (k, m, m), Pd (k, m), kN (k,) and the row B as CSR
    b_off (k + 1,), b_idx, b_val (global dofs, any order, repeats summed). s_off (n + 1,),
    s_dof (E, d), s_w (E,): the S-weights of each node (S = Σ_e w_e x_e), s_g (E,) its
    force weights, the test rows G^I of R_T = Σ_I (G^I)ᵀ t^I (:func:`slip_integrals`' e_g;
    G = W = ∂S^I/∂u where the traction acts at ζ_n); the frames'
    occurrence layout (:class:`dolfinx_mortar.friction.NodalFrames`, ``MasterFrames``):
    f_off (n + 1,) per node, f_dofs (P, nb, d) the dofs of each occurrence's facet nodes,
    fdA (P, nb, m, d, d) ∂a_α/∂x per facet node. Dofs < 0 (constrained) are left out.

    Returns (u_off (k + 1,), U: each node's sorted dofs U_i, r_off (k + 1,), R: each
    node's rows R_i ⊂ U_i, k_off (k + 1,), K: each node's (nr, nu) block row-major).
    Only the rows of the node's weight entries (those of G^I) can be nonzero: with
    ``all_rows`` R_i = U_i, the square block (the lumped recovery:
    :func:`dolfinx_mortar.assembly.add_square_blocks` takes u_off, U, k_off, K); without,
    R_i = those rows alone, nr × nu entries instead of nu × nu where B reaches far beyond
    the node's facets (the constrained normal recovery's ∂p^I/∂u through M⁻¹, session
    53; :func:`dolfinx_mortar.assembly.add_row_blocks`). The rows are marked in U_i
    (``searchsorted`` of the S-weights' dofs) rather than sorted apart: R_i = U_i[marked],
    in U_i's order (session 54, BENCHMARKS.md §66)."""
    k = nodes.size
    d = a.shape[2]
    dofs = [
        _node_dofs(nodes[i], s_off, s_dof, f_off, f_dofs, b_off[i], b_off[i + 1], b_idx)
        for i in range(k)
    ]
    u_off = np.zeros(k + 1, np.int64)
    for i in range(k):
        u_off[i + 1] = u_off[i] + dofs[i].size
    # pos[u_off[i] : u_off[i] + nr_i]: the positions in U_i of node i's rows, ascending
    pos = np.empty(u_off[k], np.int64)
    mark = np.zeros(u_off[k], np.bool_)
    r_off = np.zeros(k + 1, np.int64)
    k_off = np.zeros(k + 1, np.int64)
    for i in range(k):
        Ui, b0 = dofs[i], u_off[i]
        nu, nr = Ui.size, 0
        if all_rows:
            for j in range(nu):
                pos[b0 + j] = j
            nr = nu
        else:
            node = nodes[i]
            for e in range(s_off[node], s_off[node + 1]):
                for c in range(d):
                    if s_dof[e, c] >= 0:
                        mark[b0 + np.searchsorted(Ui, s_dof[e, c])] = True
            for j in range(nu):
                if mark[b0 + j]:
                    pos[b0 + nr] = j
                    nr += 1
        r_off[i + 1] = r_off[i] + nr
        k_off[i + 1] = k_off[i] + nr * nu
    U = np.empty(u_off[k], np.int64)
    R = np.empty(r_off[k], np.int64)
    K = np.zeros(k_off[k])
    for i in range(k):
        node = nodes[i]
        Ui, b0 = dofs[i], u_off[i]
        nu, nr = Ui.size, r_off[i + 1] - r_off[i]
        U[b0 : u_off[i + 1]] = Ui
        _, dt = _node_slip_rates(
            i, node, Ui, a, S, AT, tau, D, Pd, kN, s_off, s_dof, s_w, f_off, f_dofs, fdA,
            b_off[i], b_off[i + 1], b_idx, b_val,
        )  # fmt: skip
        Grow = np.zeros((d, nu))
        for e in range(s_off[node], s_off[node + 1]):
            for c in range(d):
                if s_dof[e, c] >= 0:
                    Grow[c, np.searchsorted(Ui, s_dof[e, c])] += s_g[e]
        base = k_off[i]
        for q in range(nr):
            r = pos[b0 + q]
            R[r_off[i] + q] = Ui[r]
            for j in range(nu):
                v = 0.0
                for c in range(d):
                    v += Grow[c, r] * dt[c, j]
                K[base + q * nu + j] = v
    return u_off, U, r_off, R, k_off, K


def slip_integrals_reference(
    ftype_s,
    ftype_m,
    ftype_phi,
    xs,
    xm,
    xs_n,
    xm_n,
    qp_xi,
    qp_w,
    qp_m,
    qp_mn,
    qp_zn,
    node_of,
    node_ok,
    dual,
    use_dual,
    qp_zeta=None,
):
    """NumPy reference of :func:`slip_integrals`: returns (A_T, S, S_n, W, G) with W the
    S-weights and G the force weights, dicts {(node, slave|master, facet, local node):
    weight} (for tests); G's master part at the current projection ``qp_zeta`` on qp_m
    (``at_current``), or G = W where ``qp_zeta`` is None."""
    from .shape import REFERENCE_NODES

    d = xs.shape[2]
    n_nodes = node_ok.size
    AT = np.zeros(n_nodes)
    S = np.zeros((n_nodes, d))
    Sn = np.zeros((n_nodes, d))
    W, G = {}, {}

    def sh(ftype, xi):
        n = REFERENCE_NODES[ftype].shape[0]
        k = REFERENCE_NODES[ftype].shape[1]
        out = np.empty(max(n, 9))
        shape(ftype, np.ascontiguousarray(xi, float), out, np.empty((9, k)), np.empty((9, k, k)))
        return out[:n]

    for f in range(xs.shape[0]):
        C = dual[f] if use_dual[f] else np.eye(dual.shape[1])
        for q in range(qp_xi.shape[1]):
            mn = qp_mn[f, q]
            if qp_m[f, q] < 0 or mn < 0 or qp_w[f, q] == 0.0:
                continue
            N = sh(ftype_s, qp_xi[f, q])
            Nm = sh(ftype_m, qp_zn[f, q])
            Phi = C @ sh(ftype_phi, qp_xi[f, q])
            dg = N @ xs[f] - Nm @ xm[mn]
            dgn = N @ xs_n[f] - Nm @ xm_n[mn]
            for i, node in enumerate(node_of[f]):
                if node < 0 or not node_ok[node]:
                    continue
                wphi = qp_w[f, q] * Phi[i]
                AT[node] += wphi
                S[node] += wphi * dg
                Sn[node] += wphi * dgn
                for a in range(N.size):
                    key = (node, "s", f, a)
                    W[key] = W.get(key, 0.0) + wphi * N[a]
                    G[key] = G.get(key, 0.0) + wphi * N[a]
                for b in range(Nm.size):
                    key = (node, "m", mn, b)
                    W[key] = W.get(key, 0.0) - wphi * Nm[b]
                m, Nc = (mn, Nm) if qp_zeta is None else (qp_m[f, q], sh(ftype_m, qp_zeta[f, q]))
                for b in range(Nc.size):
                    key = (node, "m", m, b)
                    G[key] = G.get(key, 0.0) - wphi * Nc[b]
    return AT, S, Sn, W, G
