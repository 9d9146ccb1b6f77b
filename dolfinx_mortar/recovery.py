r"""Recovery of the nodal mixed gap and pressure on the slave surface (METHOD.md §2–§3).

The mixed gap γ and pressure p are interpolated with the slave-surface functions Φ_I.
With the mortar mass matrix and the nodal integrals of :mod:`dolfinx_mortar.kernels.mortar`

    M_IJ = ∫ Φ_I Φ_J dA₀,   A^I = Σ_J M_IJ = ∫ Φ_I dA₀,   G^I = ∫ Φ_I g_N dA₀,

the variations of C_N = ∫ [p (γ − g_N) + (ε/2)⟨−γ⟩²] dA with respect to p and γ read

    M γ = G,            M p = F,   F^I = A^I p̂^I,   p̂^I = ⟨λ^I − ε^I γ^I⟩,

where the penalty integral is evaluated with nodal quadrature (∫ Φ_I ε⟨−γ⟩ dA ≈ A^I ε^I
⟨−γ^I⟩; with Uzawa multipliers λ^I the augmented ⟨λ^I − ε^I γ^I⟩). The three recoveries
solve these equations as follows (all reproduce a constant pressure, M·1 = A):

* ``lumped``: M → diag(A): γ^I = G^I/A^I, p^I = p̂^I (node-local; implemented directly in
  :class:`dolfinx_mortar.contact.MortarContact`, :func:`recover` offers it for reference).
* ``unconstrained``: γ = M⁻¹G, p = M⁻¹F. Nodal pressures can be negative.
* ``constrained``: γ = M⁻¹G, p = argmin_{p ≥ 0} ½ pᵀMp − pᵀF, solved by a primal–dual
  active-set method (:func:`nonnegative_qp`).

Uzawa augments the nodal penalty pressures, λ^I ← p̂^I: at its fixed point γ^I = 0 on
every node that carries pressure.

Tangent. The contact residual is R_c = −Σ_J p^J B^J with B^J = ∂G^J/∂u. With
W = M⁻¹, H^I = [p̂^I > 0] and d_I = A^I ε^I H^I, ∂p̂^I = −H^I ε^I Σ_K W_IK B^K, so

    K_c = Σ_I d_I a^I ⊗ c^I − Σ_J p^J ∂²G^J/∂u²,
    c^I = Σ_K R_IK B^K,   a^I = Σ_J L_IJ B^J,

with R = W (rows of the tangent nodes) and
* unconstrained: L = W (∂p = W diag(A) ∂p̂): symmetric;
* constrained: L_IJ = (M_𝒫𝒫⁻¹)_JI on the set 𝒫 of nodes with p > 0, and only I ∈ 𝒫
  carries a term (the active set of the QP is held fixed: exact wherever it is locally
  constant); not symmetric;
* lumped: L = R = diag(1/A), so d_I a^I ⊗ c^I = (ε^I H^I / A^I) B^I ⊗ B^I.

W is dense but its rows decay geometrically away from the diagonal (by about 0.27 per
node for P1 intervals): entries below :data:`INVERSE_TRUNCATION` times the largest of
their row are dropped, which changes the tangent by less than that fraction. The cost is
that the tangent couples every pair of dofs seen by nodes a few rings apart in the
contact zone: more fill than the lumped recovery's B^I ⊗ B^I.

All functions here are serial and deterministic; the contact term calls them with the
slave-surface system of every rank gathered (one value per slave node, not the facets).
"""

from __future__ import annotations

import dataclasses
import functools
import logging
from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .errors import ConvergenceError

log = logging.getLogger(__name__)

RECOVERIES = ("unconstrained", "lumped", "constrained")
#: Entries of a row of M⁻¹ (or M_𝒫𝒫⁻¹) smaller than this fraction of the row's largest
#: are left out of the tangent.
INVERSE_TRUNCATION = 1e-13
#: Iteration bound of the primal–dual active-set method of :func:`nonnegative_qp`.
QP_MAX_ITERATIONS = 200


