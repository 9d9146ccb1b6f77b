"""The nodal recoveries of :mod:`dolfinx_mortar.recovery` on small synthetic slave surfaces.

Independent references: the bound-constrained QP against scipy's NNLS on the Cholesky
factor; the tangent operator against finite differences of p(G); the per-facet mortar
mass matrix (numba) against its NumPy reference.
"""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import nnls

from dolfinx_mortar.kernels import mortar as kmortar
from dolfinx_mortar.kernels import reference as kref
from dolfinx_mortar.kernels.shape import INTERVAL1, INTERVAL2, QUAD1, TRIANGLE1, TRIANGLE2
from dolfinx_mortar.recovery import (
    RECOVERIES,
    cone_qp,
    nonnegative_qp,
    recover,
    recover_tangential,
)


def _mass_1d(n, rng, degree=1):
    """Mass matrix (n, n) of P1 (or P2 with n odd) on a random 1D mesh, and its row sums."""
    M = np.zeros((n, n))
    if degree == 1:
        h = rng.uniform(0.5, 1.5, n - 1)
        for e in range(n - 1):
            M[e : e + 2, e : e + 2] += h[e] / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])
    else:
        local = np.array([[4.0, -1.0, 2.0], [-1.0, 4.0, 2.0], [2.0, 2.0, 16.0]]) / 30.0
        for e in range((n - 1) // 2):
            i = [2 * e, 2 * e + 2, 2 * e + 1]
            M[np.ix_(i, i)] += rng.uniform(0.5, 1.5) * local
    return M, M.sum(axis=1)


@pytest.mark.parametrize("seed", range(20))
def test_nonnegative_qp_matches_nnls(seed):
    rng = np.random.default_rng(seed)
    M, _ = _mass_1d(25, rng)
    F = rng.normal(size=25) * (rng.random(25) < 0.7)
    p, free, _, its = nonnegative_qp(sp.csr_matrix(M), F)
    L = np.linalg.cholesky(M)
    ref, _ = nnls(L.T, np.linalg.solve(L, F))  # min |Lᵀp − L⁻¹F|² = 2 (½pᵀMp − pᵀF) + c
    np.testing.assert_allclose(p, ref, atol=1e-10 * max(np.abs(ref).max(), 1.0))
    assert np.all(p >= 0.0) and its >= 1
    mu = M @ p - F
    assert np.all(mu[~free] >= -1e-12) and np.allclose(mu[free], 0.0, atol=1e-12)


def _random_state(n, rng, degree=1):
    M, A = _mass_1d(n, rng, degree)
    x = np.linspace(-1.0, 1.0, n)
    G = A * (0.3 * x**2 - 0.05 + 0.01 * rng.normal(size=n))  # contact near the middle
    lam = np.where(rng.random(n) < 0.4, 0.5 * rng.random(n), 0.0)
    eps = rng.uniform(50.0, 150.0, n)
    return sp.csr_matrix(M), A, G, lam, eps


@pytest.mark.parametrize("method", RECOVERIES)
def test_recovery_equations_and_constants(method):
    rng = np.random.default_rng(3)
    M, A, G, lam, eps = _random_state(31, rng)
    has = np.ones(A.size, bool)
    r = recover(method, M, A, G, lam, eps, has)
    F = A * r.p_hat
    np.testing.assert_allclose(r.p_hat, np.maximum(lam - eps * r.gamma, 0.0), atol=1e-12)
    if method == "lumped":
        np.testing.assert_allclose(r.gamma, G / A)
        np.testing.assert_allclose(r.p, r.p_hat)
    else:
        np.testing.assert_allclose(M @ r.gamma, G, atol=1e-12)
    if method == "unconstrained":
        np.testing.assert_allclose(M @ r.p, F, atol=1e-12)
        assert r.p.min() < 0.0  # the contact edge oscillates
    if method == "constrained":
        assert r.p.min() >= 0.0 and r.qp_iterations >= 1
        mu = M @ r.p - F
        assert np.all(mu[r.p == 0.0] >= -1e-12)
        np.testing.assert_allclose(mu[r.p > 0.0], 0.0, atol=1e-12)
    # constants: a uniform gap and multiplier give a uniform pressure (M·1 = A)
    c = recover(method, M, A, -0.01 * A, np.full(A.size, 0.2), np.full(A.size, 100.0), has)
    np.testing.assert_allclose(c.gamma, -0.01, rtol=1e-12)
    np.testing.assert_allclose(c.p, 1.2, rtol=1e-12)


@pytest.mark.parametrize("method", RECOVERIES)
@pytest.mark.parametrize("degree", [1, 2])
def test_recovery_tangent_matches_finite_differences(method, degree):
    """∂p^J/∂G^K = −Σ_I L_IJ d_I R_IK (the operator the contact tangent assembles)."""
    rng = np.random.default_rng(7 + degree)
    M, A, G, lam, eps = _random_state(31, rng, degree)
    has = A > 0.0
    r = recover(method, M, A, G, lam, eps, has)
    dpdG = -(r.left.T @ sp.diags(r.d) @ r.right).toarray()
    h = 1e-7 * np.abs(G).max()
    fd = np.zeros_like(dpdG)
    for k in range(G.size):
        e = np.zeros(G.size)
        e[k] = h
        fd[:, k] = (
            recover(method, M, A, G + e, lam, eps, has).p
            - recover(method, M, A, G - e, lam, eps, has).p
        ) / (2 * h)
    np.testing.assert_allclose(dpdG, fd, atol=1e-6 * np.abs(fd).max())
    assert np.abs(fd).max() > 0.0


@pytest.mark.parametrize(
    "ftype, degree", [(INTERVAL1, 3), (INTERVAL2, 5), (TRIANGLE1, 3), (QUAD1, 3)]
)
def test_facet_mass_kernel_matches_reference(ftype, degree):
    from dolfinx_mortar.surface import quadrature

    rng = np.random.default_rng(0)
    qpts, qw = quadrature(ftype, degree)
    nsf, nq = 4, qw.size
    qp_xi = np.broadcast_to(qpts, (nsf, nq, qpts.shape[1])).copy()
    qp_w = qw[None, :] * rng.uniform(0.5, 2.0, (nsf, 1))
    qp_m = np.where(rng.random((nsf, nq)) < 0.7, 0, -1)
    nphi = kref.shape(ftype, qpts[0])[0].size
    Mf = np.zeros((nsf, nphi, nphi))
    kmortar.facet_mass(ftype, qp_xi, qp_w, qp_m, Mf)
    np.testing.assert_allclose(Mf, kref.facet_mass(ftype, qp_xi, qp_w, qp_m), atol=1e-14)
    # row sums are the nodal areas A^I of nodal_integrals
    A = np.zeros(nsf * nphi)
    G = np.zeros(nsf * nphi)
    node_of = np.arange(nsf * nphi).reshape(nsf, nphi)
    kmortar.nodal_integrals(ftype, qp_xi, qp_w, qp_m, np.ones((nsf, nq)), node_of, A, G)
    np.testing.assert_allclose(Mf.sum(axis=2).ravel(), A, atol=1e-14)


@pytest.mark.parametrize("ftype", [INTERVAL2, TRIANGLE2])
def test_paired_fraction_is_the_paired_reference_measure(ftype):
    """kernels.mortar.paired_fraction on curved P2 facets (random mid-edge offsets): the
    fraction of a facet that its paired points cover equals the sum of their rule weights
    ŵ over the reference measure (1 for an interval, 1/2 for a triangle), whatever J₀;
    every point paired gives 1 to round-off (tangential.PARTIAL_FACET_TOL compares with it)."""
    from dolfinx_mortar.surface import quadrature

    rng = np.random.default_rng(1)
    qpts, qw = quadrature(ftype, 4)
    nsf, nq = 5, qw.size
    if ftype == INTERVAL2:  # vertices, then the mid node, in 2D
        base = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.0]])
        bump = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
        ref = 1.0
    else:  # vertices, then the edge mid nodes, in 3D
        v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        mids = np.array([(v[1] + v[2]) / 2, (v[0] + v[2]) / 2, (v[0] + v[1]) / 2])
        base = np.vstack([v, mids])
        bump = np.zeros_like(base)
        bump[3:, 2] = 1.0
        ref = 0.5
    Xs = base[None] + 0.2 * rng.uniform(-1.0, 1.0, (nsf, 1, 1)) * bump[None]
    qp_xi = np.zeros((nsf, nq, qpts.shape[1]))
    qp_w = np.zeros((nsf, nq))
    kmortar.reference_weights(ftype, Xs, qpts, qw, qp_xi, qp_w)
    qp_m = np.where(rng.random((nsf, nq)) < 0.6, 0, -1)
    out = np.zeros(nsf)
    kmortar.paired_fraction(ftype, Xs, qp_xi, qp_w, qp_m, out)
    expected = np.where(qp_m >= 0, qw[None, :], 0.0).sum(axis=1) / ref
    np.testing.assert_allclose(out, expected, atol=1e-14)
    kmortar.paired_fraction(ftype, Xs, qp_xi, qp_w, np.zeros((nsf, nq), np.int64), out)
    np.testing.assert_allclose(out, 1.0, atol=1e-13)
    # the weights' sum does depend on J₀ there: the fraction is not Σ w / Σ w_all
    assert not np.allclose(qp_w.sum(axis=1), ref)


