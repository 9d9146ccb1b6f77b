"""Penalties stiffer than "auto": above contact.SOFT_START_RATIO × auto each load step
starts with a solve under ε_soft = min(ε, ε_auto); the contact predictor uses ε_soft, and
the absolute Newton tolerance grows with ε/ε_auto (docs/method-notes.md, "Stiff
penalties")."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI
from test_contact_parallel import HERTZ2D

PAIR = "cylinder_surface:block_top"
#: E* of HERTZ2D's two bodies (E = 200, ν = 0.3, plane strain) and the auto penalty's
#: value at its contact size h = 0.25: 100 E*/h
E_STAR = 200.0 / (2.0 * (1.0 - 0.3**2))
EPS_AUTO = 100.0 * E_STAR / 0.25


def _scene(**contact) -> dict:
    pair = {**HERTZ2D["contact"][0], **contact}
    return {**HERTZ2D, "contact": [pair]}


def _run(data: dict, out_dir) -> dict:
    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    return run(parse_scene(data, out_dir), MPI.COMM_WORLD, out_dir=out_dir)


def _pressures(out_dir, step: int) -> np.ndarray:
    """p_N of the slave nodes at ``step``, sorted by reference x (rank 0 reads, all get)."""
    comm = MPI.COMM_WORLD
    p = None
    if comm.rank == 0:
        t = np.genfromtxt(
            out_dir / f"contact_cylinder_surface_{step}.csv", delimiter=",", names=True
        )
        p = t["p_N"][np.argsort(t["X"])]
    return comm.bcast(p, root=0)


@pytest.mark.mpi
def test_a_stiff_penalty_ends_where_the_auto_penalty_does(shared_tmp):
    """ε = 1e3 × the auto value with Uzawa to 1e-8, force control (the cylinder is held by
    contact only): every step completes without a cutback, starts with one soft solve,
    and ends with the nodal pressures and the contact force of the auto penalty (the
    Uzawa solution does not depend on ε). Without the soft start the same scene of the hard-case
    sweep stopped in its first step after 6 cutbacks (BENCHMARKS §10); 1–3 ranks."""
    auto = _run(_scene(), shared_tmp / "auto")
    stiff = _run(_scene(penalty=1e3 * EPS_AUTO), shared_tmp / "stiff")
    assert auto["status"] == "ok" and stiff["status"] == "ok", stiff.get("error")
    n = len(auto["steps"])
    assert len(stiff["steps"]) == n
    for sa, ss in zip(auto["steps"], stiff["steps"], strict=True):
        assert sa["soft_start_solves"] == 0
        assert ss["soft_start_solves"] == 1 and ss["cutbacks"] == 0
        assert ss["max_penetration"] <= 1e-12
        fa, fs = np.asarray(sa["contact_force"][PAIR]), np.asarray(ss["contact_force"][PAIR])
        assert np.linalg.norm(fs - fa) <= 1e-8 * np.linalg.norm(fa)
    p_a, p_s = _pressures(shared_tmp / "auto", n), _pressures(shared_tmp / "stiff", n)
    assert np.count_nonzero(p_a) >= 3
    assert np.max(np.abs(p_s - p_a)) <= 1e-6 * np.max(p_a)


@pytest.mark.parametrize("factor", [1e3, 1e4])
def test_a_stiff_pure_penalty_converges_to_its_own_penetration(tmp_path, factor):
    """Pure penalty (uzawa_tol = 0) with ε = 1e3 and 1e4 × auto: every step converges
    without a cutback; the penetration is p/ε, so it falls with ε (measured: the auto run's
    / 960 and / 9600; the auto ε varies with h_I, the stiff one does not), and the contact
    force carries the applied load."""
    runs = {}
    for name, eps in (("auto", "auto"), ("stiff", factor * EPS_AUTO)):
        runs[name] = _run(_scene(penalty=eps, uzawa_tol=0.0), tmp_path / name)
        assert runs[name]["status"] == "ok", runs[name].get("error")
    last = {k: r["steps"][-1] for k, r in runs.items()}
    assert all(st["cutbacks"] == 0 for st in runs["stiff"]["steps"])
    pen = {k: st["max_penetration"] for k, st in last.items()}
    assert pen["stiff"] == pytest.approx(pen["auto"] / factor, rel=0.2)
    fy = abs(last["stiff"]["contact_force"][PAIR][1])
    assert fy == pytest.approx(abs(last["auto"]["contact_force"][PAIR][1]), rel=1e-6)


def test_soft_penalties_restore_the_own_penalty(tmp_path):
    """round_off_scale is max ε / max ε_auto (1 for the auto penalty, also where its
    nodewise values differ); above SOFT_START_RATIO × auto the pair starts its steps
    soft: ContactProblem.soft_penalties swaps ε_soft in and restores the pair's own ε on
    exit, also when the block raises, with round_off_scale 1 inside."""
    from dolfinx_mortar.contact import SOFT_START_RATIO
    from dolfinx_mortar.runner import prepare
    from dolfinx_mortar.scene import parse_scene

    assert SOFT_START_RATIO == 100.0
    for factor in (None, 50.0, 500.0):
        penalty = "auto" if factor is None else factor * EPS_AUTO
        problem, _ = prepare(parse_scene(_scene(penalty=penalty), tmp_path), MPI.COMM_WORLD)
        (term,) = problem.contacts
        own = term.eps
        if factor is None:
            assert np.ptp(own) > 0.0  # h_I varies along the slave surface
            assert problem.round_off_scale == 1.0 and not problem.soft_start
            continue
        # the mesh's smallest slave facets are a little below h = 0.25
        assert 0.9 * factor <= term.penalty_ratio <= factor * (1.0 + 1e-12)
        assert problem.round_off_scale == pytest.approx(term.penalty_ratio)
        assert problem.soft_start is (factor > SOFT_START_RATIO)
        if not problem.soft_start:
            continue
        with pytest.raises(RuntimeError, match="inside"):
            with problem.soft_penalties():
                assert np.all(term.eps <= own) and np.all(term.eps == term.eps_soft)
                assert problem.round_off_scale == 1.0
                raise RuntimeError("inside")
        assert term.eps is own
        assert problem.round_off_scale == pytest.approx(term.penalty_ratio)