class _LazyTangent:
    """The tangent operator of a recovery, built by ``build_tangent`` on first use only
    (the residual evaluations of the line search do not need it)."""

    @functools.cached_property
    def _tangent(self) -> tuple:
        return self.build_tangent()


@dataclasses.dataclass
class Recovered(_LazyTangent):
    """The recovered nodal fields and the tangent operator (all arrays over the n nodes).

    gamma, p_hat, p: (n,) mixed gap (length), nodal penalty pressure ⟨λ − εγ⟩ and the
    recovered pressure (stress). free: (n,) bool, the nodes the pressure is solved for
    (the QP's free set 𝒫 when constrained; the nodes with paired area otherwise).
    qp_iterations: active-set iterations (0 unless constrained).

    The tangent operator is built on first use only (the residual evaluations of the
    line search do not need it): tangent_nodes (m,) node indices I with d_I > 0; d (m,)
    the coefficients d_I = A^I ε^I (force per length); left, right (m, n) CSR rows L_I,
    R_I (module docstring).
    """

    gamma: np.ndarray
    p_hat: np.ndarray
    p: np.ndarray
    free: np.ndarray
    build_tangent: Callable[[], tuple] = dataclasses.field(repr=False)
    qp_iterations: int = 0
    #: nodes (k,) → CSR (k, n) rows L_I of ∂p = Σ_I L_Iᵀ ∂F_I (∂F the variation of F with
    #: M held fixed; W = M⁻¹ when unconstrained, M_𝒫𝒫⁻¹ on the free set when constrained,
    #: zero rows elsewhere); None when lumped
    left_rows: Callable[[np.ndarray], sp.csr_matrix] | None = dataclasses.field(
        default=None, repr=False
    )

    @property
    def tangent_nodes(self) -> np.ndarray:
        return self._tangent[0]

    @property
    def d(self) -> np.ndarray:
        return self._tangent[1]

    @property
    def left(self) -> sp.csr_matrix:
        return self._tangent[2]

    @property
    def right(self) -> sp.csr_matrix:
        return self._tangent[3]


def _truncated_columns(X: np.ndarray, rows: np.ndarray, n: int) -> sp.csr_matrix:
    """CSR (X.shape[1], n) of the columns of X (entries at ``rows``), small entries dropped."""
    if X.size == 0:
        return sp.csr_matrix((X.shape[1], n))
    scale = np.abs(X).max(axis=0)
    keep = np.abs(X) > INVERSE_TRUNCATION * scale[None, :]
    r, c = np.nonzero(keep)
    return sp.csr_matrix((X[r, c], (c, rows[r])), shape=(X.shape[1], n))


def _factor(M: sp.spmatrix):
    """Sparse LU of M; a singular M raises ConvergenceError (the step is cut back)."""
    try:
        return spla.splu(sp.csc_matrix(M))
    except RuntimeError as exc:
        raise ConvergenceError(f"mixed recovery: singular mortar mass matrix ({exc})") from None


def _columns_of_inverse(lu, positions: np.ndarray, size: int) -> np.ndarray:
    """Dense (size, len(positions)) columns of the inverse of the factored matrix."""
    E = np.zeros((size, positions.size))
    E[positions, np.arange(positions.size)] = 1.0
    return lu.solve(E) if positions.size else E