def test_constrained_with_imposed_free_set():
    """The chattering control keeps nodes in the QP's free set: with the converged set the
    result is the QP's; with a wider set, p solves M_𝒫𝒫 p = F on the union (and may be
    negative there at a node with p̂ > 0)."""
    rng = np.random.default_rng(5)
    M, A, G, lam, eps = _random_state(31, rng)
    has = np.ones(A.size, bool)
    r = recover("constrained", M, A, G, lam, eps, has)
    r2 = recover("constrained", M, A, G, lam, eps, has, free=r.free)
    np.testing.assert_allclose(r2.p, r.p, atol=1e-12)
    assert (r2.left != r.left).nnz == 0
    extra = np.zeros(A.size, bool)
    # a node outside the QP's set whose law presses (p̂ > 0): it stays in the set even in
    # tension (one with p̂ = 0 and p < 0 leaves it: the test below)
    extra[np.flatnonzero(~r.free & (r.p_hat > 0.0))[0]] = True
    r3 = recover("constrained", M, A, G, lam, eps, has, free=extra)
    wider = r.free | extra
    np.testing.assert_array_equal(r3.free, wider)
    F = A * r3.p_hat
    sub = np.flatnonzero(wider)
    np.testing.assert_allclose((M @ r3.p)[sub], F[sub], atol=1e-12)
    assert np.all(r3.p[~wider] == 0.0)


