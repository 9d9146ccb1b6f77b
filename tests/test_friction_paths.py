"""3D Coulomb friction along a path whose slip direction turns (BENCHMARKS §54).

The scene is ``bench/bench_turning_slip.py``'s, small: a hexahedral block (2 × 2 slave
facets, linear elastic, E = 100, ν = 0) pressed with p0 = 2 onto a rigid one, then its
top led once around a circle of radius 0.3 in 8 steps (μ = 0.3, segment integration).
Side tractions make the stress state uniform, so that the discrete answer is exact, and
the reference is computed here from the path alone. (The side tractions are the exact
τ's, from the bench's copy of the fixed point; their net force is zero on each pair of
opposite sides, so the contact force is not imposed by them but balanced by the drive's
reaction on ``upper_top``.)"""

from __future__ import annotations

import importlib.util
import pathlib

import numpy as np
import pytest
from mpi4py import MPI

from dolfinx_mortar.runner import run
from dolfinx_mortar.scene import parse_scene

BENCH = pathlib.Path(__file__).resolve().parents[1] / "bench" / "bench_turning_slip.py"
MU, P0, E, H, R, N = 0.3, 2.0, 100.0, 0.5, 0.3, 8


def _bench():
    spec = importlib.util.spec_from_file_location("bench_turning_slip", BENCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _reference():
    """The top's positions (N + 1, 2) and the exact slip directions (N, 2) of the steps:
    backward Euler on a uniform state, Δs_k = Δu_k − c (d_k − d_{k−1}), d_k = Δs_k/|Δs_k|,
    c = μ p0 H / G the elastic shear offset of the top (G = E/2 at ν = 0), d_0 = 0."""
    th = np.linspace(0.0, 2.0 * np.pi, N + 1)
    P = np.c_[R * (np.cos(th) - 1.0), R * np.sin(th)]
    c = MU * P0 * H / (E / 2.0)
    d, prev = [], np.zeros(2)
    for du in np.diff(P, axis=0):
        dk = du / np.linalg.norm(du)
        for _ in range(100):  # a contraction with factor ~ c/|Δu| = 0.026
            dk = du - c * (dk - prev)
            dk /= np.linalg.norm(dk)
        d.append(dk)
        prev = dk
    return P, np.array(d)


def _turning_circle(out, comm):
    """Run the circle; returns the summary's steps and, per step, the slave nodes' p_N and
    (τ_x, τ_y) (n, 3) from rank 0's CSV (collective)."""
    bench = _bench()
    P, d = _reference()
    assert np.allclose(bench.top_path("circle", N, R), P, rtol=0, atol=1e-15)
    data = bench.scene(P, mu=MU, p0=P0, E=E, n_upper=2, n_lower=3, n_y=1)
    data["output"] = {**data.get("output", {}), "fields": []}  # the checks read the CSVs
    summary = run(parse_scene(data, out), comm, out_dir=out)
    assert summary["status"] == "ok", summary.get("error")
    steps = summary["steps"]
    assert [s["t"] for s in steps] == [float(k) for k in range(1, N + 2)]
    assert all(s["cutbacks"] == 0 for s in steps)
    tabs = [bench.node_tractions(out, k + 1, comm) for k in range(len(steps))]
    return steps, tabs


def _angle(a, b):
    return np.arctan2(b[0] * a[1] - b[1] * a[0], a @ b)


def _check(steps, tabs):
    P, d = _reference()
    key = "upper_bottom:lower_top"
    F0 = np.array(steps[0]["contact_force"][key])  # the press: F = (0, 0, p0 L²)
    assert np.allclose(F0, [0.0, 0.0, P0], rtol=0, atol=1e-9)
    W = Wd = 0.0
    for k, (st, tab) in enumerate(zip(steps[1:], tabs[1:], strict=True)):
        F = np.array(st["contact_force"][key])
        assert abs(F[2] - P0) <= 1e-9 * P0, (k, F)
        assert abs(np.hypot(F[0], F[1]) / (MU * F[2]) - 1.0) <= 1e-8, (k, F)
        # the friction force on the slave opposes the slip direction
        assert abs(_angle(-F[:2], d[k])) <= 1e-7, (k, F, d[k])
        pn, tau = tab[:, 0], tab[:, 1:]
        assert len(pn) == 9 and np.all(pn > 0)
        assert np.abs(pn - P0).max() <= 1e-9 * P0
        assert np.abs(np.linalg.norm(tau, axis=1) - MU * pn).max() <= 1e-9 * MU * P0
        assert max(abs(_angle(-t, d[k])) for t in tau) <= 1e-7
        du = P[k + 1] - P[k]
        W += np.array(st["reactions"]["upper_top"][:2]) @ du
        Wd += MU * F[2] * d[k] @ du
        assert st["slip_nodes"] == 9 and st["stick_nodes"] == 0
    # d_k is not the chord: the elastic offset c d turns with it; the lag after the first
    # (straight) step settles geometrically at 1.0587° on this path
    lag = np.degrees([_angle(dk, du) for dk, du in zip(d, np.diff(P, axis=0), strict=True)])
    assert abs(lag[0]) < 1e-12 and np.all((-1.06 < lag[1:]) & (lag[1:] < -1.03)), lag
    # the work of the drive: μ F_N Σ d_k·Δu_k, less than μ F_N Σ|Δu_k|
    assert abs(W / Wd - 1.0) <= 1e-8, (W, Wd)
    assert W < MU * P0 * np.linalg.norm(np.diff(P, axis=0), axis=1).sum() * (1.0 - 1e-4)


@pytest.mark.mpi2
def test_a_turning_slip_follows_the_backward_euler_direction(shared_tmp):
    """Every slide step: all 9 nodes slip with |τ| = μ p_N (1e-9), |F_T| = μ F_N (1e-8),
    the force and every nodal traction along −d_k (1e-7 rad; d_k is 1.04–1.06° from the
    chord Δu_k), and the drive's work Σ R_top·Δu_top = μ F_N Σ d_k·Δu_k (1e-8). On 2 ranks
    only (``mpi2``, session 61: 4 s serially), against the reference above (not against a
    serial output)."""
    steps, tabs = _turning_circle(shared_tmp / "turning", MPI.COMM_WORLD)
    _check(steps, tabs)
