"""Weighted incremental slip of the slave nodes (numba), with a NumPy reference.

Slip of a slave quadrature point over the load step t_n → t_{n+1} (METHOD.md §1,
physical-slip rule): the point x¹(ξ) faced the master material point
x²(ζ_n) of facet m_n at t_n (closest-point projection in the t_n
configuration); its slip is its motion relative to that material point,

    Δg(ξ) = x¹_{n+1}(ξ) − x²_{n+1}(ζ_n; m_n),

evaluated with the CURRENT coordinates of the old master facet. Δg is linear in
the current nodal coordinates (ξ, ζ_n and m_n are fixed during the step), it
rotates with a superposed rigid motion (the tangential components taken in a
convected frame are incrementally objective), and it needs no special rule
when the projection moves to another master facet. Its normal component is
discarded by the nodal frame (:mod:`dolfinx_mortar.friction`).

Nodal integrals over the owned mixed-field nodes I that touched at t_n (``node_ok``;
points paired now AND at t_n), with the weight functions Ψ_I (the mixed basis Φ_I, or its
dual basis on the facets of finite ``area``: ``tangential_weights``):

    A_T^I = Σ_q w_q J₀ Ψ_I(ξ_q),    S^I = Σ_q w_q J₀ Ψ_I(ξ_q) Δg(ξ_q)   (d-vector),

and the constant weights W^I_k of S^I = Σ_k W^I_k x_k over the slave facet nodes
(W = w J₀ Ψ_I N_a) and the old master facet nodes (W = −w J₀ Ψ_I N^m_b(ζ_n)), one
entry per (node I, point, facet node): ``e_node``, ``e_key`` (global block of
node k), ``e_dof`` (its d global dofs, −1 where constrained), ``e_w``.
"""

from __future__ import annotations

import numba
import numpy as np

from .shape import shape, tdim

#: relative shortfall of the paired area below which a facet still counts as fully paired
FULL_COVER_TOL = 1e-6


@numba.njit(cache=True)
def slip_integrals(
    ftype_s,
    ftype_m,
    ftype_phi,
    xs,
    xm,
    qp_xi,
    qp_w,
    qp_m,
    qp_mn,
    qp_zn,
    node_of,
    node_ok,
    dual,
    area,
    skeys,
    sdofs,
    mkeys,
    mdofs,
    AT,
    S,
    e_node,
    e_key,
    e_dof,
    e_w,
):
    """Fill A_T (n,), S (n, d) and the weight entries; returns the number of entries.

    xs (nsf, ns, d), xm (nmf, nm, d) current coordinates; qp_xi (nsf, nq, ks), qp_w
    (nsf, nq) weights with J₀; qp_m (nsf, nq) current pairing (−1: none), qp_mn, qp_zn
    (nsf, nq), (nsf, nq, km) the pairing at t_n; node_of (nsf, nphi); node_ok (n,) the nodes
    that take part (touching at t_n, see MortarContact); dual (nsf, nphi, nphi) the
    weight functions Ψ_i = Σ_j dual[f, i, j] Φ_j (identity: Ψ = Φ), used on a facet only
    where its points paired now and at t_n cover its whole area (nsf,) (to 1e-6; elsewhere
    Ψ = Φ, so that no A_T^I comes from the negative part of Ψ alone; area = inf keeps Φ on
    that facet); skeys (nsf, ns),
    mkeys (nmf, nm) global blocks; sdofs (nsf, ns·d), mdofs (nmf, nm·d) global dofs.
    Entry arrays must hold nsf·nq·nphi·(ns + nm) rows (e_dof: (…, d)).
    """
    nsf, ns, d = xs.shape
    nq = qp_xi.shape[1]
    nm = xm.shape[1]
    nphi = node_of.shape[1]
    ks = tdim(ftype_s)
    km = tdim(ftype_m)
    N = np.empty(ns)
    dN = np.empty((ns, ks))
    ddN = np.empty((ns, ks, ks))
    Nm = np.empty(nm)
    dNm = np.empty((nm, km))
    ddNm = np.empty((nm, km, km))
    Phi = np.empty(9)
    Psi = np.empty(9)
    dP = np.empty((9, ks))
    ddP = np.empty((9, ks, ks))
    dg = np.empty(d)
    AT[:] = 0.0
    S[:, :] = 0.0
    e = 0
    for f in range(nsf):
        covered = 0.0
        for q in range(nq):
            if qp_m[f, q] >= 0 and qp_mn[f, q] >= 0:
                covered += qp_w[f, q]
        use_dual = covered >= (1.0 - FULL_COVER_TOL) * area[f]
        for q in range(nq):
            mn = qp_mn[f, q]
            if qp_m[f, q] < 0 or mn < 0 or qp_w[f, q] == 0.0:
                continue
            shape(ftype_s, qp_xi[f, q], N, dN, ddN)
            shape(ftype_m, qp_zn[f, q], Nm, dNm, ddNm)
            shape(ftype_phi, qp_xi[f, q], Phi, dP, ddP)
            for i in range(nphi):
                if use_dual:
                    Psi[i] = 0.0
                    for j in range(nphi):
                        Psi[i] += dual[f, i, j] * Phi[j]
                else:
                    Psi[i] = Phi[i]
            for c in range(d):
                s = 0.0
                for a in range(ns):
                    s += N[a] * xs[f, a, c]
                for b in range(nm):
                    s -= Nm[b] * xm[mn, b, c]
                dg[c] = s
            for i in range(nphi):
                node = node_of[f, i]
                if node < 0 or not node_ok[node]:
                    continue
                wphi = qp_w[f, q] * Psi[i]
                AT[node] += wphi
                for c in range(d):
                    S[node, c] += wphi * dg[c]
                for a in range(ns):
                    e_node[e] = node
                    e_key[e] = skeys[f, a]
                    for c in range(d):
                        e_dof[e, c] = sdofs[f, a * d + c]
                    e_w[e] = wphi * N[a]
                    e += 1
                for b in range(nm):
                    e_node[e] = node
                    e_key[e] = mkeys[mn, b]
                    for c in range(d):
                        e_dof[e, c] = mdofs[mn, b * d + c]
                    e_w[e] = -wphi * Nm[b]
                    e += 1
    return e