def nonnegative_qp(M: sp.spmatrix, F: np.ndarray, scale: float | None = None):
    """min_{p ≥ 0} ½ pᵀMp − pᵀF for a symmetric positive definite sparse M (n, n).

    Primal–dual active-set method (Hintermüller, Ito & Kunisch 2002): with the
    multiplier μ = Mp − F, the bound set is 𝒵 = {i : μ_i − c p_i > 0} (c = ``scale``,
    default the mean diagonal of M); p_𝒵 = 0 and M_𝒫𝒫 p_𝒫 = F_𝒫 on the rest, until 𝒵
    repeats. Returns (p (n,), free set 𝒫 as a bool mask, the LU factors of M_𝒫𝒫 or None,
    iterations). Raises ConvergenceError when the sets cycle.
    """
    M = sp.csc_matrix(M)
    n = F.size
    if n == 0 or not np.any(F > 0.0):
        return np.zeros(n), np.zeros(n, bool), None, 0
    c = float(M.diagonal().mean()) if scale is None else scale
    bound = ~(F > 0.0)
    seen = set()
    for it in range(1, QP_MAX_ITERATIONS + 1):
        seen.add(np.packbits(bound).tobytes())
        idx = np.flatnonzero(~bound)
        p = np.zeros(n)
        lu = None
        if idx.size:
            lu = _factor(M[idx][:, idx])
            p[idx] = lu.solve(F[idx])
        mu = M @ p - F
        mu[idx] = 0.0
        tol = 1e-13 * c * np.abs(p).max(initial=0.0)
        new = mu - c * p > tol
        if np.array_equal(new, bound):
            return np.maximum(p, 0.0), ~bound, lu, it
        if np.packbits(new).tobytes() in seen:
            break
        bound = new
    raise ConvergenceError(
        f"constrained recovery: the active-set iteration cycled or exceeded {it} iterations"
    )


def near_contact(
    gamma: np.ndarray, has: np.ndarray, gmin: float, tol: float, h: np.ndarray
) -> np.ndarray:
    """(n,) bool: the nodes closest to contact while none carries pressure, γ^I ≤ gmin +
    tol and γ^I < h^I (closer than one facet size); gmin is the smallest γ of the whole
    surface (length). They get the penalty stiffness of an active node in the tangent
    only, so that the first Newton step brings a body held by contact alone into
    contact."""
    return has & (gamma <= gmin + tol) & (gamma < h)