def test_unconstrained_predictor_closes_the_recovered_gap():
    """Nothing in contact: ``predictor`` gives the nodes nearest to contact the tangent of
    an active node in the unconstrained form, whose row is the row of M⁻¹ (the linearised
    step closes γ^I = (M⁻¹G)^I); ignored as soon as a node carries pressure."""
    rng = np.random.default_rng(5)
    M, A = _mass_1d(31, rng)
    M = sp.csr_matrix(M)
    x = np.linspace(-1.0, 1.0, A.size)
    G = A * (0.3 * x**2 + 0.01)  # open everywhere, closest at the middle
    lam, eps, has = np.zeros(A.size), np.full(A.size, 100.0), np.ones(A.size, bool)
    h = np.full(A.size, 0.1)
    assert recover("unconstrained", M, A, G, lam, eps, has).tangent_nodes.size == 0
    r = recover("unconstrained", M, A, G, lam, eps, has, predictor=(1e-4, h))
    assert np.all(r.p == 0.0)  # the residual is untouched
    near = np.flatnonzero(r.gamma <= r.gamma.min() + 1e-4)
    np.testing.assert_array_equal(r.tangent_nodes, near)
    np.testing.assert_allclose(r.d, A[near] * eps[near])
    np.testing.assert_allclose(r.right @ G, r.gamma[near], rtol=1e-10)
    np.testing.assert_allclose(r.left.toarray(), r.right.toarray())
    closed = recover("unconstrained", M, A, G - 0.02 * A, lam, eps, has, predictor=(1e-4, h))
    assert closed.p_hat.max() > 0.0
    np.testing.assert_array_equal(closed.tangent_nodes, np.flatnonzero(closed.p_hat > 0.0))