def slip_integrals_reference(
    ftype_s,
    ftype_m,
    ftype_phi,
    xs,
    xm,
    qp_xi,
    qp_w,
    qp_m,
    qp_mn,
    qp_zn,
    node_of,
    node_ok,
    dual,
    area,
):
    """NumPy reference of :func:`slip_integrals`: returns (A_T, S, W) with W a dict
    {(node, slave|master, facet, local node): weight} (for tests)."""
    from .shape import REFERENCE_NODES

    d = xs.shape[2]
    n_nodes = node_ok.size
    AT = np.zeros(n_nodes)
    S = np.zeros((n_nodes, d))
    W = {}

    def sh(ftype, xi):
        n = REFERENCE_NODES[ftype].shape[0]
        k = REFERENCE_NODES[ftype].shape[1]
        out = np.empty(max(n, 9))
        shape(ftype, np.ascontiguousarray(xi, float), out, np.empty((9, k)), np.empty((9, k, k)))
        return out[:n]

    for f in range(xs.shape[0]):
        paired = (qp_m[f] >= 0) & (qp_mn[f] >= 0)
        full = qp_w[f][paired].sum() >= (1.0 - FULL_COVER_TOL) * area[f]
        C = dual[f] if full else np.eye(dual.shape[1])
        for q in range(qp_xi.shape[1]):
            mn = qp_mn[f, q]
            if qp_m[f, q] < 0 or mn < 0 or qp_w[f, q] == 0.0:
                continue
            N = sh(ftype_s, qp_xi[f, q])
            Nm = sh(ftype_m, qp_zn[f, q])
            Phi = C @ sh(ftype_phi, qp_xi[f, q])
            dg = N @ xs[f] - Nm @ xm[mn]
            for i, node in enumerate(node_of[f]):
                if node < 0 or not node_ok[node]:
                    continue
                wphi = qp_w[f, q] * Phi[i]
                AT[node] += wphi
                S[node] += wphi * dg
                for a in range(N.size):
                    key = (node, "s", f, a)
                    W[key] = W.get(key, 0.0) + wphi * N[a]
                for b in range(Nm.size):
                    key = (node, "m", mn, b)
                    W[key] = W.get(key, 0.0) - wphi * Nm[b]
    return AT, S, W