def recover(
    method: str,
    M: sp.spmatrix,
    A: np.ndarray,
    G: np.ndarray,
    lam: np.ndarray,
    eps: np.ndarray,
    has: np.ndarray,
    free: np.ndarray | None = None,
    predictor: tuple[float, np.ndarray] | None = None,
) -> Recovered:
    """Recover γ, p̂, p and the tangent operator (module docstring) on n slave nodes.

    M (n, n) sparse mortar mass matrix; A, G, lam, eps (n,) nodal area (length^{d−1}),
    weighted gap, multiplier and penalty; has (n,) bool: nodes with paired area (the
    others get γ = p = 0 and no tangent). ``free`` (constrained only): nodes that stay in
    the free set: the QP's free set 𝒫 is replaced by 𝒫 ∪ ``free`` when it lacks some of
    them (p is then M_𝒫𝒫⁻¹F_𝒫 on the union, 0 elsewhere, not necessarily ≥ 0). A kept
    node whose nodal law is open (F_I = A^I p̂^I = 0) and whose p_I on the union is < 0
    leaves it again (repeated until none does): the returned ``free`` lacks it. The
    contact term's chattering control uses ``free`` so that the set can only grow within
    a Newton solve, except for such nodes.

    ``predictor`` (unconstrained only): (tol, h), h (n,) nodal sizes: while NO node
    carries pressure, the nodes of :func:`near_contact` get the tangent of an active node
    (the residual stays exact). A body held by
    contact alone has a singular Jacobian in that state; the predictor stiffness
    d_I W_I ⊗ W_I closes the recovered gap γ^I = (M⁻¹G)^I of those nodes in one Newton
    step. The lumped stiffness would close G^I/A^I instead, which leaves γ < 0 (and a
    large penalty force) at the nodes next to them, since the rows of M⁻¹ change sign.
    Serial, deterministic.
    """
    n = A.size
    idx = np.flatnonzero(has)
    gamma = np.zeros(n)
    p = np.zeros(n)
    if method == "lumped":
        gamma[idx] = G[idx] / A[idx]
    elif idx.size:
        Mh = sp.csc_matrix(sp.csr_matrix(M)[idx][:, idx])
        lu = _factor(Mh)
        gamma[idx] = lu.solve(G[idx])
    trial = lam - eps * gamma
    H = has & (trial >= 0.0)
    p_hat = np.where(H, trial, 0.0)
    F = A * p_hat
    tnodes = np.flatnonzero(H & (eps > 0.0))
    if method == "lumped":

        def lumped_tangent():
            rows = sp.csr_matrix(
                (1.0 / A[tnodes], (np.arange(tnodes.size), tnodes)), shape=(tnodes.size, n)
            )
            return tnodes, A[tnodes] * eps[tnodes], rows, rows

        return Recovered(gamma, p_hat, p_hat.copy(), has, lumped_tangent)
    if not idx.size:
        empty = sp.csr_matrix((0, n))
        return Recovered(gamma, p_hat, p, has, lambda: (tnodes[:0], np.zeros(0), empty, empty))
    pos = np.full(n, -1, np.int64)
    pos[idx] = np.arange(idx.size)

    def inverse_rows(nodes):
        return _truncated_columns(_columns_of_inverse(lu, pos[nodes], idx.size), idx, n)

    if method == "unconstrained":
        p[idx] = lu.solve(F[idx])
        if predictor is not None and not H.any():
            gmin = float(gamma[idx].min())
            tnodes = np.flatnonzero(near_contact(gamma, has, gmin, *predictor) & (eps > 0.0))

        def unconstrained_tangent():
            right = inverse_rows(tnodes)
            return tnodes, A[tnodes] * eps[tnodes], right, right

        return Recovered(gamma, p_hat, p, has, unconstrained_tangent, left_rows=inverse_rows)
    if method != "constrained":
        raise ValueError(f"unknown recovery {method!r}")
    ph, fmask, lu_free, its = nonnegative_qp(Mh, F[idx])
    if free is not None and not np.all(fmask[free[idx]]):
        # a node of the union whose nodal law is open (F_I = A p̂ = 0) and whose p is < 0
        # there leaves it (hysteresis: a kept node stays while p ≥ 0 or F_I > 0)
        fmask = fmask | free[idx]
        Fh = F[idx]
        while True:
            sub = np.flatnonzero(fmask)
            ph = np.zeros(idx.size)
            lu_free = _factor(sp.csr_matrix(Mh)[sub][:, sub])
            ph[sub] = lu_free.solve(Fh[sub])
            drop = fmask & (Fh <= 0.0) & (ph < 0.0)
            if not drop.any():
                break
            fmask &= ~drop
    p[idx] = ph
    fidx = idx[fmask]
    free_all = np.zeros(n, bool)
    free_all[fidx] = True

    def free_rows(nodes):
        """Rows of M_𝒫𝒫⁻¹ for the nodes in 𝒫 (zero rows for the others)."""
        out = sp.lil_matrix((nodes.size, n))
        inside = np.flatnonzero(free_all[nodes])
        if lu_free is None or not inside.size:
            return out.tocsr()
        fpos = np.full(n, -1, np.int64)
        fpos[fidx] = np.arange(fidx.size)
        cols = _columns_of_inverse(lu_free, fpos[nodes[inside]], fidx.size)
        rows = _truncated_columns(cols, fidx, n)
        sel = sp.csr_matrix(
            (np.ones(inside.size), (inside, np.arange(inside.size))),
            shape=(nodes.size, inside.size),
        )
        return (sel @ rows).tocsr()

    def constrained_tangent():
        nodes = tnodes[np.isin(tnodes, fidx)]
        return nodes, A[nodes] * eps[nodes], free_rows(nodes), inverse_rows(nodes)

    return Recovered(gamma, p_hat, p, free_all, constrained_tangent, its, left_rows=free_rows)


# ---------------------------------------------------------------------------- tangential
#: Iteration bound of the semismooth Newton method of :func:`cone_qp`.
CONE_QP_MAX_ITERATIONS = 50


