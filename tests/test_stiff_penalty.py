"""Penalties stiffer than "auto": above contact.SOFT_START_RATIO × auto each load step
starts with a solve under ε_soft = min(ε, ε_auto); the contact predictor uses ε_soft, and
the absolute Newton tolerance grows with ε/ε_auto (docs/method-notes.md, "Stiff
penalties")."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
from _logs import warnings_of
from mpi4py import MPI
from test_contact_parallel import HERTZ2D

PAIR = "cylinder_surface:block_top"
#: serially and on 2 ranks, not on 3 (``mpi_not3``, session 61: the 2-core budget; on 3
#: ranks test_contact_parallel compares such runs with serial ones to 1e-8)
pytestmark = pytest.mark.mpi_not3
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
    """p_N of the slave nodes at ``step``, sorted by reference x (every rank)."""
    from test_uzawa import _node_table

    t = _node_table(out_dir, step)
    return t["p_N"][np.argsort(t["X"])]


# Runs that several tests compare with, made once per module (session 60: the unit
# HERTZ2D run was made by 5 tests, the others by 2 each; each test reads the summary only).
@pytest.fixture(scope="module")
def module_tmp(tmp_path_factory):
    """A directory of this module with the same path on every rank (collective)."""
    comm = MPI.COMM_WORLD
    path = str(tmp_path_factory.mktemp("stiff_penalty")) if comm.rank == 0 else None
    return Path(comm.bcast(path, root=0))


@pytest.fixture(scope="module")
def unit2d(module_tmp):
    """HERTZ2D with the auto penalty and Uzawa to 1e-8: (output directory, summary)."""
    out = module_tmp / "auto"
    return out, _run(_scene(), out)


@pytest.fixture(scope="module")
def pure_penalty_auto(module_tmp):
    """HERTZ2D with the auto penalty as pure penalty (uzawa_tol = 0): the summary."""
    return _run(_scene(penalty="auto", uzawa_tol=0.0), module_tmp / "pure_auto")


@pytest.fixture(scope="module")
def unit3d(module_tmp):
    """HERTZ3D (the auto penalty): the summary."""
    from test_contact_parallel import HERTZ3D

    return _run(HERTZ3D, module_tmp / "unit3d")


@pytest.fixture(scope="module")
def small_auto(module_tmp):
    """HERTZ2D with E and the load times 1e-9 and the default atol ("auto"): the summary
    and the WARNING messages the run logged."""
    return warnings_of(_run, _scaled(1e-9), module_tmp / "scaled_small_auto")


@pytest.mark.mpi
def test_a_stiff_penalty_ends_where_the_auto_penalty_does(shared_tmp, unit2d):
    """ε = 1e3 × the auto value with Uzawa to 1e-8, force control (the cylinder is held by
    contact only): every step completes without a cutback, goes through its Uzawa rounds
    under ε_soft first (their entries marked ``soft_penalty``), then with ε in at most 2
    Newton iterations, and ends with the nodal pressures and the contact force of the auto
    penalty (the Uzawa solution does not depend on ε). Without the soft pass the same
    scene of the hard-case sweep stopped in its first step after 6 cutbacks (BENCHMARKS
    §10). Serially and on 2 ranks (``pytestmark``)."""
    auto_dir, auto = unit2d
    stiff = _run(_scene(penalty=1e3 * EPS_AUTO), shared_tmp / "stiff")
    assert auto["status"] == "ok" and stiff["status"] == "ok", stiff.get("error")
    n = len(auto["steps"])
    assert len(stiff["steps"]) == n
    for sa, ss in zip(auto["steps"], stiff["steps"], strict=True):
        assert not any("soft_penalty" in r[PAIR] for r in sa["uzawa"])
        soft = [bool(r[PAIR].get("soft_penalty")) for r in ss["uzawa"]]
        k = soft.index(False)  # the soft rounds come first
        assert k >= 1 and not any(soft[k:]), soft
        assert sum(ss["newton_iterations"][k:]) <= 2 and ss["cutbacks"] == 0
        assert ss["max_penetration"] <= 1e-12
        fa, fs = np.asarray(sa["contact_force"][PAIR]), np.asarray(ss["contact_force"][PAIR])
        assert np.linalg.norm(fs - fa) <= 1e-8 * np.linalg.norm(fa)
    p_a, p_s = _pressures(auto_dir, n), _pressures(shared_tmp / "stiff", n)
    assert np.count_nonzero(p_a) >= 3
    assert np.max(np.abs(p_s - p_a)) <= 1e-6 * np.max(p_a)


@pytest.mark.parametrize("factor", [1e3, 1e4])
def test_a_stiff_pure_penalty_converges_to_its_own_penetration(tmp_path, pure_penalty_auto, factor):
    """Pure penalty (uzawa_tol = 0) with ε = 1e3 and 1e4 × auto: every step converges
    without a cutback; the penetration is p/ε, so it falls with ε (measured: the auto run's
    / 960 and / 9600; the auto ε varies with h_I, the stiff one does not), and the contact
    force carries the applied load."""
    runs = {"auto": pure_penalty_auto}
    runs["stiff"] = _run(_scene(penalty=factor * EPS_AUTO, uzawa_tol=0.0), tmp_path / "stiff")
    for run in runs.values():
        assert run["status"] == "ok", run.get("error")
    last = {k: r["steps"][-1] for k, r in runs.items()}
    assert all(st["cutbacks"] == 0 for st in runs["stiff"]["steps"])
    pen = {k: st["max_penetration"] for k, st in last.items()}
    assert pen["stiff"] == pytest.approx(pen["auto"] / factor, rel=0.2)
    fy = abs(last["stiff"]["contact_force"][PAIR][1])
    assert fy == pytest.approx(abs(last["auto"]["contact_force"][PAIR][1]), rel=1e-6)


def test_soft_penalties_restore_the_own_penalty(tmp_path):
    """round_off_scale is max ε / max ε_auto (1 for the auto penalty, also where its
    nodewise values differ); a stiff pair starts its steps soft with Uzawa at any ratio,
    as pure penalty above SOFT_START_RATIO; ContactProblem.soft_penalties swaps ε_soft in
    and restores the pair's own ε on exit, also when the block raises, with
    round_off_scale 1 inside."""
    from dolfinx_mortar.contact import SOFT_START_RATIO
    from dolfinx_mortar.runner import prepare
    from dolfinx_mortar.scene import parse_scene

    assert SOFT_START_RATIO == 100.0
    cases = [(None, 1e-8), (50.0, 1e-8), (50.0, 0.0), (500.0, 0.0)]
    for factor, uzawa_tol in cases:
        penalty = "auto" if factor is None else factor * EPS_AUTO
        data = _scene(penalty=penalty, uzawa_tol=uzawa_tol)
        problem, _ = prepare(parse_scene(data, tmp_path), MPI.COMM_WORLD)
        (term,) = problem.contacts
        own = term.eps
        if factor is None:
            assert np.ptp(own) > 0.0  # h_I varies along the slave surface
            assert problem.round_off_scale == 1.0 and not problem.soft_start
            continue
        # the mesh's smallest slave facets are a little below h = 0.25
        assert 0.9 * factor <= term.penalty_ratio <= factor * (1.0 + 1e-12)
        assert problem.round_off_scale == pytest.approx(term.penalty_ratio)
        assert problem.soft_start is (uzawa_tol > 0.0 or factor > SOFT_START_RATIO)
        if not problem.soft_start:
            continue
        with pytest.raises(RuntimeError, match="inside"):
            with problem.soft_penalties() as names:
                assert names == [term.name]
                assert np.all(term.eps <= own) and np.all(term.eps == term.eps_soft)
                assert problem.round_off_scale == 1.0
                raise RuntimeError("inside")
        assert term.eps is own
        assert problem.round_off_scale == pytest.approx(term.penalty_ratio)


def test_stiff_normal_and_tangential_penalties_with_friction(tmp_path):
    """The coarse Cattaneo press and shift (μ = 0.2, Uzawa to 1e-8) with ε = ε_T = 1e3 ×
    the auto normal value: the soft pass carries the friction too (ε_T,soft), so both
    steps complete without a cutback and end with the auto run's contact force (measured
    5.7e-10 relative). Peers problem B with such penalties stopped in its shift step after
    6 cutbacks while only the first solve was soft (docs/method-notes.md, "Stiff
    penalties")."""
    from test_uzawa import _coarse_cattaneo

    eps = 1e3 * 100.0 * E_STAR / 0.1  # the scene's contact size is h = 0.1
    runs = {}
    for name, pen in (("auto", None), ("stiff", eps)):
        data = _coarse_cattaneo("auto")
        if pen is not None:
            data["contact"][0].update(penalty=pen, penalty_tangential=pen)
        runs[name] = _run(data, tmp_path / name)
        assert runs[name]["status"] == "ok", runs[name].get("error")
    assert all(st["cutbacks"] == 0 for st in runs["stiff"]["steps"])
    (fa,) = runs["auto"]["steps"][-1]["contact_force"].values()
    (fs,) = runs["stiff"]["steps"][-1]["contact_force"].values()
    assert np.max(np.abs(np.subtract(fs, fa))) <= 1e-7 * np.max(np.abs(fa))
    assert abs(fa[0]) > 0.05 * abs(fa[1])  # the shift carries a tangential force


def test_a_stiff_penalty_in_3d(tmp_path, unit3d):
    """The coarse quarter-model 3D Hertz (segment integration, force control) with ε = 1e3
    × auto and Uzawa to 1e-8 ends with the auto run's contact force; the second pass of
    each step takes at most 2 Newton iterations (measured: 1)."""
    from test_contact_parallel import HERTZ3D

    eps = 1e3 * 100.0 * E_STAR / 0.5  # the scene's contact size is h = 0.5
    assert "penalty" not in HERTZ3D["contact"][0]  # unit3d: the auto penalty
    data = {**HERTZ3D, "contact": [{**HERTZ3D["contact"][0], "penalty": eps}]}
    runs = {"auto": unit3d, "stiff": _run(data, tmp_path / "stiff")}
    for run in runs.values():
        assert run["status"] == "ok", run.get("error")
    pair = "sphere_surface:block_top"
    st = runs["stiff"]["steps"][-1]
    soft = [bool(r[pair].get("soft_penalty")) for r in st["uzawa"]]
    k = soft.index(False)
    assert k >= 1 and sum(st["newton_iterations"][k:]) <= 2, (soft, st["newton_iterations"])
    fa = np.asarray(runs["auto"]["steps"][-1]["contact_force"][pair])
    fs = np.asarray(st["contact_force"][pair])
    assert np.linalg.norm(fs - fa) <= 1e-7 * np.linalg.norm(fa)


def _scaled(scale: float, atol: float | None = None) -> dict:
    """HERTZ2D with E and the load times ``scale``: the same strains and pressures / scale;
    ``atol``: the scene's [solver] atol (None: the scene's own)."""
    data = _scene()
    if atol is not None:
        data["solver"] = {**data.get("solver", {}), "atol": atol}
    data["material"] = [{**m, "E": m["E"] * scale} for m in data["material"]]
    data["traction"] = [
        {**t, "path": [[row[0]] + [v * scale for v in row[1:]] for row in t["path"]]}
        for t in data["traction"]
    ]
    return data


@pytest.mark.mpi
@pytest.mark.parametrize("scale", [1e6, 1e9])
def test_large_forces_converge_as_the_unit_ones(shared_tmp, unit2d, scale):
    """E and the load times 1e6 or 1e9 (E = 2e11: steel in SI units). The absolute
    tolerance 1e-10 is a force and lies below the residual's round-off level there
    (about 1e-4 at 1e9); the solver raises it to solver.ROUND_OFF_ATOL × the measured
    level. Before, a later Uzawa round hovered at 5 × that level until max_it, and the
    run failed after every cutback. The same iterations as the unit run, ± 1 per step,
    and the contact force / scale to 1e-9."""
    unit = unit2d[1]
    big = _run(_scaled(scale), shared_tmp / f"scaled_{scale:g}")
    assert big["status"] == "ok", big.get("error")
    for a, b in zip(unit["steps"], big["steps"], strict=True):
        assert b["cutbacks"] == 0
        assert abs(sum(a["newton_iterations"]) - sum(b["newton_iterations"])) <= 1
        fa, fb = np.asarray(a["contact_force"][PAIR]), np.asarray(b["contact_force"][PAIR])
        assert np.linalg.norm(fb / scale - fa) <= 1e-9 * np.linalg.norm(fa), (fa, fb / scale)


@pytest.mark.mpi
@pytest.mark.parametrize("atol", ["scaled", "auto"])
def test_small_forces_converge_as_the_unit_ones(shared_tmp, unit2d, request, atol):
    """E and the load times 1e-9, with ``atol`` times 1e-9 as well ("scaled") or the
    default "auto" (1e-10, never looser than rtol × the forces: solver.AUTO_ATOL; a fixed
    1e-10 stopped every solve early and the contact force was 6.5e-4 off). PETSc's "cp"
    line search (the energy line search of this symmetric problem) ended solves as
    converged when |<R, du>| < 1e-15 ||du||, an absolute force of its own
    (solver.LINE_SEARCH_ATOL): with the scaled atol the first round of step 2 stopped at
    3.5e-6 of its first norm, later Uzawa rounds took no Newton iteration, and the contact
    force was 8e-4 off. Now the unit run's Uzawa rounds, its Newton iterations ± 1 per
    step, and the contact force / scale to 1e-9."""
    scale = 1e-9
    unit = unit2d[1]
    if atol == "auto":  # the module's run, also read by the explicit-atol test
        small = request.getfixturevalue("small_auto")[0]
    else:
        small = _run(_scaled(scale, atol=1e-10 * scale), shared_tmp / f"scaled_small_{atol}")
    assert small["status"] == "ok", small.get("error")
    for a, b in zip(unit["steps"], small["steps"], strict=True):
        assert b["cutbacks"] == 0
        assert b["uzawa_rounds"] == a["uzawa_rounds"], (a["uzawa_rounds"], b["uzawa_rounds"])
        assert abs(sum(a["newton_iterations"]) - sum(b["newton_iterations"])) <= 1
        fa, fb = np.asarray(a["contact_force"][PAIR]), np.asarray(b["contact_force"][PAIR])
        assert np.linalg.norm(fb / scale - fa) <= 1e-9 * np.linalg.norm(fa), (fa, fb / scale)


def test_an_explicit_atol_looser_than_the_forces_is_warned(tmp_path, caplog, small_auto):
    """An explicit ``atol`` is used as given, with one warning where it is looser than
    rtol × the forces; the default "auto" is never looser, so it logs none (the run of
    test_small_forces_converge_as_the_unit_ones[auto], small_auto, with its warnings)."""
    with caplog.at_level(logging.WARNING, logger="dolfinx_mortar"):
        _run(_scaled(1e-9, atol=1e-10), tmp_path / "explicit")
    assert sum("exceeds rtol" in r.getMessage() for r in caplog.records) == 1
    summary, messages = small_auto
    assert summary["status"] == "ok", summary.get("error")
    assert not [m for m in messages if "exceeds rtol" in m]


@pytest.mark.mpi
def test_si_units_with_lengths_in_millimetres(shared_tmp, unit3d):
    """The coarse quarter-model 3D Hertz in SI units: every length times 1e-3 (R = 8 mm
    given as 0.008 m) and E and the traction times 1e9 (E = 2e11 Pa), so the forces are
    1e3 times the unit run's. The mesh generator sorted its faces with a tolerance below
    OpenCASCADE's 1e-7 box padding there (generators.OCC_BOX_PAD) and the run stopped on
    "mesh: KeyError: 'sphere_top'". Now the unit run's iterations ± 1 per step, its
    load × 1e3 to 1e-9 and its contact force × 1e3 to 1e-5."""
    from test_contact_parallel import HERTZ3D

    pair = "sphere_surface:block_top"
    length, stress = 1e-3, 1e9
    from dolfinx_mortar.generators import validate_params

    params = validate_params("hertz3d", HERTZ3D["mesh"]["params"])  # with the defaults
    lengths = ("R", "gap0", "W", "H", "c_zone", "h_contact", "h_far")
    mesh = {
        **HERTZ3D["mesh"],
        "params": {k: v * length if k in lengths else v for k, v in params.items()},
    }
    si = {
        **HERTZ3D,
        "mesh": mesh,
        "material": [{**m, "E": m["E"] * stress} for m in HERTZ3D["material"]],
        "traction": [
            {**t, "path": [[r[0]] + [v * stress for v in r[1:]] for r in t["path"]]}
            for t in HERTZ3D["traction"]
        ],
    }
    unit = unit3d
    run_si = _run(si, shared_tmp / "si3d")
    assert run_si["status"] == "ok", run_si.get("error")
    assert run_si["dofs"] == unit["dofs"], (run_si["dofs"], unit["dofs"])
    scale = stress * length**2
    for a, b in zip(unit["steps"], run_si["steps"], strict=True):
        assert abs(sum(a["newton_iterations"]) - sum(b["newton_iterations"])) <= 1
        fa, fb = np.asarray(a["contact_force"][pair]), np.asarray(b["contact_force"][pair])
        # the load (z) to 1e-9; the lateral components (the tilt of the deformed master,
        # carried by the symmetry planes) depend on the mesh, which gmsh does not make
        # scale-free to the node
        assert abs(fb[2] / scale - fa[2]) <= 1e-9 * abs(fa[2]), (fa, fb / scale)
        assert np.linalg.norm(fb / scale - fa) <= 1e-5 * np.linalg.norm(fa), (fa, fb / scale)


def _dragged_block(E: float) -> dict:
    """A 2D block (finite strain) pressed by 0.02, then dragged by 3.5 in one step, half
    off the end of the master (patch2d, 13 slave and 70 master facets): displacement
    driven, so the residual's Dirichlet rows carry the prescribed increments."""
    return {
        "kinematics": "finite",
        "mesh": {
            "generator": "patch2d",
            "params": {"n_lower": 70, "n_upper": 13, "n_y": 3, "margin": 3.0},
        },
        "material": [
            {"region": r, "model": "neo-hookean", "E": E, "nu": 0.3} for r in ("lower", "upper")
        ],
        "contact": [{"slave": "upper_bottom", "master": "lower_top"}],
        "dirichlet": [
            {"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]},
            {
                "boundary": "upper_top",
                "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.02], [2.0, 3.5, -0.02]],
            },
        ],
        "steps": {"t_end": 2.0, "n": 2},
    }


@pytest.mark.parametrize("scale", [1e-5, 1e6])
def test_a_displacement_driven_run_is_the_same_in_other_units(tmp_path, scale):
    """E times 1e-5 or 1e6 with the same prescribed displacements: the same problem in
    other units of stress. The rows of constrained dofs are scaled by a bulk stiffness
    (ContactProblem.dirichlet_scale), so every residual norm of a step's main solve is
    the unit run's × scale, with its Newton iterations, and the Uzawa rounds are the
    same (their later solves, which end at the absolute tolerance solver.AUTO_ATOL, a
    force, take 0–2 iterations more or fewer); the contact force / scale to 1e-7, the
    level of the Uzawa tolerance 1e-6 (measured 3e-8 at 1e-5).
    With unit rows (x − ū, a length) ‖R‖ mixed lengths with forces: E × 1e-5 took 11
    Newton iterations in a step that the unit run took in 7, and its force was 7e-9 off;
    a 3D slide in SI units took 31 where the unit run took 11 (BENCHMARKS §44)."""
    pair = "upper_bottom:lower_top"
    unit = _run(_dragged_block(100.0), tmp_path / "unit")
    other = _run(_dragged_block(100.0 * scale), tmp_path / "other")
    assert unit["status"] == other["status"] == "ok", (unit["error"], other["error"])
    for a, b in zip(unit["steps"], other["steps"], strict=True):
        assert b["newton_iterations"][0] == a["newton_iterations"][0]
        assert b["uzawa_rounds"] == a["uzawa_rounds"]
        ra, rb = np.asarray(a["residual_norms"][0]), np.asarray(b["residual_norms"][0])
        big = ra > 1e-6 * ra[0]  # above the round-off of either run
        assert np.allclose(rb[big] / scale, ra[big], rtol=1e-6, atol=0.0), (ra, rb / scale)
        fa, fb = np.asarray(a["contact_force"][pair]), np.asarray(b["contact_force"][pair])
        assert np.linalg.norm(fb / scale - fa) <= 1e-7 * np.linalg.norm(fa), (fa, fb / scale)