# ---------------------------------------------------------------- tangential recoveries
def _tangential_state(n, m, rng):
    M, A = _mass_1d(n, rng)
    x = np.linspace(-1.0, 1.0, n)
    sigma = A[:, None] * (
        0.02 * x[:, None] ** np.arange(1, m + 1) + 0.003 * rng.normal(size=(n, m))
    )
    lam = 0.1 * rng.normal(size=(n, m))
    p = np.maximum(1.0 - x**2, 0.0) + 0.1
    p[:2] = 0.0  # two open nodes
    has = np.ones(n, bool)
    has[-1] = False  # one node without tangential area
    return sp.csr_matrix(M), A, sigma, lam, p, has, p > 0.0, np.full(n, 50.0)


MU_T = 0.3


@pytest.mark.parametrize("method", RECOVERIES)
@pytest.mark.parametrize("m", [1, 2])
def test_tangential_recovery_equations(method, m):
    """The defining equations (module docstring of recover_tangential), stick and slip
    nodes present, the cone respected except by the unconstrained recovery."""
    M, A, sigma, lam, p, has, active, eps = _tangential_state(21, m, np.random.default_rng(1))
    r = recover_tangential(method, M, A, sigma, lam, p, has, active, MU_T, eps)
    idx = np.flatnonzero(has)
    Mh = M[idx][:, idx].toarray()
    states = np.bincount(r.state[active], minlength=3)
    assert states[1] >= 1 and states[2] >= 1, states
    assert np.all(r.tau[~has] == 0.0) and np.all(r.tau_hat[~active] == 0.0)
    F = A[idx, None] * r.tau_hat[idx]
    norm = np.linalg.norm(r.tau, axis=1)
    if method == "lumped":
        np.testing.assert_allclose(r.gamma[idx], sigma[idx] / A[idx, None])
        np.testing.assert_allclose(r.tau, r.tau_hat)
    else:
        np.testing.assert_allclose(Mh @ r.gamma[idx], sigma[idx], atol=1e-14)
    if method == "unconstrained":
        np.testing.assert_allclose(Mh @ r.tau[idx], F, atol=1e-14)
        assert np.any(norm > MU_T * p * (1 + 1e-6))  # M⁻¹ leaves the cone
    else:
        assert np.all(norm <= MU_T * p * (1 + 1e-12) + 1e-15)
    if method == "constrained":
        # KKT: the gradient Mτ − F vanishes inside the cone and is antiparallel to τ on it
        g = Mh @ r.tau[idx] - F
        c = MU_T * p[idx]
        inside = np.linalg.norm(r.tau[idx], axis=1) < c * (1 - 1e-9)
        np.testing.assert_allclose(g[inside], 0.0, atol=1e-12)
        on = ~inside & (c > 0)
        cosang = np.einsum("na,na->n", g[on], r.tau[idx][on]) / (
            np.linalg.norm(g[on], axis=1) * np.linalg.norm(r.tau[idx][on], axis=1) + 1e-300
        )
        assert np.all((cosang < -1 + 1e-9) | (np.linalg.norm(g[on], axis=1) < 1e-12))
    # a uniform stick state is reproduced exactly (M·1 = A)
    u = recover_tangential(
        method,
        M,
        A,
        1e-4 * A[:, None] * np.ones((1, m)),
        np.zeros((A.size, m)),
        np.ones(A.size),
        np.ones(A.size, bool),
        np.ones(A.size, bool),
        MU_T,
        eps,
    )
    np.testing.assert_allclose(u.tau, 50.0 * 1e-4, rtol=1e-11)