@dataclasses.dataclass
class TangentialRecovered(_LazyTangent):
    """The recovered tangential fields of n slave nodes with m = d − 1 frame components.

    gamma (n, m): the mixed slip (length); tau_hat (n, m): the nodal Coulomb law applied to
    it (:func:`dolfinx_mortar.friction.return_mapping`, stress); tau (n, m): the recovered
    traction; state (n,), D (n, m, m) = ∂τ̂/∂γ, Pd (n, m) = ∂τ̂/∂p of the nodal law.

    The tangent operator, built on first use: ``Tsig`` (n·m, n·m) = ∂τ/∂σ and ``Tp``
    (n·m, n) = ∂τ/∂p, dense, with the components of node I at rows I·m + α (σ^I_α =
    a^I_α·S^I − a^I_{α,n}·S^I_n: the weighted slip since t_n in the node's frame; p: the
    normal pressures of the cone),
    and ``TF`` (n·m, n·m) = ∂τ/∂F at fixed M (W = M⁻¹ unconstrained, the linearised
    M-norm projection constrained; zero when lumped), with which a variation of M and A
    enters as ∂τ = Tsig(∂σ − ∂M γ) + TF(τ̂ ∂A − ∂M τ) (moving integration points).
    """

    gamma: np.ndarray
    tau_hat: np.ndarray
    tau: np.ndarray
    state: np.ndarray
    D: np.ndarray
    Pd: np.ndarray
    build_tangent: Callable[[], tuple] = dataclasses.field(repr=False)
    iterations: int = 0

    @property
    def Tsig(self) -> np.ndarray:
        return self._tangent[0]

    @property
    def Tp(self) -> np.ndarray:
        return self._tangent[1]

    @property
    def TF(self) -> np.ndarray:
        return self._tangent[2]


def _project_discs(z: np.ndarray, c: np.ndarray):
    """Projection of z (n, m) onto the discs |τ_i| ≤ c_i, with its derivatives.

    Returns P (n, m), dPz (n, m, m) = ∂P/∂z and dPc (n, m) = ∂P/∂c."""
    n, m = z.shape
    nz = np.linalg.norm(z, axis=1)
    out = nz > c
    s = z / np.maximum(nz, 1e-300)[:, None]
    P = np.where(out[:, None], c[:, None] * s, z)
    eye = np.eye(m)
    ratio = np.where(out, c / np.maximum(nz, 1e-300), 1.0)
    dPz = ratio[:, None, None] * np.where(
        out[:, None, None], eye - np.einsum("ni,nj->nij", s, s), eye
    )
    dPc = np.where(out[:, None], s, 0.0)
    return P, dPz, dPc


def _block(Mdense: np.ndarray, m: int) -> np.ndarray:
    """M ⊗ I_m with the components of node I at rows I·m + α, shape (n·m, n·m)."""
    return np.kron(Mdense, np.eye(m))


def _blockdiag(blocks: np.ndarray) -> np.ndarray:
    """(n, m, m) → block-diagonal (n·m, n·m)."""
    n, m, _ = blocks.shape
    out = np.zeros((n * m, n * m))
    for i in range(m):
        for j in range(m):
            out[np.arange(n) * m + i, np.arange(n) * m + j] = blocks[:, i, j]
    return out


def _column_blocks(vecs: np.ndarray) -> np.ndarray:
    """(n, m) → (n·m, n) with vecs[I] in column I (rows I·m + α)."""
    n, m = vecs.shape
    out = np.zeros((n * m, n))
    for a in range(m):
        out[np.arange(n) * m + a, np.arange(n)] = vecs[:, a]
    return out


