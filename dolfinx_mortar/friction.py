"""Coulomb friction at the slave nodes: convected nodal frames, return mapping, nodal tangent.

Node-level part of the tangential three-field formulation (METHOD.md §1, §2, §4)
with lumped tangential recovery (the normal pressure in the Coulomb limit comes from the
lumped or the constrained normal recovery); the point integrals are in
:mod:`dolfinx_mortar.kernels.friction`. With m = d − 1 tangential directions:

- **Nodal frame** (:class:`NodalFrames`): an orthonormal basis a_α^I (α < m) of
  the tangent plane of the slave surface at node I, convected with the slave
  surface, so a superposed rigid motion rotates it (incremental objectivity).
  In 2D a_1 = t̃/|t̃|, t̃ = Σ_f s_f ∂x/∂ξ|_f(ξ_I) (the oriented facet tangents at
  the node, t̃ turned by −90° is the outward normal). In 3D the normal is
  n = ñ/|ñ|, ñ = Σ_f s_f (∂x/∂ξ¹ × ∂x/∂ξ²)|_f(ξ_I), a_1 is the unit tangential
  part of the convected vector e = Σ_f F_f E (F_f the surface deformation
  gradient of facet f at the node, E a fixed reference tangent: the global x
  axis, or y when x is within 10° of the reference normal), and a_2 = n × a_1.
  The metric of the frame is the identity, so covariant and contravariant
  components coincide (a_αβ = δ_αβ).
- **Master frame** (``tangential_frame = "master"``, :class:`MasterFrames`): the
  master's convected covariant basis g_α at the material point the node faced at t_n,
  with its metric and contravariant components (METHOD.md §1); the return mapping in
  covariant components with the metric (:func:`covariant_return_mapping`) is run in an
  orthonormal basis of the same plane, convected as g_α is, which gives the same states
  and traction.
- **Symmetry planes.** At a node on a symmetry plane (a displacement component k held
  at zero by a Dirichlet condition, the reference normal within 60° of the plane, and
  the master's body held so on the same plane: the contact term marks only those,
  ``MortarContact._held_at_zero``; a roller wall beside a sliding master is none)
  the frame is the one of the mirrored model: the normal ñ − (ñ·e_k) e_k, in the
  plane, and the tangent e_k across it (3D: a_1 = e_k, a_2 = n × e_k). The slip and
  the traction along e_k are odd in the mirror, so the mirrored model has none at the
  plane: that component is left out (a_1 = 0; in 2D the node then carries no
  tangential traction, in 3D only along a_2; on two planes none). The half model's
  one-sided weighted slip S^I = ∫_{half support} Φ_I Δg had put the full Coulomb
  traction μ p_N on the axis node of a frictional Hertz half model, where the
  mirrored model has S^I = 0.
- **Slip since the start of the step** (session 45): the tangential components of the
  weighted slip, measured from t_n in the node's convected frame,

      σ_α^I = a_α^I · S^I − a_{α,n}^I · S_n^I,

  with S_n^I = Σ_e W_e x_{e,n} the same S-weights (same points, pairing set and Ψ_I) on
  the t_n coordinates and a_{α,n}^I the node's frame (either kind, symmetry cuts
  included) in the t_n configuration. At u = u_n, S^I = S_n^I is the weighted t_n gap
  vector ∫Ψ_I d_n, d_n(ξ) = x¹_n(ξ) − x²_n(ζ_n) along the normal of the point's master
  facet, which on a non-matching interface has a tangential part in the node's frame:
  a·S alone counted it as a slip in every step, and the stick tractions of a held load
  drifted step by step (docs/method-notes.md, "Slip since t_n"). σ = 0 at u = u_n
  exactly, and a rigid motion superposed on the t_{n+1} configuration turns S and a
  alike and leaves a_n·S_n: σ stays incrementally objective. With element and node
  integration the weights are constant, a_n·S_n does not depend on u and the residual
  and tangent below are those of a·S; with segment integration the weights move with
  the points and ∂σ gains −a_n·∂S_n.
- **Recovery** (lumped): γ_α^I = σ_α^I / A_T^I, the tangential components of the nodal
  average slip since t_n.
- **Return mapping** (:func:`return_mapping`): trial τ^tr = λ_T + ε_T γ,
  Φ = |τ^tr| − μ p_N; stick (Φ ≤ 0) τ = τ^tr, slip τ = μ p_N τ^tr/|τ^tr|; open
  nodes (p_N = 0) τ = 0. λ_T is the tangential multiplier: the traction of the
  last converged step, then the Uzawa iterates.
- **Residual** R_T = Σ_I (G^I)ᵀ t^I with t^I = τ_α a_α^I (the traction resisting
  slip; the master pushes the slave with −t^I per unit reference area) and G^I the
  node's force weights (session 55): on the slave those of S^I (w J₀ Ψ_I N_a), on the
  master −w J₀ Ψ_I N^m_b(ζ) at the CURRENT projection ζ of each point (the continuum's
  δg_T at the current closest point), or at ζ_n, G^I = ∂S^I/∂u (before session 55):
  ``tangential.FORCE_AT_CURRENT_PROJECTION``. At ζ, G^I also takes the points paired now
  but not at t_n (session 56: the strip a master end swept since t_n), which have no
  S-weight.
  The variation of the frame is not part of the weak form (as the paper omits the
  variation of a_αβ); it IS part of the tangent, through t^I(u).
- **Tangent** (:func:`node_tangent`): K_I = (G^I)ᵀ ∂t^I/∂u, with
  ∂t = a_αᵀ ∂τ_α + τ_α ∂a_α, ∂τ = D ∂γ + P ∂p_N, ∂γ_β = (a_β·∂S + S·∂a_β)/A_T
  (segment integration: also − a_{β,n}·∂S_n and − γ_β ∂A_T, the moving points),
  ∂p_N = −(ε_N/A) B^I; with G at ζ also the geometric block of ζ's motion,
  Σ_q Σ_I (−w Ψ_I) t^I ⊗ ∂_γN^m_b(ζ_q) ∂ζ_q^γ/∂u
  (:func:`dolfinx_mortar.kernels.friction.force_geometric_blocks`, left out with the
  normal part's geometric block). Exact (no term dropped) and non-symmetric. The contact term
  computes all nodes at once with the numba kernel
  :func:`dolfinx_mortar.kernels.friction.node_tangent_blocks`; :func:`node_tangent` is its
  reference, and still serves segment integration (its moving points).
"""