@pytest.mark.parametrize("method", RECOVERIES)
@pytest.mark.parametrize("m", [1, 2])
def test_tangential_recovery_tangent_matches_finite_differences(method, m):
    """Tsig = ∂τ/∂σ and Tp = ∂τ/∂p (away from the kink of the cone radius μ⟨p⟩ at p = 0)."""
    n = 21
    M, A, sigma, lam, p, has, active, eps = _tangential_state(n, m, np.random.default_rng(9))

    def tau(s, q):
        return recover_tangential(method, M, A, s, lam, q, has, active, MU_T, eps).tau.ravel()

    r = recover_tangential(method, M, A, sigma, lam, p, has, active, MU_T, eps)
    h = 1e-7
    fd_s = np.stack(
        [
            (tau(sigma + h * e, p) - tau(sigma - h * e, p)) / (2 * h)
            for e in np.eye(n * m).reshape(n * m, n, m)
        ],
        axis=1,
    )
    fd_p = np.stack(
        [(tau(sigma, p + h * e) - tau(sigma, p - h * e)) / (2 * h) for e in np.eye(n)], 1
    )
    np.testing.assert_allclose(r.Tsig, fd_s, atol=1e-7 * np.abs(fd_s).max())
    np.testing.assert_allclose(r.Tp[:, 2:], fd_p[:, 2:], atol=1e-7 * np.abs(fd_p).max())
    assert np.abs(fd_s).max() > 0.0 and np.abs(fd_p).max() > 0.0


@pytest.mark.parametrize("m", [1, 2])
def test_constrained_tangent_at_first_contact_sticks_like_the_nodal_law(m):
    """At first contact every cone is closed (p = 0) and the mixed slip is round-off: the
    nodal law sticks (its slip tolerance), and the constrained recovery must give the same
    stick tangent as the unconstrained one, not ∂τ/∂σ = 0 from round-off lying outside a
    closed cone (a 3D press then took its first Newton step with no tangential stiffness
    and every node slipped)."""
    n = 21
    M, A, _, _, _, has, _, eps = _tangential_state(n, m, np.random.default_rng(4))
    sigma = 1e-17 * np.random.default_rng(5).normal(size=(n, m))
    lam, p, active = np.zeros((n, m)), np.zeros(n), has.copy()
    tol = 1e-10 * eps * 0.1
    ru = recover_tangential("unconstrained", M, A, sigma, lam, p, has, active, MU_T, eps, tol=tol)
    rc = recover_tangential("constrained", M, A, sigma, lam, p, has, active, MU_T, eps, tol=tol)
    assert np.all(rc.state[active] == 1)  # stick
    assert np.abs(rc.Tsig).max() > 0.0
    np.testing.assert_allclose(rc.Tsig, ru.Tsig, rtol=1e-12, atol=1e-12 * np.abs(ru.Tsig).max())
    np.testing.assert_allclose(rc.tau, ru.tau, atol=1e-14)


@pytest.mark.parametrize("m", [1, 2])
def test_constrained_recovery_has_no_cone_at_a_node_frozen_in_stick(m):
    """A node that the chattering control imposes in STICK (``frozen``) keeps τ̂ = λ_T +
    ε_T γ outside the Coulomb cone, as the lumped law does, and the constrained recovery
    puts no cone on it either: its τ is the unconstrained M⁻¹F there (smooth in σ), the
    other nodes keep theirs (the QP's gradient Mτ − F vanishes at the frozen nodes). Before session 48 the QP projected such a node onto its cone,
    and a Newton solve with the states frozen (the unloading step of
    ``demo_cattaneo2d.py --unload`` with this recovery) 4-cycled until max_it."""
    n = 21
    M, A, sigma, lam, p, has, active, eps = _tangential_state(n, m, np.random.default_rng(1))
    free = recover_tangential("constrained", M, A, sigma, lam, p, has, active, MU_T, eps)
    slipping = np.flatnonzero(free.state == 2)
    assert slipping.size >= 2
    states = np.full(n, -1)
    states[slipping] = 1  # imposed stick where the free law slips: outside the cone
    frozen = (states, np.zeros((n, m)))

    def rec(method, s=sigma):
        return recover_tangential(method, M, A, s, lam, p, has, active, MU_T, eps, frozen)

    rc, ru = rec("constrained"), rec("unconstrained")
    assert np.all(rc.state[slipping] == 1)
    trial = lam + eps[:, None] * rc.gamma
    np.testing.assert_allclose(rc.tau_hat[slipping], trial[slipping])
    assert np.all(np.linalg.norm(trial[slipping], axis=1) > MU_T * p[slipping])
    # KKT of the QP: the gradient Mτ − F vanishes at the frozen nodes (no constraint there)
    idx = np.flatnonzero(has)
    g = np.zeros((n, m))
    g[idx] = M[idx][:, idx].toarray() @ rc.tau[idx] - A[idx, None] * rc.tau_hat[idx]
    np.testing.assert_allclose(g[slipping], 0.0, atol=1e-12)
    norm = np.linalg.norm(rc.tau, axis=1)
    assert np.any(norm[slipping] > MU_T * p[slipping] * (1 + 1e-6))  # outside the cone
    others = np.flatnonzero(has & (states < 0))
    assert np.all(norm[others] <= MU_T * p[others] * (1 + 1e-12) + 1e-15)
    # where no other cone is active either, it is the unconstrained recovery
    if np.all(norm[others] < MU_T * p[others] * (1 - 1e-9)):
        np.testing.assert_allclose(rc.tau, ru.tau, atol=1e-13)
    # smooth: its tangent matches finite differences
    h = 1e-7
    fd = np.stack(
        [
            (rec("constrained", sigma + h * e).tau - rec("constrained", sigma - h * e).tau).ravel()
            / (2 * h)
            for e in np.eye(n * m).reshape(n * m, n, m)
        ],
        axis=1,
    )
    np.testing.assert_allclose(rc.Tsig, fd, atol=1e-7 * np.abs(fd).max())