def cone_qp(M: np.ndarray, F: np.ndarray, c: np.ndarray, tol=0.0):
    """min ½ Σ_α τ_αᵀ M τ_α − Σ_α τ_αᵀ F_α subject to |τ_i| ≤ c_i for every node i.

    M (n, n) symmetric positive definite (dense), F (n, m), c (n,) ≥ 0: the Coulomb cone
    radii μ p_i (``inf``: no cone at that node). The solution is the fixed point τ = P(z), z = τ − R(Mτ − F), with P the
    nodewise projection onto the discs (intervals when m = 1) and R = diag(1/M_ii) > 0
    (for a separable convex set the fixed point is the KKT system, whatever R). It is
    found by semismooth Newton on G(τ) = τ − P(z(τ)), started from the projection of
    the unconstrained minimiser, to a relative 1e-13. ``tol`` (scalar or (n,), stress):
    the slip tolerance of the nodal law (:func:`~dolfinx_mortar.friction.return_mapping`
    slips only where |τ^tr| − μp > tol); a disc is never smaller than it, radius
    max(c_i, tol_i): at first contact every cone is closed (p = 0) and M⁻¹F is
    round-off, which lay outside a disc of radius 0, so ∂τ/∂F was 0 and the first
    Newton step had no tangential stiffness where the nodal law sticks. (Counting
    |z| ≤ c + tol as inside instead made the projection jump at c + tol, and the
    iteration then found no fixed point for some z in that band.)

    Returns (τ (n, m), J (n·m, n·m) = ∂G/∂τ at the solution, dPz (n, m, m), dPc (n, m),
    iterations): the sensitivities ∂τ = J⁻¹[∂P/∂z R ∂F + ∂P/∂c ∂c] follow from
    differentiating the fixed point. Raises ConvergenceError without convergence.
    """
    n, m = F.shape
    if n == 0:
        return F.copy(), np.zeros((0, 0)), np.zeros((0, m, m)), np.zeros((0, m)), 0
    r = 1.0 / np.diag(M)
    Mb = _block(M, m)
    open_ = c >= tol  # where the radius is c (∂radius/∂c = 1), not tol
    c = np.maximum(c, tol)
    tau, _, _ = _project_discs(np.linalg.solve(M, F), c)
    finite = c[np.isfinite(c)]
    scale = max(float(np.abs(F).max()) * float(r.max()), float(finite.max(initial=0.0)), 1e-300)
    for it in range(1, CONE_QP_MAX_ITERATIONS + 1):
        z = tau - r[:, None] * (M @ tau - F)
        P, dPz, dPc = _project_discs(z, c)
        G = tau - P
        J = np.eye(n * m) - _blockdiag(dPz) @ (np.eye(n * m) - np.repeat(r, m)[:, None] * Mb)
        if np.abs(G).max() <= 1e-13 * scale:
            return P, J, dPz, np.where(open_[:, None], dPc, 0.0), it
        tau = tau - np.linalg.solve(J, G.ravel()).reshape(n, m)
    raise ConvergenceError(
        f"constrained tangential recovery: no convergence in {CONE_QP_MAX_ITERATIONS} "
        "semismooth Newton iterations"
    )