from __future__ import annotations

import numpy as np

from .kernels.shape import REFERENCE_NODES, shape, tdim

#: states written to the CSV / XDMF ``contact_state``
OPEN, STICK, SLIP = 0, 1, 2


#: a displacement component held at zero marks a symmetry plane at a slave node when
#: the node's reference normal n₀ has |n₀·e_k| ≤ this (the plane within 60° of the
#: normal): see :class:`NodalFrames`
SYMMETRY_NORMAL_TOL = 0.5


def _cross_matrix(w: np.ndarray) -> np.ndarray:
    """[w]× with [w]× v = w × v, for w (..., 3): shape (..., 3, 3)."""
    z = np.zeros(w.shape[:-1])
    return np.stack(
        [
            np.stack([z, -w[..., 2], w[..., 1]], -1),
            np.stack([w[..., 2], z, -w[..., 0]], -1),
            np.stack([-w[..., 1], w[..., 0], z], -1),
        ],
        -2,
    )


def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    nv = np.linalg.norm(v, axis=-1)
    return v / np.maximum(nv, 1e-300)[..., None], nv


class NodalFrames:
    """Convected orthonormal tangent frames at the owned slave nodes (see module docstring).

    Parameters: ftype (slave facet type), X (nsf, ns, d) reference coordinates,
    sign (nsf,) orientation (+1/−1: outward normal), node_of (nsf, nphi) owned-node
    index of the mixed nodes (−1: not owned), mixed (nphi,) their facet-local
    numbers, n_nodes. The frame of node I uses every slave facet around it, so
    the frames do not depend on the partition.

    ``held_at_zero`` (nsf, ns, d) bool, optional: the displacement components of the
    facet nodes held at zero by a Dirichlet condition (the contact term passes those
    whose plane the master's body is held on too, and clamps). A node with some, not all, of its
    components held, each within SYMMETRY_NORMAL_TOL of the plane it defines (|n₀·e_k|
    ≤ SYMMETRY_NORMAL_TOL for the reference normal n₀), lies on a symmetry plane (see
    the module docstring): ``sym`` (n_sym,) those nodes, ``sym_proj`` (n_sym, d, d) the
    projectors applied to the averaged tangent in 2D, e_k e_kᵀ, and to the averaged
    normal in 3D, I − Σ_k e_k e_kᵀ; ``sym_cut`` (n_sym, m) the tangential directions
    left out (a_α = 0).

    Occurrences p = (facet f_p, mixed node of I): ``pair_f`` (P,), ``pair_node`` (P,),
    sorted by node, with ``pair_off`` (n+1,) the offsets of each node. ``dofs`` (nsf, ns,
    d): the global dofs of the facet nodes (−1: constrained); the layout the nodal
    tangents read (shared with :class:`MasterFrames`) is ``off`` (= pair_off) and
    ``dofs`` (P, ns, d) = dofs[pair_f], the dofs the derivatives of :meth:`compute` run
    over.
    """

    def __init__(self, ftype, X, sign, node_of, mixed, n_nodes, dofs, held_at_zero=None):
        d = X.shape[2] if X.ndim == 3 else 2
        self.d, self.m, self.n = d, d - 1, n_nodes
        k = tdim(ftype)
        ns = REFERENCE_NODES[ftype].shape[0]
        f_idx, i_idx = np.nonzero(node_of >= 0)
        node = node_of[f_idx, i_idx]
        order = np.argsort(node, kind="stable")
        self.pair_f, self.pair_node = f_idx[order], node[order]
        self.pair_off = np.searchsorted(self.pair_node, np.arange(n_nodes + 1))
        self.facet_dofs = dofs
        self.off, self.dofs = self.pair_off, dofs[self.pair_f]  # the occurrence layout
        loc = np.asarray(mixed)[i_idx[order]]
        # dN_b at the reference position of every facet node l: table (ns, ns, k)
        table = np.empty((ns, ns, k))
        N, dN, ddN = np.empty(9), np.empty((9, k)), np.empty((9, k, k))
        for l_ in range(ns):
            shape(ftype, np.ascontiguousarray(REFERENCE_NODES[ftype][l_]), N, dN, ddN)
            table[l_] = dN[:ns]
        self.dN = table[loc]  # (P, ns, k)
        self.sign = np.asarray(sign, float)[self.pair_f]
        self.coef = None
        if d == 3 and self.pair_f.size:
            A0 = np.einsum("pbk,pbc->pkc", self.dN, X[self.pair_f])
            n0, _ = _unit(self._summed_normals(A0))
            E = np.zeros((n_nodes, 3))
            near_x = np.abs(n0[:, 0]) > np.cos(np.radians(10.0))
            E[~near_x, 0] = 1.0
            E[near_x, 1] = 1.0
            G = np.einsum("pkc,plc->pkl", A0, A0)
            contra = np.linalg.solve(G, A0)  # (P, k, d): A0^α
            proj = np.einsum("pkc,pc->pk", contra, E[self.pair_node])
            self.coef = np.einsum("pbk,pk->pb", self.dN, proj)  # e = Σ_p Σ_b coef x_b
        self.sym = np.empty(0, np.int64)
        self.sym_proj = np.zeros((0, d, d))
        self.sym_cut = np.zeros((0, d - 1), bool)
        if held_at_zero is not None and self.pair_f.size:
            self._symmetry_planes(X, np.asarray(held_at_zero, bool)[self.pair_f, loc])

    def _symmetry_planes(self, X: np.ndarray, held: np.ndarray) -> None:
        """``sym`` and ``sym_proj`` from the held components of each occurrence, held
        (P, d), and the reference coordinates X (nsf, ns, d); see the class docstring."""
        d, n = self.d, self.n
        comps = np.zeros((n, d), bool)
        np.logical_or.at(comps, self.pair_node, held)
        n0, _ = _unit(self._summed_normals(np.einsum("pbk,pbc->pkc", self.dN, X[self.pair_f])))
        comps &= np.abs(n0) <= SYMMETRY_NORMAL_TOL
        count = comps.sum(axis=1)
        self.sym = np.flatnonzero((count > 0) & (count < d))
        comps = comps[self.sym]
        E = comps[:, :, None] * np.eye(d)  # (n_sym, d, d): Σ_k e_k e_kᵀ
        self.sym_proj = E if d == 2 else np.eye(d) - E
        # a_1 = e_k across the (first) plane, left out; a_2 too on two planes (3D)
        self.sym_cut = np.zeros((self.sym.size, self.m), bool)
        self.sym_cut[:, 0] = True
        if d == 3:
            self.sym_cut[:, 1] = count[self.sym] == 2
            self.sym_e = np.eye(3)[np.argmax(comps, axis=1)]  # (n_sym, 3): that e_k
            at_sym = np.isin(self.pair_node, self.sym)
            self.coef = np.where(at_sym[:, None], 0.0, self.coef)  # e = e_k there, fixed
        on = np.zeros((n, self.m), bool)
        on[self.sym] = self.sym_cut
        self._cut_p = on[self.pair_node]  # (P, m): per occurrence

    def _summed_normals(self, A: np.ndarray) -> np.ndarray:
        """Σ_f s_f ñ_f at each node (n, d), unnormalised outward normals of the slave facets
        around it, from their covariant tangents at the node A (P, k, d) (2D: the summed
        oriented tangent turned by −90°; 3D: the summed cross products)."""
        out = np.zeros((self.n, self.d))
        if self.d == 2:
            np.add.at(out, self.pair_node, self.sign[:, None] * A[:, 0])
            return np.stack([out[:, 1], -out[:, 0]], axis=1)
        np.add.at(out, self.pair_node, self.sign[:, None] * np.cross(A[:, 0], A[:, 1]))
        return out

    def compute(self, xs: np.ndarray, derivatives: bool = True):
        """Frames at the current slave coordinates xs (nsf, ns, d).

        Returns a (n, m, d) tangent vectors, nrm (n, d) outward unit normals and the
        derivatives dA (P, ns, m, d, d): ∂a_α,c / ∂x_{f_p, b, c'} (zero rows for nodes
        without facets), or None without ``derivatives`` (most of the cost; only
        Jacobians need them).
        """
        d, m, n = self.d, self.m, self.n
        P, ns = self.dN.shape[0], self.dN.shape[1]
        a = np.zeros((n, m, d))
        nrm = np.zeros((n, d))
        dA = np.zeros((P, ns, m, d, d)) if derivatives else None
        if P == 0:
            return a, nrm, dA
        x = xs[self.pair_f]  # (P, ns, d)
        A = self.dN.transpose(0, 2, 1) @ x  # covariant tangents at the node, (P, k, d)
        eye = np.eye(d)
        if d == 2:
            tt = np.zeros((n, 2))
            np.add.at(tt, self.pair_node, self.sign[:, None] * A[:, 0])
            if self.sym.size:  # symmetry planes: the tangent along e_k
                tt[self.sym] = np.einsum("nij,nj->ni", self.sym_proj, tt[self.sym])
            a1, lt = _unit(tt)
            a[:, 0] = a1
            nrm[:, 0], nrm[:, 1] = a1[:, 1], -a1[:, 0]
            a[self.sym, 0] = 0.0  # the tangent across a symmetry plane: left out
            if not derivatives:
                return a, nrm, dA
            Q = (eye - np.einsum("ni,nj->nij", a1, a1)) / np.maximum(lt, 1e-300)[:, None, None]
            Q[self.sym] = 0.0
            dA[:, :, 0] = (self.sign[:, None] * self.dN[:, :, 0])[:, :, None, None] * Q[
                self.pair_node
            ][:, None]
            return a, nrm, dA
        nt = self._summed_normals(A)
        if self.sym.size:  # symmetry planes: the normal within them
            nt[self.sym] = np.einsum("nij,nj->ni", self.sym_proj, nt[self.sym])
        nv, ln = _unit(nt)
        e = np.zeros((n, 3))
        np.add.at(e, self.pair_node, (self.coef[:, None] @ x)[:, 0])
        if self.sym.size:  # across the plane (its coef rows are zero: Je = 0 there)
            e[self.sym] = self.sym_e
        en = np.einsum("nc,nc->n", e, nv)
        v = e - en[:, None] * nv
        a1, lv = _unit(v)
        a2 = np.cross(nv, a1)
        a[:, 0], a[:, 1], nrm[:] = a1, a2, nv
        if self.sym.size:  # the directions across symmetry planes: left out
            a[self.sym] *= ~self.sym_cut[:, :, None]
        if not derivatives:
            return a, nrm, dA
        # derivatives per occurrence p and facet node b
        q = self.pair_node
        Pn = (eye - np.einsum("ni,nj->nij", nv, nv)) / np.maximum(ln, 1e-300)[:, None, None]
        if self.sym.size:
            Pn[self.sym] = Pn[self.sym] @ self.sym_proj
        Qa = (eye - np.einsum("ni,nj->nij", a1, a1)) / np.maximum(lv, 1e-300)[:, None, None]
        cA0, cA1 = _cross_matrix(A[:, 0]), _cross_matrix(A[:, 1])  # (P, 3, 3)
        dnt = self.sign[:, None, None, None] * (
            -self.dN[:, :, 0, None, None] * cA1[:, None]
            + self.dN[:, :, 1, None, None] * cA0[:, None]
        )  # (P, ns, 3, 3)
        Jn = Pn[q][:, None] @ dnt
        Je = self.coef[:, :, None, None] * eye
        Mv = np.einsum("pi,pj->pij", nv[q], e[q]) + en[q][:, None, None] * eye
        # batched 3 × 3 products (P, 1, 3, 3) @ (P, ns, 3, 3): matmul, 6× faster than einsum
        Jv = (eye - np.einsum("ni,nj->nij", nv, nv))[q][:, None] @ Je - Mv[:, None] @ Jn
        Ja1 = Qa[q][:, None] @ Jv
        Ja2 = _cross_matrix(nv)[q][:, None] @ Ja1 - _cross_matrix(a1)[q][:, None] @ Jn
        dA[:, :, 0], dA[:, :, 1] = Ja1, Ja2
        if self.sym.size:
            dA *= ~self._cut_p[:, None, :, None, None]
        return a, nrm, dA