def test_cone_qp_converges_with_z_just_outside_a_cone():
    """The slip tolerance enlarges a disc only below it (radius max(c, tol)): a first
    version counted |z| ≤ c + tol as inside, the projection then jumped at c + tol and
    the semismooth Newton found no fixed point for z in that band (this case: 50
    iterations, ConvergenceError). The Coulomb bound holds to round-off."""
    M = np.array([[2.0, 1.0, 0.0], [1.0, 4.0, 1.0], [0.0, 1.0, 2.0]]) / 6.0
    c = np.array([0.74, 1.15, 0.56])
    F = np.array([[0.1508337], [-0.21333315], [-0.0025]])
    tau0 = cone_qp(M, F, c)[0]
    tau, *_ = cone_qp(M, F, c, np.full(3, 1e-6))
    np.testing.assert_allclose(tau, tau0, atol=1e-14)
    assert np.all(np.abs(tau[:, 0]) <= c * (1 + 1e-14))


def test_a_kept_node_whose_law_is_open_leaves_the_free_set_in_tension():
    """The chattering control keeps the free set of a Newton solve (``free``); a node of
    the union with F_I = A p̂ = 0 (its law is open: it slid off the master's end) and p_I < 0
    there leaves it. On a P1 line (M = h/6 tridiag(1, 4, 1)) with F = 0 on the first four
    nodes and all nodes kept, p = M⁻¹F alternates in sign there (5.3, −10.6, 37.0, −137.5
    next to 513 at node 4: the diagnosed iterates); nodes 1 and 3 (p < 0) leave, which
    decouples nodes 0 and 2 from the loaded ones: p = 0 there, and p on the loaded nodes
    solves M p = F on the set. Before, p = M⁻¹F on all nodes."""
    n, h = 8, 1.0 / 7
    diag = np.full(n, 4 * h / 6)
    diag[[0, -1]] = 2 * h / 6
    off = np.full(n - 1, h / 6)
    M = sp.csr_matrix(sp.diags([off, diag, off], [-1, 0, 1]))
    A = np.asarray(M.sum(axis=1)).ravel()
    lam = np.array([0.0, 0.0, 0.0, 0.0, 400.0, 500.0, 500.0, 400.0])
    has = np.ones(n, bool)
    # G = 0: γ = 0 and p̂ = λ, F = A λ
    r = recover("constrained", M, A, np.zeros(n), lam, np.ones(n), has, free=has)
    F = A * lam
    kept = np.array([True, False, True, False, True, True, True, True])
    np.testing.assert_array_equal(r.free, kept)
    expected = np.zeros(n)
    expected[4:] = np.linalg.solve(M.toarray()[4:, 4:], F[4:])
    np.testing.assert_allclose(r.p, expected, rtol=1e-12, atol=1e-12)
    assert np.all(r.p >= 0.0)
    # the union's p = M⁻¹F (the rule before) alternates in sign where F = 0
    full = np.linalg.solve(M.toarray(), F)
    np.testing.assert_allclose(full[:5], [5.290, -10.581, 37.032, -137.547, 513.157], atol=1e-3)
