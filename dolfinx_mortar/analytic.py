"""Analytic reference solutions for the contact benchmarks (METHOD.md section 8).

Pure NumPy; used by demos, tests and benchmarks. Conventions: pressures and
tractions are positive in compression, loads ``P`` are positive pressing
forces (per unit length in 2D / plane strain), lengths and moduli in the
scene's units.

Effective quantities::

    1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2,     1/R* = 1/R1 + 1/R2

Functions
---------
effective_modulus, effective_radius
hertz2d, hertz2d_pressure                    line contact (plane strain)
hertz3d, hertz3d_pressure                    point contact
cattaneo_mindlin2d_stick, cattaneo_mindlin2d partial slip, line contact
mindlin_deresiewicz2d                        unloading and reloading, line contact
cattaneo_mindlin3d, cattaneo_mindlin3d_traction   partial slip, point contact
tangential_compliance, cattaneo_mindlin3d_shift    tangential shift, point contact
mindlin_deresiewicz3d, mindlin_deresiewicz3d_stick,
mindlin_deresiewicz3d_shift, mindlin_deresiewicz3d_energy
                                             unloading and reloading, point contact
torsion_full_slip                            torque of a fully sliding Hertz contact
wedge_slip_ratio                             gross-slip force ratio of a block on a wedge

Reference numbers (BENCHMARKS.md): a cylinder of R = 8 on a block, both
E = 200, nu = 0.3, P = 10: E* = 109.89, a = 0.9628, p0 = 6.612.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "cattaneo_mindlin2d",
    "cattaneo_mindlin2d_stick",
    "cattaneo_mindlin3d",
    "cattaneo_mindlin3d_shift",
    "cattaneo_mindlin3d_traction",
    "effective_modulus",
    "effective_radius",
    "hertz2d",
    "hertz2d_pressure",
    "hertz3d",
    "hertz3d_pressure",
    "mindlin_deresiewicz2d",
    "mindlin_deresiewicz3d",
    "mindlin_deresiewicz3d_energy",
    "mindlin_deresiewicz3d_shift",
    "mindlin_deresiewicz3d_stick",
    "tangential_compliance",
    "torsion_full_slip",
    "wedge_slip_ratio",
]


def effective_modulus(E1: float, nu1: float, E2: float | None = None, nu2: float | None = None):
    """Contact modulus ``E*`` with ``1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2``.

    ``E2 = None`` (default) means the second body is of the same material as the
    first (``nu2`` then defaults to ``nu1``): ``E* = E/(2(1 - nu^2))``.
    ``E2 = inf`` is a rigid second body: ``E* = E1/(1 - nu1^2)``.
    """
    if E2 is None:
        E2 = E1
        nu2 = nu1 if nu2 is None else nu2
    elif nu2 is None:
        nu2 = nu1
    if E1 <= 0.0 or E2 <= 0.0:
        raise ValueError("Young's moduli must be positive")
    if math.isinf(E2):  # as MortarContact's plane modulus always was, to the last bit
        return E1 / (1.0 - nu1**2)
    return 1.0 / ((1.0 - nu1**2) / E1 + (1.0 - nu2**2) / E2)


def effective_radius(R1: float, R2: float = math.inf) -> float:
    """Effective radius ``R*`` with ``1/R* = 1/R1 + 1/R2`` (``R2 = inf``: flat)."""
    return 1.0 / (1.0 / R1 + (0.0 if math.isinf(R2) else 1.0 / R2))


# ---------------------------------------------------------------------------
# Hertz
# ---------------------------------------------------------------------------


def hertz2d(P: float, R_star: float, E_star: float) -> dict:
    """Hertz line contact (plane strain), load ``P`` per unit length.

    ``a = 2 sqrt(P R*/(pi E*))`` (contact half-width), ``p0 = 2P/(pi a)``
    (peak pressure). Returns ``{"a": a, "p0": p0}``.
    """
    a = 2.0 * math.sqrt(P * R_star / (math.pi * E_star))
    return {"a": a, "p0": 2.0 * P / (math.pi * a)}


def hertz2d_pressure(x, P: float, R_star: float, E_star: float):
    """Hertz line-contact pressure ``p(x) = p0 sqrt(1 - x^2/a^2)`` for |x| < a, 0 outside.

    ``x`` is the distance from the contact centre along the surface (array or scalar).
    """
    h = hertz2d(P, R_star, E_star)
    return _ellipse(x, h["a"], h["p0"])


def hertz3d(P: float, R_star: float, E_star: float) -> dict:
    """Hertz point contact of spheres, total load ``P``.

    ``a = (3 P R*/(4 E*))^(1/3)`` (contact radius), ``p0 = 3P/(2 pi a^2)`` (peak
    pressure), ``delta = a^2/R*`` (approach of distant points). Returns
    ``{"a": a, "p0": p0, "delta": delta}``.
    """
    a = (3.0 * P * R_star / (4.0 * E_star)) ** (1.0 / 3.0)
    return {"a": a, "p0": 3.0 * P / (2.0 * math.pi * a**2), "delta": a**2 / R_star}


def hertz3d_pressure(r, P: float, R_star: float, E_star: float):
    """Hertz point-contact pressure ``p(r) = p0 sqrt(1 - r^2/a^2)`` for r < a, 0 outside."""
    h = hertz3d(P, R_star, E_star)
    return _ellipse(r, h["a"], h["p0"])


def _ellipse(x, a: float, p0: float):
    """``p0 sqrt(1 - x^2/a^2)`` for |x| < a, else 0 (scalar in, scalar out)."""
    x = np.asarray(x, dtype=float)
    out = p0 * np.sqrt(np.clip(1.0 - (x / a) ** 2, 0.0, None)) if a > 0 else np.zeros_like(x)
    return out[()] if out.ndim == 0 else out


# ---------------------------------------------------------------------------
# Cattaneo-Mindlin partial slip
# ---------------------------------------------------------------------------


def _slip_fraction(P: float, Q: float, mu: float) -> float:
    """``|Q|/(mu P)``, checked to lie in [0, 1]."""
    if P <= 0.0:
        raise ValueError("the normal load P must be positive")
    if Q == 0.0:
        return 0.0
    if mu <= 0.0 or abs(Q) > mu * P * (1.0 + 1e-12):
        raise ValueError(f"|Q| = {abs(Q)} exceeds mu P = {mu * P}: gross sliding")
    return min(abs(Q) / (mu * P), 1.0)


def cattaneo_mindlin2d_stick(P: float, Q: float, mu: float, R_star: float, E_star: float):
    """Stick zone of a 2D (line) Cattaneo-Mindlin contact.

    Same material on both sides, constant ``P``, tangential force ``Q`` rising
    monotonically from 0 with ``|Q| <= mu P``: ``c/a = sqrt(1 - |Q|/(mu P))``.
    Returns ``{"a": a, "p0": p0, "c": c}`` (``a``, ``p0`` from :func:`hertz2d`).
    """
    h = hertz2d(P, R_star, E_star)
    c = h["a"] * math.sqrt(1.0 - _slip_fraction(P, Q, mu))
    return {"a": h["a"], "p0": h["p0"], "c": c}


def cattaneo_mindlin2d(x, P: float, Q: float, mu: float, R_star: float, E_star: float):
    """Tangential traction ``q(x)`` of a 2D Cattaneo-Mindlin contact.

    ``q(x) = mu p0 [sqrt(1 - x^2/a^2) - (c/a) sqrt(1 - x^2/c^2)]`` for |x| <= c
    (stick), ``q(x) = mu p(x)`` for c <= |x| <= a (slip), 0 outside; with ``a``,
    ``p0`` of :func:`hertz2d` and ``c`` of :func:`cattaneo_mindlin2d_stick`.
    ``q`` has the sign of ``Q``; its integral over x is ``Q``.
    """
    s = cattaneo_mindlin2d_stick(P, Q, mu, R_star, E_star)
    return _cm_traction(x, s["a"], s["c"], mu * s["p0"], Q)


def mindlin_deresiewicz2d(
    x,
    P: float,
    Q_star: float,
    Q: float,
    mu: float,
    R_star: float,
    E_star: float,
    Q_min: float | None = None,
):
    """Tangential traction ``q(x)`` of a 2D (line) contact unloaded after Cattaneo-Mindlin
    loading, and reloaded (Mindlin & Deresiewicz 1953; Johnson, Contact Mechanics, 1985,
    section 7.2).

    Same material on both sides (no normal-tangential coupling), constant ``P``; the
    tangential force rose monotonically from 0 to ``Q_star`` (``|Q_star| <= mu P``), then
    went back monotonically to ``Q`` (unloading, ``Q_min = None``), or back to ``Q_min``
    and up again to ``Q`` (reloading). Signs: ``Q``, ``Q_min`` as ``Q_star``'s with
    ``-|Q_star| <= Q <= |Q_star|``; reloading needs ``Q`` between ``Q_min`` and
    ``Q_star``. Every change of the force direction is superposed on the state before it
    as a Cattaneo solution with twice the friction coefficient (the traction changes by
    up to 2 mu p where the slip reverses), for the force change ``dQ``::

        q_2mu(x; dQ) = 2 mu (p0/a) [sqrt(a^2 - x^2) - sqrt(c_d^2 - x^2) 1{|x| < c_d}] sign(dQ),
        (c_d/a)^2 = 1 - |dQ|/(2 mu P)

    so that unloading gives ``q = q*(x) + q_2mu(x; Q - Q_star)``, with ``q*`` of
    :func:`cattaneo_mindlin2d` at ``Q_star`` and the new stick zone ``|x| < c'``,
    ``(c'/a)^2 = 1 - (Q_star - Q)/(2 mu P)`` (reverse slip, ``q = -mu p`` for the load's
    sign, between ``c'`` and ``a``); reloading adds ``q_2mu(x; Q - Q_min)`` to the state
    at ``Q_min``. Each term integrates to its force change, so ``∫ q dx = Q``; ``Q = Q_star``
    gives ``q*``, ``Q = -Q_star`` gives ``-q*``. ``x``: distance from the contact centre
    (array or scalar); ``a``, ``p0`` of :func:`hertz2d`. Returns q with x's shape (force
    per unit area, the sign of the force).

    Raises ValueError where the history leaves that range (gross slip, or a reload past
    ``Q_star``, where the memory of the loop is erased and the virgin curve holds).
    """
    h = hertz2d(P, R_star, E_star)
    a, q0 = h["a"], mu * h["p0"]
    sgn, qs, qq, qm = _md_frame(P, Q_star, Q, mu, Q_min)  # the loading direction's frame

    def step(dq):  # q_2mu(x; dq): the Cattaneo solution of dq with 2 mu
        f = min(abs(dq) / (2.0 * mu * P), 1.0)
        c = a * math.sqrt(1.0 - f)
        return 2.0 * _cm_traction(x, a, c, q0, dq)

    q = _cm_traction(x, a, a * math.sqrt(1.0 - min(qs / (mu * P), 1.0)), q0, qs)
    if qm is None:
        q = q + step(qq - qs)
    else:
        q = q + step(qm - qs) + step(qq - qm)
    q = sgn * np.asarray(q)
    return q[()] if q.ndim == 0 else q


def cattaneo_mindlin3d(P: float, Q: float, mu: float) -> float:
    """Stick ratio ``c/a = (1 - |Q|/(mu P))^(1/3)`` of a 3D (point) Cattaneo-Mindlin contact."""
    return (1.0 - _slip_fraction(P, Q, mu)) ** (1.0 / 3.0)


def cattaneo_mindlin3d_traction(r, P: float, Q: float, mu: float, R_star: float, E_star: float):
    """Tangential traction ``q(r)`` of a 3D Cattaneo-Mindlin contact.

    ``q(r) = mu p0 [sqrt(1 - r^2/a^2) - (c/a) sqrt(1 - r^2/c^2)]`` for r <= c,
    ``mu p(r)`` for c <= r <= a, 0 outside, with ``a``, ``p0`` of :func:`hertz3d`
    and ``c/a`` of :func:`cattaneo_mindlin3d`; it integrates over the disc to ``Q``.
    """
    h = hertz3d(P, R_star, E_star)
    c = h["a"] * cattaneo_mindlin3d(P, Q, mu)
    return _cm_traction(r, h["a"], c, mu * h["p0"], Q)


def _cm_traction(x, a: float, c: float, q0: float, Q: float):
    x = np.asarray(x, dtype=float)
    q = _ellipse(x, a, q0) - (c / a) * _ellipse(x, c, q0) if c > 0 else _ellipse(x, a, q0)
    q = np.asarray(q) * (1.0 if Q >= 0 else -1.0)
    return q[()] if q.ndim == 0 else q


# ---------------------------------------------------------------------------
# Mindlin-Deresiewicz: a tangential cycle of a point contact
# ---------------------------------------------------------------------------


def tangential_compliance(
    E1: float, nu1: float, E2: float | None = None, nu2: float | None = None
) -> float:
    """The tangential compliance sum ``Λ = (2 - nu1)/G1 + (2 - nu2)/G2``, ``G = E/(2(1 + nu))``
    (Johnson, Contact Mechanics, 1985, eq. 7.42; units 1/modulus).

    Arguments as :func:`effective_modulus`'s: ``E2 = None`` (default) is the same material
    as the first body, ``E2 = inf`` a rigid second body (its term 0). Identical materials:
    ``Λ = 2(2 - nu)/G``. A Hertz contact of radius ``a`` under a small tangential force has
    the tangential compliance ``dδ/dQ = Λ/(8a)`` (Mindlin 1949).
    """
    if E2 is None:
        E2 = E1
        nu2 = nu1 if nu2 is None else nu2
    elif nu2 is None:
        nu2 = nu1
    if E1 <= 0.0 or E2 <= 0.0:
        raise ValueError("Young's moduli must be positive")

    def term(E, nu):
        return 0.0 if math.isinf(E) else (2.0 - nu) * 2.0 * (1.0 + nu) / E

    return term(E1, nu1) + term(E2, nu2)


def _g23(x: float) -> float:
    """``1 - (1 - x)^(2/3)`` for x in [0, 1] (clipped)."""
    return 1.0 - (1.0 - min(max(x, 0.0), 1.0)) ** (2.0 / 3.0)


def _shift_scale(P: float, mu: float, R_star: float, E_star: float, compliance: float) -> float:
    """``K0 = 3 mu P Λ/(16 a)``, the shift at gross slip (Q = mu P) of a virgin loading."""
    a = hertz3d(P, R_star, E_star)["a"]
    return 3.0 * mu * P * compliance / (16.0 * a)


def cattaneo_mindlin3d_shift(
    P: float, Q: float, mu: float, R_star: float, E_star: float, compliance: float
) -> float:
    """Tangential shift ``δ`` of distant points of a 3D (point) Cattaneo-Mindlin contact
    (Mindlin 1949; Johnson, Contact Mechanics, 1985, eq. 7.42)::

        δ = (3 mu P Λ/(16 a)) [1 - (1 - |Q|/(mu P))^(2/3)] sign(Q)

    Constant ``P``, ``Q`` rising monotonically from 0 with ``|Q| <= mu P`` (the virgin
    curve); ``a`` of :func:`hertz3d`, ``Λ = compliance`` of :func:`tangential_compliance`.
    Mindlin's approximation (the traction parallel to the force; exact for nu = 0). The
    shift of the contact alone: a body's own elastic compliance away from the contact adds
    ``C_b Q``. Returns δ in length units, the sign of ``Q``.
    """
    f = _slip_fraction(P, Q, mu)
    d = _shift_scale(P, mu, R_star, E_star, compliance) * _g23(f)
    return d if Q >= 0 else -d


def _md_frame(P: float, Q_star: float, Q: float, mu: float, Q_min: float | None):
    """Checks of a Mindlin-Deresiewicz history (line and point contact: ValueError for a
    ``Q_star`` beyond gross slip, a ``Q_min`` outside [-|Q_star|, |Q_star|], a ``Q`` outside
    the loop) and its forces in the loading direction's frame, where Q_star >= 0:
    (sgn, Q*, Q, Q_min or None)."""
    _slip_fraction(P, Q_star, mu)
    tol = 1e-12 * mu * P
    sgn = 1.0 if Q_star >= 0 else -1.0
    qs, qq = sgn * Q_star, sgn * Q
    qm = None if Q_min is None else sgn * Q_min
    low = -qs if qm is None else qm
    if qm is not None and not (-qs - tol <= qm <= qs + tol):
        raise ValueError(f"Q_min = {Q_min} lies outside [-|Q_star|, |Q_star|] = [{-qs}, {qs}]")
    if not (low - tol <= qq <= qs + tol):
        raise ValueError(f"Q = {Q} lies outside the loop [{sgn * low}, {Q_star}]")
    return sgn, qs, qq, qm


def mindlin_deresiewicz3d_stick(
    P: float, Q_star: float, Q: float, mu: float, Q_min: float | None = None
) -> float:
    """Stick ratio ``c'/a`` of a 3D (point) contact unloaded after Cattaneo-Mindlin loading
    to ``Q_star``, or reloaded from ``Q_min`` (Mindlin & Deresiewicz 1953; Johnson,
    Contact Mechanics, 1985, eq. 7.46)::

        (c'/a)^3 = 1 - |Q - Q_rev|/(2 mu P),   Q_rev = Q_star (unloading) or Q_min (reloading)

    The slip since the last reversal of the force lies in the annulus c' < r < a; c' = a
    at the reversal, c' = c of :func:`cattaneo_mindlin3d` at ``Q_star`` when the unloading
    reaches ``Q = -Q_star``. Arguments, signs and ranges as :func:`mindlin_deresiewicz3d`'s
    (ValueError outside the loop).
    """
    _, qs, qq, qm = _md_frame(P, Q_star, Q, mu, Q_min)
    rev = qs if qm is None else qm
    return (1.0 - min(abs(qq - rev) / (2.0 * mu * P), 1.0)) ** (1.0 / 3.0)


def mindlin_deresiewicz3d(
    r,
    P: float,
    Q_star: float,
    Q: float,
    mu: float,
    R_star: float,
    E_star: float,
    Q_min: float | None = None,
):
    """Tangential traction ``q(r)`` of a 3D (point) contact unloaded after Cattaneo-Mindlin
    loading, and reloaded (Mindlin & Deresiewicz 1953; Johnson, Contact Mechanics, 1985,
    section 7.2, eqs. 7.45-7.47; Mindlin's approximation: q parallel to the force).

    The point-contact form of :func:`mindlin_deresiewicz2d` (same material, constant ``P``,
    the same history, signs and ranges): each change of the force direction superposes a
    Cattaneo solution with twice the friction coefficient for the force change ``dQ``::

        q_2mu(r; dQ) = 2 mu (p0/a) [sqrt(a^2 - r^2) - sqrt(c_d^2 - r^2) 1{r < c_d}] sign(dQ),
        (c_d/a)^3 = 1 - |dQ|/(2 mu P)

    so that unloading gives ``q = q* + q_2mu(r; Q - Q_star)`` (``q*`` of
    :func:`cattaneo_mindlin3d_traction` at ``Q_star``; the new stick radius ``c'`` of
    :func:`mindlin_deresiewicz3d_stick`, reverse slip ``q = -mu p sign(Q_star)`` in
    ``c' < r < a``), reloading adds ``q_2mu(r; Q - Q_min)`` to the state at ``Q_min``.
    ``∫ q dA = Q`` over the disc; ``Q = -Q_star`` gives ``-q*``. ``r``: distance from the
    contact centre (array or scalar); ``a``, ``p0`` of :func:`hertz3d`. Returns q with
    r's shape (force per unit area, the sign of the force).

    Raises ValueError where the history leaves that range (gross slip, or a force past
    the loop, where the memory of the loop is erased and the virgin curve holds).
    """
    h = hertz3d(P, R_star, E_star)
    a, q0 = h["a"], mu * h["p0"]
    sgn, qs, qq, qm = _md_frame(P, Q_star, Q, mu, Q_min)

    def step(dq):  # q_2mu(r; dq): the Cattaneo solution of dq with 2 mu
        c = a * (1.0 - min(abs(dq) / (2.0 * mu * P), 1.0)) ** (1.0 / 3.0)
        return 2.0 * _cm_traction(r, a, c, q0, dq)

    q = _cm_traction(r, a, a * (1.0 - min(qs / (mu * P), 1.0)) ** (1.0 / 3.0), q0, qs)
    if qm is None:
        q = q + step(qq - qs)
    else:
        q = q + step(qm - qs) + step(qq - qm)
    q = sgn * np.asarray(q)
    return q[()] if q.ndim == 0 else q


def mindlin_deresiewicz3d_shift(
    P: float,
    Q_star: float,
    Q: float,
    mu: float,
    R_star: float,
    E_star: float,
    compliance: float,
    Q_min: float | None = None,
) -> float:
    """Tangential shift ``δ`` on the unloading and reloading branches of a 3D (point)
    contact's hysteresis loop (Mindlin & Deresiewicz 1953; Johnson, Contact Mechanics,
    1985, eqs. 7.48-7.49)::

        unloading from Q*:  δ = δ* - 2 K0 [1 - (1 - (Q* - Q)/(2 mu P))^(2/3)]
        reloading from Q_min: δ = δ_min + 2 K0 [1 - (1 - (Q - Q_min)/(2 mu P))^(2/3)]

    for ``Q_star > 0`` (mirrored for ``Q_star < 0``), with ``K0 = 3 mu P Λ/(16 a)``,
    ``δ* = δ(Q*)`` of :func:`cattaneo_mindlin3d_shift` and ``δ_min`` the unloading
    branch's at ``Q_min``: each branch is the virgin curve scaled by 2 in force and shift
    (Masing's rule). ``Q = Q*`` gives δ*, ``Q = -Q*`` gives ``-δ*``; with ``Q_min = -Q*``
    the reloading branch is the unloading one mirrored. Arguments, signs and ranges as
    :func:`mindlin_deresiewicz3d`'s; ``compliance`` ``Λ`` of
    :func:`tangential_compliance`. Returns δ (length units); ValueError outside the loop.
    """
    sgn, qs, qq, qm = _md_frame(P, Q_star, Q, mu, Q_min)
    k0 = _shift_scale(P, mu, R_star, E_star, compliance)
    d = k0 * _g23(qs / (mu * P))
    if qm is not None:
        d -= 2.0 * k0 * _g23((qs - qm) / (2.0 * mu * P))
        d += 2.0 * k0 * _g23((qq - qm) / (2.0 * mu * P))
    else:
        d -= 2.0 * k0 * _g23((qs - qq) / (2.0 * mu * P))
    return sgn * d


def mindlin_deresiewicz3d_energy(
    P: float, Q_star: float, mu: float, R_star: float, E_star: float, compliance: float
) -> float:
    """Frictional energy dissipated per cycle of the tangential force between ``-Q_star``
    and ``Q_star`` at constant ``P`` (the area of the δ(Q) loop of
    :func:`mindlin_deresiewicz3d_shift`; Mindlin & Deresiewicz 1953, Johnson, Contact
    Mechanics, 1985, eq. 7.50, with X = |Q_star|/(mu P))::

        ΔW = (9 mu^2 P^2 Λ/(10 a)) [1 - (1 - X)^(5/3) - (5X/6)(1 + (1 - X)^(2/3))]

    ``a`` of :func:`hertz3d`, ``Λ = compliance`` of :func:`tangential_compliance`
    (identical materials: ``9 mu^2 P^2 (2 - nu)/(5 G a)``). Small amplitudes:
    ``ΔW ≈ Λ |Q*|^3/(36 mu P a)``; gross slip (X = 1): ``3 mu^2 P^2 Λ/(20 a)``.
    Energy units (force × length).
    """
    x = _slip_fraction(P, Q_star, mu)
    a = hertz3d(P, R_star, E_star)["a"]
    y = 1.0 - x
    bracket = 1.0 - y ** (5.0 / 3.0) - (5.0 * x / 6.0) * (1.0 + y ** (2.0 / 3.0))
    return 9.0 * mu**2 * P**2 * compliance / (10.0 * a) * max(bracket, 0.0)


# ---------------------------------------------------------------------------
# Torsion, wedge
# ---------------------------------------------------------------------------


def torsion_full_slip(mu: float, P: float, a: float) -> float:
    """Torque of a Hertz point contact sliding everywhere in torsion:
    ``M = (3 pi/16) mu P a`` (integral of ``mu p(r) r`` over the disc of radius ``a``)."""
    return 3.0 * math.pi / 16.0 * mu * P * a


def wedge_slip_ratio(tan_alpha: float, mu: float) -> float:
    """Horizontal-to-vertical force ratio at gross slip of a block pushed up a wedge:
    ``F_x/F_y = (tan alpha + mu)/(1 - mu tan alpha)``.

    Infinite when ``mu tan alpha >= 1`` (self-locking: no horizontal push makes
    the block slide up).
    """
    den = 1.0 - mu * tan_alpha
    return math.inf if den <= 0.0 else (tan_alpha + mu) / den