def recover_tangential(
    method: str,
    M: sp.spmatrix,
    A: np.ndarray,
    sigma: np.ndarray,
    lam: np.ndarray,
    p: np.ndarray,
    has: np.ndarray,
    active: np.ndarray,
    mu: float,
    eps_t: np.ndarray,
    frozen=None,
    tol=None,
) -> TangentialRecovered:
    r"""Tangential recovery of n slave nodes (docs/method-notes.md, "Tangential recoveries").

    With the tangential mortar matrix M_IJ = ∫Ψ_I Φ_J dA₀ (Ψ the tangential weights, row
    sums A^I = ∫Ψ_I dA₀) and the weighted slip since t_n σ^I_α = a^I_α·S^I − a^I_{α,n}·S^I_n
    in each node's frame (:meth:`.tangential.TangentialTerms._slip_since_t_n`):

        M γ_α = σ_α,    τ̂^I = Coulomb(λ_T^I + ε_T^I γ^I; μ p^I),    F^I = A^I τ̂^I,

    * ``lumped``: M → diag(A): γ = σ/A, τ = τ̂ (the nodal return mapping);
    * ``unconstrained``: M τ_α = F_α (τ may leave the Coulomb cone);
    * ``constrained``: τ = argmin_{|τ^I| ≤ μ p^I} ½ Σ_α τ_αᵀMτ_α − τ_αᵀF_α
      (:func:`cone_qp`): the projection of M⁻¹F onto the cone in the M-norm. A node that
      ``frozen`` imposes in STICK (the chattering control) has no cone there, as its
      lumped law's τ̂ = λ_T + ε_T γ has none (session 48: with the cone the QP's
      projection switched at such a node from iterate to iterate, and a Newton solve
      with the states frozen 4-cycled until max_it).

    The frame components of neighbouring nodes are identified (M acts on each component
    α); exact for a flat surface, an O(h κ) approximation on a curved one.

    M (n, n) sparse; A, p, eps_t (n,); sigma, lam (n, m); has (n,) bool: nodes that take
    part (others get zero); active (n,) the normal active set; mu the Coulomb
    coefficient; frozen, tol as :func:`~dolfinx_mortar.friction.return_mapping`.
    Serial, deterministic.
    """
    from .friction import STICK, return_mapping

    n, m = sigma.shape
    idx = np.flatnonzero(has)
    gamma = np.zeros((n, m))
    tau = np.zeros((n, m))
    if method == "lumped":
        gamma[idx] = sigma[idx] / A[idx, None]
    elif idx.size:
        Mh = sp.csr_matrix(M)[idx][:, idx].toarray()
        W = np.linalg.inv(Mh)
        gamma[idx] = W @ sigma[idx]
    tau_hat, state, D, Pd = return_mapping(lam, gamma, p, active & has, mu, eps_t, frozen, tol)
    tau_hat[~has] = 0.0
    F = A[:, None] * tau_hat
    k = idx.size
    pos = (idx[:, None] * m + np.arange(m)).ravel()  # rows of the taking-part nodes

    def embed(Ts, Tp_, TF_=None):
        Tsig, Tp, TF = np.zeros((n * m, n * m)), np.zeros((n * m, n)), np.zeros((n * m, n * m))
        Tsig[np.ix_(pos, pos)] = Ts
        Tp[np.ix_(pos, idx)] = Tp_
        if TF_ is not None:
            TF[np.ix_(pos, pos)] = TF_
        return Tsig, Tp, TF

    Dk, Pk, Ak = D[idx], Pd[idx], A[idx]
    if method == "lumped":

        def lumped_tangent():
            return embed(_blockdiag(Dk / Ak[:, None, None]), _column_blocks(Pk))

        tau[idx] = tau_hat[idx]
        return TangentialRecovered(gamma, tau_hat, tau, state, D, Pd, lumped_tangent)
    if method not in ("unconstrained", "constrained"):
        raise ValueError(f"unknown tangential recovery {method!r}")
    if not k:
        return TangentialRecovered(
            gamma, tau_hat, tau, state, D, Pd, lambda: embed(np.zeros((0, 0)), np.zeros((0, 0)))
        )
    Wb = _block(W, m)
    # ∂F (k·m) = A D W ∂σ + A Pd ∂p
    dF_sig = _blockdiag(Ak[:, None, None] * Dk) @ Wb
    dF_p = _column_blocks(Ak[:, None] * Pk)
    if method == "unconstrained":
        tau[idx] = W @ F[idx]

        def unconstrained_tangent():
            return embed(Wb @ dF_sig, Wb @ dF_p, Wb)

        return TangentialRecovered(gamma, tau_hat, tau, state, D, Pd, unconstrained_tangent)
    c = mu * np.maximum(p[idx], 0.0)
    if frozen is not None:
        # a node imposed STICK by the chattering control has no cone in the QP either: its
        # τ̂ = λ_T + ε_T γ is linear in u, and the projection onto |τ| ≤ μp would bring the
        # stick/slip kink back (docs/method-notes.md, "Tangential recoveries")
        stuck = (frozen[0][idx] >= 0) & (state[idx] == STICK)
        c = np.where(stuck, np.inf, c)
    t_k, J, dPz, dPc, its = cone_qp(Mh, F[idx], c, 0.0 if tol is None else tol[idx])
    tau[idx] = t_k

    def constrained_tangent():
        PR = _blockdiag(dPz) * np.repeat(1.0 / np.diag(Mh), m)[None, :]
        # ∂c/∂p = μ H(p): a negative pressure has no cone (radius μ max(p, 0))
        rhs_p = PR @ dF_p + _column_blocks(dPc * (p[idx] >= 0.0)[:, None]) * mu
        TF = np.linalg.solve(J, PR)
        return embed(TF @ dF_sig, np.linalg.solve(J, rhs_p), TF)

    return TangentialRecovered(gamma, tau_hat, tau, state, D, Pd, constrained_tangent, its)
