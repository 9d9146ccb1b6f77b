"""Tests of dolfinx_mortar.analytic against BENCHMARKS.md and by quadrature."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from dolfinx_mortar import analytic as A

E, NU, R, P = 200.0, 0.3, 8.0, 10.0


def test_effective_modulus_and_radius():
    Es = A.effective_modulus(E, NU)
    assert Es == pytest.approx(E / (2 * (1 - NU**2)), rel=1e-14)
    assert A.effective_modulus(E, NU, E, NU) == pytest.approx(Es, rel=1e-14)
    assert A.effective_modulus(E, NU, math.inf) == pytest.approx(E / (1 - NU**2), rel=1e-14)
    assert A.effective_modulus(100.0, 0.0, 300.0, 0.5) == pytest.approx(
        1 / (1 / 100 + 0.75 / 300), rel=1e-14
    )
    assert A.effective_radius(R) == R
    assert A.effective_radius(R, R) == pytest.approx(R / 2)
    with pytest.raises(ValueError):
        A.effective_modulus(-1.0, 0.3)


def test_hertz2d_benchmark_numbers():
    h = A.hertz2d(P, R, A.effective_modulus(E, NU))
    assert h["a"] == pytest.approx(0.9628, abs=5e-5)
    assert h["p0"] == pytest.approx(6.612, abs=5e-4)


def test_hertz2d_force_balance():
    Es = A.effective_modulus(E, NU)
    a = A.hertz2d(P, R, Es)["a"]
    total, _ = quad(lambda x: A.hertz2d_pressure(x, P, R, Es), -a, a, epsabs=1e-13)
    assert total == pytest.approx(P, rel=1e-9)
    assert A.hertz2d_pressure(1.5 * a, P, R, Es) == 0.0
    assert A.hertz2d_pressure(0.0, P, R, Es) == pytest.approx(A.hertz2d(P, R, Es)["p0"])
    x = np.linspace(-2 * a, 2 * a, 11)
    p = A.hertz2d_pressure(x, P, R, Es)
    assert p.shape == x.shape and np.all(p >= 0.0)


def test_hertz3d():
    Es = A.effective_modulus(E, NU)
    h = A.hertz3d(P, R, Es)
    assert h["a"] == pytest.approx((3 * P * R / (4 * Es)) ** (1 / 3), rel=1e-14)
    assert h["p0"] == pytest.approx(3 * P / (2 * math.pi * h["a"] ** 2), rel=1e-14)
    assert h["delta"] == pytest.approx(h["a"] ** 2 / R, rel=1e-14)
    total, _ = quad(lambda r: 2 * math.pi * r * A.hertz3d_pressure(r, P, R, Es), 0, h["a"])
    assert total == pytest.approx(P, rel=1e-9)
    # M = (3 pi / 16) mu P a is the integral of mu p(r) r over the disc
    mu = 0.2
    torque, _ = quad(lambda r: 2 * math.pi * r**2 * mu * A.hertz3d_pressure(r, P, R, Es), 0, h["a"])
    assert A.torsion_full_slip(mu, P, h["a"]) == pytest.approx(torque, rel=1e-9)


@pytest.mark.parametrize("ratio", [0.1, 0.5, 0.9])
def test_cattaneo_mindlin2d(ratio):
    mu, Rs = 0.2, 4.0  # two half-cylinders R = 8
    Es = A.effective_modulus(E, NU)
    Q = ratio * mu * P
    s = A.cattaneo_mindlin2d_stick(P, Q, mu, Rs, Es)
    a, c = s["a"], s["c"]
    assert c / a == pytest.approx(math.sqrt(1 - ratio), rel=1e-14)

    def q(x):
        return A.cattaneo_mindlin2d(x, P, Q, mu, Rs, Es)

    # continuous at c (a square-root cusp on the stick side), mu p in the slip zone, 0 outside
    assert q(c * (1 - 1e-12)) == pytest.approx(q(c * (1 + 1e-12)), abs=1e-5)
    xs = np.linspace(c, a, 7)[1:-1]
    assert np.allclose(q(xs), mu * A.hertz2d_pressure(xs, P, Rs, Es))
    assert q(1.01 * a) == 0.0 and q(-1.01 * a) == 0.0
    assert np.all(q(np.linspace(-a, a, 101)) >= 0.0)
    total = quad(q, -a, a, points=[-c, c], epsabs=1e-13, limit=200)[0]
    assert total == pytest.approx(Q, rel=1e-8)
    # the sign follows Q
    assert A.cattaneo_mindlin2d(0.3 * c, P, -Q, mu, Rs, Es) == pytest.approx(-q(0.3 * c))


def test_cattaneo_mindlin_limits():
    Es = A.effective_modulus(E, NU)
    s = A.cattaneo_mindlin2d_stick(P, 0.0, 0.2, 4.0, Es)
    assert s["c"] == s["a"]
    assert A.cattaneo_mindlin2d(0.1, P, 0.0, 0.2, 4.0, Es) == 0.0
    assert A.cattaneo_mindlin2d_stick(P, 2.0, 0.2, 4.0, Es)["c"] == 0.0  # Q = mu P
    with pytest.raises(ValueError):
        A.cattaneo_mindlin2d_stick(P, 2.5, 0.2, 4.0, Es)
    with pytest.raises(ValueError):
        A.cattaneo_mindlin3d(P, 1.0, 0.0)


def test_cattaneo_mindlin3d():
    mu, Es = 0.2, A.effective_modulus(E, NU)
    Q = 0.5 * mu * P
    assert A.cattaneo_mindlin3d(P, Q, mu) == pytest.approx(0.5 ** (1 / 3), rel=1e-14)
    a = A.hertz3d(P, R, Es)["a"]
    c = a * A.cattaneo_mindlin3d(P, Q, mu)

    def q(r):
        return A.cattaneo_mindlin3d_traction(r, P, Q, mu, R, Es)

    total = quad(lambda r: 2 * math.pi * r * q(r), 0, a, points=[c], epsabs=1e-13)[0]
    assert total == pytest.approx(Q, rel=1e-8)
    # continuous at c (a square-root cusp on the stick side), mu p in the slip zone, 0 outside
    assert q(c * (1 - 1e-12)) == pytest.approx(q(c * (1 + 1e-12)), abs=1e-5)


def test_wedge_slip_ratio():
    assert A.wedge_slip_ratio(0.1, 0.3) == pytest.approx(0.41237, abs=5e-6)
    assert A.wedge_slip_ratio(0.1, 0.5) == pytest.approx(0.63158, abs=5e-6)
    assert A.wedge_slip_ratio(0.0, 0.3) == pytest.approx(0.3)
    assert A.wedge_slip_ratio(2.0, 0.5) == math.inf


@pytest.mark.parametrize("ratio", [0.3, 0.5, 1.0])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_mindlin_deresiewicz2d_unloading(ratio, sign):
    """Unloading from Q* = ±ratio μP: the limits Q = Q* (Cattaneo–Mindlin's q*) and
    Q = −Q* (−q*), ∫ q dx = Q, the reverse-slip band q = −μ p sign(Q*) outside the new
    stick zone c' = a √(1 − (Q* − Q)/(2μP)), the stick zone's traction change
    q* − q = 2 (μ p0/a)(√(a² − x²) − √(c'² − x²)) (Johnson §7.2, eq. 7.48's 2D form)."""
    mu, Rs = 0.2, 4.0
    Es = A.effective_modulus(E, NU)
    Qs = sign * ratio * mu * P
    h = A.hertz2d(P, Rs, Es)
    a, p0 = h["a"], h["p0"]
    xs = np.linspace(-1.1 * a, 1.1 * a, 221)
    qstar = A.cattaneo_mindlin2d(xs, P, Qs, mu, Rs, Es)
    md = A.mindlin_deresiewicz2d
    assert np.allclose(md(xs, P, Qs, Qs, mu, Rs, Es), qstar, rtol=0, atol=1e-13)
    assert np.allclose(md(xs, P, Qs, -Qs, mu, Rs, Es), -qstar, rtol=0, atol=1e-13)
    for frac in (0.8, 0.5, 0.0, -0.25, -0.9):
        Q = frac * Qs
        dQ = abs(Qs - Q)
        c1 = a * math.sqrt(1 - dQ / (2 * mu * P))
        c0 = a * math.sqrt(1 - ratio)
        assert c1 >= c0 - 1e-12

        def q(x, Q=Q):
            return md(x, P, Qs, Q, mu, Rs, Es)

        pts = sorted({-c1, -c0, c0, c1})
        total = quad(q, -a, a, points=pts, epsabs=1e-13, limit=400)[0]
        assert total == pytest.approx(Q, rel=1e-8, abs=1e-12)
        band = np.linspace(c1, a, 9)[1:-1]
        assert np.allclose(q(band), -sign * mu * A.hertz2d_pressure(band, P, Rs, Es), atol=1e-13)
        assert np.allclose(q(-band), q(band), atol=1e-13)  # even in x
        inner = np.linspace(-c1, c1, 21)[1:-1]
        change = 2 * mu * p0 / a * (np.sqrt(a**2 - inner**2) - np.sqrt(c1**2 - inner**2))
        qs_in = A.cattaneo_mindlin2d(inner, P, Qs, mu, Rs, Es)
        assert np.allclose(qs_in - q(inner), sign * change, atol=1e-12)
        # the traction stays within the cone, and reaches it only outside c'
        assert np.all(np.abs(q(xs)) <= mu * A.hertz2d_pressure(xs, P, Rs, Es) + 1e-12)
        assert q(1.01 * a) == 0.0


def test_mindlin_deresiewicz2d_reloading():
    """Loaded to Q*, unloaded to Q_min, reloaded to Q: Q = Q_min continues the unloading
    state; Q = Q* closes the loop on q* (Masing's memory); ∫ q dx = Q; with Q_min = −Q*
    the reloading branch is the unloading one mirrored: q(Q) = −q_unloading(−Q)."""
    mu, Rs = 0.2, 4.0
    Es = A.effective_modulus(E, NU)
    Qs, Qm = 0.5 * mu * P, -0.25 * mu * P
    a = A.hertz2d(P, Rs, Es)["a"]
    xs = np.linspace(-1.1 * a, 1.1 * a, 221)
    md = A.mindlin_deresiewicz2d
    unl = md(xs, P, Qs, Qm, mu, Rs, Es)
    assert np.allclose(md(xs, P, Qs, Qm, mu, Rs, Es, Q_min=Qm), unl, atol=1e-13)
    qstar = A.cattaneo_mindlin2d(xs, P, Qs, mu, Rs, Es)
    assert np.allclose(md(xs, P, Qs, Qs, mu, Rs, Es, Q_min=Qm), qstar, atol=1e-13)
    for Q in (-0.1 * mu * P, 0.0, 0.3 * mu * P):
        # the square-root cusps: c*, c' of the unloading, c'' of the reloading
        cs = [a * math.sqrt(1 - f) for f in (0.5, 0.375, (Q - Qm) / (2 * mu * P))]
        pts = sorted({s * c for c in cs for s in (-1, 1)})
        total = quad(
            lambda x, Q=Q: md(x, P, Qs, Q, mu, Rs, Es, Q_min=Qm),
            -a,
            a,
            points=pts,
            epsabs=1e-13,
            limit=400,
        )[0]
        assert total == pytest.approx(Q, rel=1e-8, abs=1e-12)
    Q = 0.2 * mu * P
    assert np.allclose(
        md(xs, P, Qs, Q, mu, Rs, Es, Q_min=-Qs), -md(xs, P, Qs, -Q, mu, Rs, Es), atol=1e-13
    )
    with pytest.raises(ValueError):
        md(0.0, P, Qs, 1.1 * Qs, mu, Rs, Es)  # past the reversal point: virgin curve
    with pytest.raises(ValueError):
        md(0.0, P, Qs, -1.1 * Qs, mu, Rs, Es)  # beyond the loop
    with pytest.raises(ValueError):
        md(0.0, P, Qs, 1.1 * Qs, mu, Rs, Es, Q_min=Qm)
    with pytest.raises(ValueError):
        md(0.0, P, 1.01 * mu * P, 0.0, mu, Rs, Es)  # gross slip


def test_tangential_compliance():
    """Λ = (2 − ν1)/G1 + (2 − ν2)/G2: identical materials 2(2 − ν)/G, a rigid partner one
    term; the virgin shift's initial slope is Mindlin's compliance Λ/(8a)."""
    G = E / (2 * (1 + NU))
    assert A.tangential_compliance(E, NU) == pytest.approx(2 * (2 - NU) / G, rel=1e-14)
    assert A.tangential_compliance(E, NU, math.inf) == pytest.approx((2 - NU) / G, rel=1e-14)
    assert A.tangential_compliance(100.0, 0.0, 300.0, 0.5) == pytest.approx(
        2 / 50 + 1.5 / 100, rel=1e-14
    )
    lam, Es, mu = A.tangential_compliance(E, NU), A.effective_modulus(E, NU), 0.3
    a = A.hertz3d(P, R, Es)["a"]
    dQ = 1e-6 * mu * P
    slope = A.cattaneo_mindlin3d_shift(P, dQ, mu, R, Es, lam) / dQ
    assert slope == pytest.approx(lam / (8 * a), rel=1e-5)
    assert A.cattaneo_mindlin3d_shift(P, -dQ, mu, R, Es, lam) == -slope * dQ
    with pytest.raises(ValueError):
        A.tangential_compliance(0.0, NU)


def _md3d_branches(X, mu=0.3, sign=1.0):
    """δ on the unloading and reloading branches of the full loop ±X μP (3D)."""
    lam, Es = A.tangential_compliance(E, NU), A.effective_modulus(E, NU)
    Qs = sign * X * mu * P

    def unload(Q):
        return A.mindlin_deresiewicz3d_shift(P, Qs, Q, mu, R, Es, lam)

    def reload(Q):
        return A.mindlin_deresiewicz3d_shift(P, Qs, Q, mu, R, Es, lam, Q_min=-Qs)

    return Qs, lam, Es, unload, reload


@pytest.mark.parametrize("X", [0.05, 0.3, 0.54, 0.78, 1.0])
def test_mindlin_deresiewicz3d_loop_area_is_the_energy(X):
    """The area of the δ(Q) loop (unloading from Q* to −Q*, reloading back), by quadrature,
    is the closed-form energy per cycle (Johnson eq. 7.50) to 1e-9; the virgin curve joins
    the unloading branch at Q* and the reloading branch at −Q* (mirrored), the two
    branches meet at the turning points ±Q* (δ = ±δ*), and the reloading branch is the
    unloading one mirrored."""
    mu = 0.3
    Qs, lam, Es, unload, reload = _md3d_branches(X, mu)
    ds = A.cattaneo_mindlin3d_shift(P, Qs, mu, R, Es, lam)
    assert unload(Qs) == pytest.approx(ds, rel=1e-14)
    assert unload(-Qs) == pytest.approx(-ds, rel=1e-12)
    assert reload(-Qs) == pytest.approx(-ds, rel=1e-12)
    assert reload(Qs) == pytest.approx(ds, rel=1e-12)
    for f in (0.9, 0.2, -0.6):
        assert reload(f * Qs) == pytest.approx(-unload(-f * Qs), rel=1e-12)
        assert unload(f * Qs) > reload(f * Qs)  # the force lags the shift: a loss
    # continuity of slope at the reversal: the unloading starts with the virgin slope ×1
    # (twice the force and twice the shift scales: dδ/dQ = Λ/(8a) there)
    a = A.hertz3d(P, R, Es)["a"]
    eps = 1e-7 * Qs
    assert (ds - unload(Qs - eps)) / eps == pytest.approx(lam / (8 * a), rel=1e-5)
    area = quad(lambda Q: unload(Q) - reload(Q), -Qs, Qs, epsabs=0, epsrel=1e-12, limit=200)[0]
    dW = A.mindlin_deresiewicz3d_energy(P, Qs, mu, R, Es, lam)
    assert area == pytest.approx(dW, rel=1e-9)
    assert A.mindlin_deresiewicz3d_energy(P, -Qs, mu, R, Es, lam) == pytest.approx(dW, rel=1e-14)


def test_mindlin_deresiewicz3d_energy_limits():
    """ΔW → Λ Q*³/(36 μ P a) as X → 0 (cubic in the amplitude), 3 μ² P² Λ/(20 a) at gross
    slip (X = 1), increasing in between; gross sliding (X > 1) is refused."""
    mu = 0.3
    lam, Es = A.tangential_compliance(E, NU), A.effective_modulus(E, NU)
    a = A.hertz3d(P, R, Es)["a"]

    def dW(X):
        return A.mindlin_deresiewicz3d_energy(P, X * mu * P, mu, R, Es, lam)

    for X in (1e-2, 1e-3):
        Qs = X * mu * P
        assert dW(X) == pytest.approx(lam * Qs**3 / (36 * mu * P * a), rel=2 * X)
    assert dW(0.0) == 0.0
    assert dW(1.0) == pytest.approx(3 * mu**2 * P**2 * lam / (20 * a), rel=1e-14)
    xs = np.linspace(0.0, 1.0, 51)
    assert np.all(np.diff([dW(x) for x in xs]) > 0)
    with pytest.raises(ValueError):
        dW(1.01)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_mindlin_deresiewicz3d_traction_and_stick(sign):
    """Unloading from Q* = ±0.54 μP: c' = a at Q = Q*, c' → c (Cattaneo–Mindlin's at Q*)
    as Q → −Q*; q = q* at Q*, −q* at −Q*; ∫ q dA = Q; reverse slip q = −μ p sign(Q*) in
    c' < r < a, |q| < μ p within c'; the reloading from −Q* is the unloading mirrored;
    the shift, traction and stick ratio refuse a force past the loop."""
    mu = 0.3
    Es = A.effective_modulus(E, NU)
    Qs = sign * 0.54 * mu * P
    a = A.hertz3d(P, R, Es)["a"]
    rs = np.linspace(0.0, 1.1 * a, 111)
    md, st = A.mindlin_deresiewicz3d, A.mindlin_deresiewicz3d_stick
    qstar = A.cattaneo_mindlin3d_traction(rs, P, Qs, mu, R, Es)
    assert st(P, Qs, Qs, mu) == 1.0
    assert st(P, Qs, -Qs, mu) == pytest.approx(A.cattaneo_mindlin3d(P, Qs, mu), rel=1e-14)
    assert np.allclose(md(rs, P, Qs, Qs, mu, R, Es), qstar, rtol=0, atol=1e-13)
    assert np.allclose(md(rs, P, Qs, -Qs, mu, R, Es), -qstar, rtol=0, atol=1e-13)
    c0 = a * A.cattaneo_mindlin3d(P, Qs, mu)
    for f in (0.8, 0.0, -0.5, -0.99):
        Q = f * Qs
        c1 = a * st(P, Qs, Q, mu)
        assert c1 == pytest.approx(a * (1 - (1 - f) * 0.54 / 2) ** (1 / 3), rel=1e-14)

        def q(r, Q=Q):
            return md(r, P, Qs, Q, mu, R, Es)

        total = quad(lambda r: 2 * math.pi * r * q(r), 0, a, points=[c0, c1], limit=200)[0]
        assert total == pytest.approx(Q, rel=1e-8, abs=1e-12)
        band = np.linspace(c1, a, 9)[1:-1]
        assert np.allclose(q(band), -sign * mu * A.hertz3d_pressure(band, P, R, Es), atol=1e-13)
        inner = np.linspace(0.0, c1, 11)[:-1]
        assert np.all(np.abs(q(inner)) < mu * A.hertz3d_pressure(inner, P, R, Es))
        assert q(1.01 * a) == 0.0
        assert np.allclose(
            md(rs, P, Qs, -Q, mu, R, Es, Q_min=-Qs), -q(rs), rtol=0, atol=1e-13
        )  # reloading from −Q* mirrors the unloading
        assert st(P, Qs, -Q, mu, Q_min=-Qs) == pytest.approx(c1 / a, rel=1e-14)
    lam = A.tangential_compliance(E, NU)
    for fn in (
        lambda: md(0.0, P, Qs, 1.1 * Qs, mu, R, Es),
        lambda: st(P, Qs, -1.1 * Qs, mu),
        lambda: A.mindlin_deresiewicz3d_shift(P, Qs, 1.1 * Qs, mu, R, Es, lam, Q_min=-Qs),
        lambda: A.mindlin_deresiewicz3d_shift(P, 1.01 * mu * P, 0.0, mu, R, Es, lam),
    ):
        with pytest.raises(ValueError):
            fn()