class MasterFrames:
    """Frames of the MASTER's convected tangent plane (``tangential_frame = "master"``).

    METHOD.md §1 in its literal form: the tangential kinematics of slave node I live in
    the convected curvilinear coordinates ζ^α of the master. At t_n the node faced the
    master material point (m_n^I, ζ_n^I) (closest-point projection in the t_n
    configuration, fixed during the step); its covariant basis convects with the master,

        g_α = ∂x²/∂ζ^α = Σ_b ∂N_b/∂ζ^α(ζ_n^I) x_b     (the current nodes x_b of facet m_n^I),

    with the metric a_αβ = g_α·g_β, its inverse a^αβ and the contravariant basis
    g^α = a^αβ g_β (:meth:`covariant`). The nodal slip components are contravariant,
    g_T^α = g^α·(σ_β ê_β)/A_T^I with σ_β = ê_β·S^I − ê_{β,n}·S_n^I (the slip since the
    start of the step, module docstring): where the node's points faced one affine master
    facet at t_n (d_n ⊥ ê_n, so ê_n·S_n = 0) exactly ζ̄^α − ζ_n^α of the paper's eq. 2.2,
    and across master facets the physical-slip rule (S is the motion relative to the t_n
    material point). The paper's return mapping in covariant components with
    the metric (eq. 2.8, :func:`covariant_return_mapping`) is carried out in an
    orthonormal basis ê_α of the same plane, convected with the master as g_α is:

        ê_1 = c_α g_α/|c_β g_β|;   3D: ν = σ (g_1 × g_2)/|g_1 × g_2|, ê_2 = ν × ê_1,

    with c (m,) and σ = ±1 fixed at t_n: c_α g_α is then the slave frame's a_1 projected on
    the master plane (so ê_1 is the same direction whichever facet a node on a facet edge
    projected onto, and its components stay comparable with the slave frame's), and ν
    lies on the side of the slave's outward normal. ê_α components are the covariant
    ones through L_αi = g_α·ê_i: g_α = L_αi ê_i, a_αβ = (L Lᵀ)_αβ, τ_α = L_αi τ̂_i,
    g_T^α = (L⁻ᵀ)_αi γ̂_i; the Coulomb norm is invariant,
    τ_α a^αβ τ_β = |τ̂|², so the stick/slip decision, the slip direction and the traction
    vector t = τ_α g^α = τ̂_i ê_i are the paper's (``tests/test_friction.py``,
    ``test_covariant_return_mapping_is_the_orthonormal_one``). The frame depends on the
    current coordinates of the master facet m_n^I only (ζ_n^I is fixed), linearly through
    g_α: its derivatives run over that facet's dofs.

    Nodes without a t_n master point (``mn < 0``) and nodes on symmetry planes keep the
    slave frame of ``slave`` (:class:`NodalFrames`), the mirrored model's.

    Layout shared with the slave frames (consumed by the nodal tangents): occurrences p
    of the frame's dependencies, ``off`` (n + 1,) per node, ``dofs`` (P, nb, d) the
    global dofs of the facet nodes each occurrence differentiates (−1: none or
    constrained), the derivatives dA (P, nb, m, d, d) from :meth:`compute`.
    """

    def __init__(self, slave: NodalFrames, ftype_m: int, nm: int):
        self.slave, self.ftype_m = slave, ftype_m
        self.d, self.m, self.n = slave.d, slave.m, slave.n
        k, d = tdim(ftype_m), self.d
        self.set_points(
            np.full(self.n, -1), np.zeros((self.n, k)), None, None, np.zeros((0, nm, d), np.int64)
        )

    def set_points(self, mn, zn, xs_n, xm_n, mdofs) -> None:
        """The t_n master points (local): mn (n,) master facet of each node (−1: none),
        zn (n, km) its ζ_n; xs_n (nsf, ns, d), xm_n (nmf, nm, d) the t_n coordinates (for
        the signs σ); mdofs (nmf, nm, d) the master facets' global dofs."""
        sl, d = self.slave, self.d
        sdofs = sl.facet_dofs
        use = np.asarray(mn) >= 0
        use[sl.sym] = False
        self.use, self.mn = use, np.asarray(mn)[use]
        k = tdim(self.ftype_m)
        nm = mdofs.shape[1]
        N, dN, ddN = np.empty(9), np.empty((9, k)), np.empty((9, k, k))
        self.dN = np.empty((self.mn.size, nm, k))
        for i, z in enumerate(np.asarray(zn)[use]):
            shape(self.ftype_m, np.ascontiguousarray(z, dtype=float), N, dN, ddN)
            self.dN[i] = dN[:nm]
        # ê_1 ∥ c_α g_α: c the contravariant components, at t_n, of the slave frame's a_1
        # projected on the master plane (the same direction whichever facet a node on a
        # facet edge projected onto); σ orients the 3D normal along the slave's
        self.sigma, self.c = np.ones(self.mn.size), np.zeros((self.mn.size, k))
        if self.mn.size:
            a_s, n_s, _ = sl.compute(xs_n, derivatives=False)
            g = self._basis(xm_n)
            v = a_s[use, 0]
            if d == 3:
                nt = np.cross(g[:, 0], g[:, 1])
                self.sigma = np.where(np.einsum("uc,uc->u", nt, n_s[use]) < 0.0, -1.0, 1.0)
            G = g @ g.transpose(0, 2, 1)
            self.c = np.linalg.solve(G, (g @ v[:, :, None]))[:, :, 0]
            flat = np.linalg.norm(np.einsum("ua,uac->uc", self.c, g), axis=1) < 1e-6
            self.c[flat] = np.eye(k)[0] / np.linalg.norm(g[flat, 0], axis=1)[:, None]
        # occurrences: one per master node (its facet m_n), the slave facets elsewhere
        count = np.where(use, 1, np.diff(sl.pair_off))
        self.off = np.concatenate([[0], np.cumsum(count)]).astype(np.int64)
        ns = sdofs.shape[1]
        self._nb = max(ns, nm)
        keep = ~use[sl.pair_node]
        self._sel_s = np.flatnonzero(keep)
        node_s = sl.pair_node[keep]
        self._pos_s = self.off[node_s] + (self._sel_s - sl.pair_off[node_s])
        self._pos_m = self.off[:-1][use]
        self.dofs = np.full((self.off[-1], self._nb, d), -1, np.int64)
        self.dofs[self._pos_s, :ns] = sdofs[sl.pair_f[self._sel_s]]
        self.dofs[self._pos_m, :nm] = mdofs[self.mn]

    def _basis(self, xm: np.ndarray) -> np.ndarray:
        """Covariant basis g (U, m, d) of the master points at the coordinates xm."""
        return self.dN.transpose(0, 2, 1) @ xm[self.mn]

    def covariant(self, xm: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The master's convected covariant basis g_α (U, m, d), metric a_αβ (U, m, m)
        and contravariant basis g^α = a^αβ g_β (U, m, d) at the master points of the
        nodes ``use`` (U of them), with the current master coordinates xm (nmf, nm, d)."""
        g = self._basis(xm)
        G = g @ g.transpose(0, 2, 1)
        return g, G, np.linalg.solve(G, g)

    def compute(self, xs: np.ndarray, xm: np.ndarray, derivatives: bool = True):
        """Frames at the current slave xs (nsf, ns, d) and master xm (nmf, nm, d)
        coordinates: a (n, m, d) orthonormal tangents (ê_α at the master nodes, the slave
        frame elsewhere), nrm (n, d) the slave frame's outward normals (outputs), and
        dA (P, nb, m, d, d) = ∂a_α,c/∂x_{b,c'} in the occurrence layout (class
        docstring), or None without ``derivatives``."""
        a, nrm, dA_s = self.slave.compute(xs, derivatives)
        d, U = self.d, self.mn.size
        dA = None
        if derivatives:
            dA = np.zeros((self.off[-1], self._nb, self.m, d, d))
            ns = dA_s.shape[1]
            dA[self._pos_s, :ns] = dA_s[self._sel_s]
        if U == 0:
            return a, nrm, dA
        g = self._basis(xm)
        eye = np.eye(d)
        sig = self.sigma
        e1, l1 = _unit(np.einsum("ua,uac->uc", self.c, g))
        nm = self.dN.shape[1]
        if derivatives:
            # ∂(c_α g_α)/∂x_b = w_b I, w_b = c_α ∂N_b/∂ζ^α: ∂ê_1 = (I − ê_1 ê_1) w_b/|c_α g_α|
            w = np.einsum("uba,ua->ub", self.dN, self.c)
            Q1 = (eye - np.einsum("ui,uj->uij", e1, e1)) / l1[:, None, None]
            Je1 = w[:, :, None, None] * Q1[:, None]  # (U, nm, d, d)
        if d == 2:
            a[self.use, 0] = e1
            if derivatives:
                dA[self._pos_m, :nm, 0] = Je1
            return a, nrm, dA
        nt = np.cross(g[:, 0], g[:, 1])
        nu, ln = _unit(sig[:, None] * nt)
        e2 = np.cross(nu, e1)
        a[self.use, 0], a[self.use, 1] = e1, e2
        if derivatives:
            Pn = (eye - np.einsum("ui,uj->uij", nu, nu)) * (sig / ln)[:, None, None]
            dN = self.dN[:, :, :, None, None]
            dnt = (
                -dN[:, :, 0] * _cross_matrix(g[:, 1])[:, None]
                + dN[:, :, 1] * _cross_matrix(g[:, 0])[:, None]
            )
            Jn = Pn[:, None] @ dnt
            Je2 = _cross_matrix(nu)[:, None] @ Je1 - _cross_matrix(e1)[:, None] @ Jn
            dA[self._pos_m, :nm, 0], dA[self._pos_m, :nm, 1] = Je1, Je2
        return a, nrm, dA


def covariant_return_mapping(lam, gamma, G, p, mu, eps_t):
    """The paper's penalty-regularised Coulomb update (METHOD.md §1, eq. 2.8; §4) in
    covariant components with the metric, the reference of the orthonormal
    :func:`return_mapping` that the code runs (:class:`MasterFrames`).

    lam (n, m) covariant multipliers τ_α^n, gamma (n, m) contravariant slip g_T^α,
    G (n, m, m) the metric a_αβ, p (n,) normal pressure, mu, eps_t (n,). Trial
    τ^tr_α = τ_α^n + ε_T a_αβ g_T^β, ‖τ‖² = τ_α a^αβ τ_β, Φ = ‖τ^tr‖ − μ p; stick τ = τ^tr,
    slip τ_α = μ p τ^tr_α/‖τ^tr‖. Returns τ (n, m) covariant and the states (n,)
    (STICK/SLIP; no open nodes here)."""
    trial = lam + eps_t[:, None] * np.einsum("nab,nb->na", G, gamma)
    norm = np.sqrt(np.einsum("na,na->n", trial, np.linalg.solve(G, trial[..., None])[..., 0]))
    slip = norm > mu * p
    tau = np.where(
        slip[:, None], mu * p[:, None] * trial / np.maximum(norm, 1e-300)[:, None], trial
    )
    return tau, np.where(slip, SLIP, STICK)


def return_mapping(lam, gamma, p, active, mu, eps_t, frozen=None, tol=None):
    """Nodal Coulomb return mapping (METHOD.md §4) in an orthonormal frame.

    lam, gamma (n, m) tangential multiplier and mixed slip; p (n,) normal pressure;
    active (n,) the normal active set (a node touching with p = 0 is active: it sticks
    when τ^tr = 0 and otherwise slips with τ = 0 and ∂τ/∂p = μ s). A node with p < 0 (the
    constrained normal recovery with its free set frozen by the chattering control:
    p = M_𝒫𝒫⁻¹F alternates in sign) has no Coulomb cone and counts as open whatever
    ``active`` and ``frozen`` say: τ = 0, D = 0, Pd = 0 (the Coulomb radius is
    μ max(p, 0); before session 46 such a node slipped with τ = μ p s, a traction along
    its slip);
    mu friction coefficient; eps_t (n,) tangential penalty (stress per length);
    frozen: None or (states (n,), directions (n, m) or None) to impose where states ≥ 0
    (the chattering control of :class:`~dolfinx_mortar.contact.MortarContact`): a frozen
    slip node keeps its slip direction s, so τ = μ p_N s is smooth in u; with directions
    None only the states are imposed and s follows the trial traction (the exact
    multiplier update's differences), and so it does at a node whose row of directions
    is NaN (a pair frozen with no node in stick: tangential.FREE_SLIP_DIRECTIONS); tol (n,) a node
    slips only when Φ > tol (round-off in a touching node's slip must not select a
    slip direction).

    Returns tau (n, m), state (n,) (OPEN/STICK/SLIP), D (n, m, m) = ∂τ/∂γ and
    Pd (n, m) = ∂τ/∂p_N; state is the one used (frozen where imposed).
    """
    n, m = gamma.shape
    # a negative nodal pressure has no Coulomb cone: the node is open for the law (τ = 0,
    # no tangent, no imposed state), so that the radius is μ max(p, 0) and ∂τ/∂p = μ s H(p)
    active = active & (p >= 0.0)
    trial = lam + eps_t[:, None] * gamma
    norm = np.linalg.norm(trial, axis=1)
    slip = active & (norm - mu * p > (0.0 if tol is None else tol))
    s = trial / np.maximum(norm, 1e-300)[:, None]
    fixed = np.zeros(n, bool)
    if frozen is not None:
        states, directions = frozen
        imposed = active & (states >= 0)
        slip = np.where(imposed, states == SLIP, slip)
        if directions is not None:
            # a row of NaN: the state is imposed, the direction follows the trial traction
            fixed = imposed & slip & np.all(np.isfinite(directions), axis=1)
            s = np.where(fixed[:, None], directions, s)
    stick = active & ~slip
    tau = np.where(stick[:, None], trial, 0.0) + np.where(slip[:, None], mu * p[:, None] * s, 0.0)
    eye = np.eye(m)
    D = np.where(stick[:, None, None], eps_t[:, None, None] * eye, 0.0)
    Dslip = (mu * p * eps_t / np.maximum(norm, 1e-300))[:, None, None] * (
        eye - np.einsum("ni,nj->nij", s, s)
    )
    D = np.where((slip & ~fixed)[:, None, None], Dslip, D)
    Pd = np.where(slip[:, None], mu * s, 0.0)
    state = np.where(slip, SLIP, np.where(stick, STICK, OPEN))
    return tau, state, D, Pd


def node_rows(s_dofs, s_w, f_dofs, f_dA, extra=None):
    """The derivative rows of one node's weighted slip and frame over the union U of its
    dofs (and of ``extra`` dofs, if given). Dofs < 0 are dropped.

    s_dofs (E, d), s_w (E,): the S-weights (S = Σ_k w_k x_k); f_dofs (F, d), f_dA
    (F, m, d, d): the frame derivatives per facet node (dofs of its d components).
    Returns (U (nu,), pos: dofs → columns (nu for dropped ones), Srow (d, nu + 1) =
    ∂S/∂u, Frow (m, d, nu + 1) = ∂a_α/∂u); the last column collects the dropped dofs.
    """
    m, d = f_dA.shape[1], s_dofs.shape[1]
    parts = [s_dofs.ravel(), f_dofs.ravel()] + ([] if extra is None else [extra])
    U = np.unique(np.concatenate(parts))
    U = U[U >= 0]
    nu = U.size
    Srow = np.zeros((d, nu + 1))
    Frow = np.zeros((m, d, nu + 1))

    def pos(idx):
        j = np.searchsorted(U, idx)
        return np.where(idx >= 0, np.minimum(j, nu), nu)

    for c in range(d):
        np.add.at(Srow[c], pos(s_dofs[:, c]), s_w)
        for c2 in range(d):
            np.add.at(Frow[:, c].T, pos(f_dofs[:, c2]), f_dA[:, :, c, c2])
    return U, pos, Srow, Frow


def weight_rows(pos, s_dofs: np.ndarray, s_g: np.ndarray, nu: int) -> np.ndarray:
    """The rows (d, nu) of one node's weights ``s_g`` (E,) on its dofs s_dofs (E, d),
    ``pos`` of :func:`node_rows` mapping dofs to columns (dropped dofs left out): the test
    rows G^I of R_T = Σ_I (G^I)ᵀ t^I (the force weights, session 55)."""
    d = s_dofs.shape[1]
    G = np.zeros((d, nu + 1))
    for c in range(d):
        np.add.at(G[c], pos(s_dofs[:, c]), s_g)
    return G[:, :nu]


def node_tangent(
    a, S, AT, tau, D, Pd, kN, s_dofs, s_w, f_dofs, f_dA, b_idx, b_val, moving=None, s_g=None
):
    """K_I = (G^I)ᵀ ∂t/∂u of one node over the union of its dofs (module docstring), G^I
    the force weights ``s_g`` (E,) on s_dofs (the test rows of R_T; None: G = ∂S/∂u).

    a (m, d) frame; S (d,) weighted slip; AT area; tau (m,), D (m, m), Pd (m,) from
    :func:`return_mapping`; kN = ε_N/A (∂p_N = −kN B); s_dofs, s_w, f_dofs, f_dA as
    :func:`node_rows`; b_idx, b_val the row B^I. Dofs < 0 are dropped. ``moving`` = (dofs
    (E,), dsig (m, E), dA_T (E,), sigma (m,)): the parts of ∂σ and ∂A_T from moving
    integration points (segment integration), dsig = a·∂S − a_n·∂S_n (both S-weights
    move), and the node's σ = a·S − a_n·S_n, so that
    ∂γ = (a·∂S + S·∂a + dsig)/A_T − γ ∂A_T/A_T with γ = σ/A_T; the left factor (the
    residual weights) stays (∂S/∂u at fixed points). Without ``moving`` a_n·S_n is
    constant in u and σ is not needed.
    Returns (dofs (U,), K (U, U)).
    """
    m, d = a.shape
    extra = b_idx if moving is None else np.concatenate([b_idx, moving[0]])
    U, pos, Srow, Frow = node_rows(s_dofs, s_w, f_dofs, f_dA, extra)
    nu = U.size
    Brow = np.zeros(nu + 1)
    np.add.at(Brow, pos(b_idx), b_val)
    dgam = a @ Srow.reshape(d, -1) + np.einsum("c,acu->au", S, Frow)
    if moving is not None:
        j = pos(moving[0])
        dgam += np.stack([np.bincount(j, moving[1][al], nu + 1) for al in range(m)])
        at_row = np.bincount(j, moving[2], nu + 1)
    dgam /= AT
    if moving is not None:
        dgam -= np.outer(moving[3] / AT, at_row / AT)
    dtau = D @ dgam - np.outer(Pd, kN * Brow)
    dt = a.T @ dtau + np.einsum("a,acu->cu", tau, Frow)
    G = Srow[:, :nu] if s_g is None else weight_rows(pos, s_dofs, s_g, nu)
    K = G.T @ dt[:, :nu]
    return U, K
