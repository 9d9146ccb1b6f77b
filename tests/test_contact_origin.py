"""A model far from the origin runs as it does at the origin (the pair's origin, session 50).

The contact kernels work in current coordinates x = X + u; 1e4 from the origin their
round-off (eps·|x| ≈ 2e-12) was noise in the gaps that ε_N turned into forces of the size
of Newton's tolerance and Uzawa's multiplier changes: the frictional patch below stopped
("Uzawa augmentation stalled", multiplier changes 1, 0.97, 0.97, 0.94 after 6 cutbacks)
and the frictionless one too (changes of 5e-6 to 1.5e-5 against uzawa_tol = 1e-8). Each
pair now keeps its coordinates relative to an origin o near its slave surface
(:func:`dolfinx_mortar.surface.pair_origin`), and the frictional exact update's
difference step has a floor above the nodal law's round-off (uzawa.EXACT_FD_ROUND_OFF).
"""

from __future__ import annotations

import csv
import types

import numpy as np
import pytest
from conftest import written_once
from mpi4py import MPI

from dolfinx_mortar import contact
from dolfinx_mortar.runner import run
from dolfinx_mortar.scene import parse_scene
from dolfinx_mortar.surface import ORIGIN_NEAR, pair_origin

PAIR = "upper_bottom:lower_top"


def _write_patch(path, params: dict, shift) -> None:
    """The patch2d generator's mesh with every node moved by ``shift`` (rank 0)."""
    import gmsh

    from dolfinx_mortar import generators

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("patch")
    generators.build("patch2d", params)
    tags, coords, _ = gmsh.model.mesh.getNodes()
    for tag, x in zip(tags, coords.reshape(-1, 3), strict=True):
        gmsh.model.mesh.setNode(int(tag), [x[0] + shift[0], x[1] + shift[1], 0.0], [])
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(str(path))
    gmsh.finalize()


def _mesh(tmp, name: str, params: dict, shift) -> str:
    return str(written_once(tmp / f"{name}.msh", _write_patch, params, shift))


def _frictional(msh: str) -> dict:
    """Triangles, neo-Hookean, μ = 0.3: pressed by 0.01, then slid by 0.05 (4 steps)."""
    return {
        "kinematics": "finite",
        "mesh": {"file": msh},
        "material": [
            {"region": r, "model": "neo-hookean", "E": 100.0, "nu": 0.3} for r in ("lower", "upper")
        ],
        "contact": [{"slave": "upper_bottom", "master": "lower_top", "friction": 0.3}],
        "dirichlet": [
            {"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]},
            {
                "boundary": "upper_top",
                "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.01], [2.0, 0.05, -0.01]],
            },
        ],
        "steps": {"t_end": 2.0, "n": 4},
    }


def _frictionless(msh: str) -> dict:
    """Quadrilaterals, linear elastic, pressed by 0.01 in one step, Uzawa to 1e-8."""
    return {
        "kinematics": "small",
        "mesh": {"file": msh},
        "material": [
            {"region": r, "model": "linear-elastic", "E": 100.0, "nu": 0.3}
            for r in ("lower", "upper")
        ],
        "contact": [{"slave": "upper_bottom", "master": "lower_top", "uzawa_tol": 1e-8}],
        "dirichlet": [
            {"boundary": "lower_bottom", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]},
            {"boundary": "upper_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.01]]},
        ],
        "steps": {"n": 1},
    }


FRICTIONAL = {"quads": False, "n_lower": 5, "n_upper": 7, "n_y": 3}
FRICTIONLESS = {"quads": True, "n_lower": 5, "n_upper": 20, "n_y": 3}


def _run(data: dict, out) -> tuple[dict, np.ndarray]:
    """The summary and the pair's origin."""
    held = []
    summary = run(parse_scene(data, out), MPI.COMM_WORLD, out_dir=out, setup=held.append)
    origin = held[0].contacts[0].origin.copy()
    held[0].destroy()
    return summary, origin


def _table(out, step: int) -> np.ndarray:
    """The contact CSV of a step: columns x, y (reference), X, Y (current), p_N."""
    with open(out / f"contact_upper_bottom_{step}.csv") as f:
        rows = list(csv.DictReader(f))
    return np.array([[float(r[k]) for k in ("x", "y", "X", "Y", "p_N")] for r in rows])


def _compare(at0: dict, far: dict, out0, out_far, shift) -> None:
    """``far`` ended as ``at0``: the same Uzawa rounds per step, the contact forces to
    1e-8, and in the CSVs the same mesh coordinates shifted and the same pressures."""
    assert at0["status"] == "ok", at0.get("error")
    assert far["status"] == "ok", far.get("error")
    rounds = [[s["uzawa_rounds"] for s in r["steps"]] for r in (at0, far)]
    assert rounds[0] == rounds[1], rounds
    for k, (a, b) in enumerate(zip(at0["steps"], far["steps"], strict=True)):
        fa, fb = (np.asarray(s["contact_force"][PAIR]) for s in (a, b))
        assert np.linalg.norm(fb - fa) <= 1e-8 * np.linalg.norm(fa), (k, fa, fb)
        if MPI.COMM_WORLD.rank == 0:
            ta, tb = _table(out0, k + 1), _table(out_far, k + 1)
            moved = 8.0 * np.finfo(float).eps * np.abs(shift).max()  # the mesh file's rounding
            np.testing.assert_allclose(tb[:, :2] - shift, ta[:, :2], rtol=0, atol=1e-11 + moved)
            np.testing.assert_allclose(tb[:, 2:4] - shift, ta[:, 2:4], rtol=0, atol=1e-9 + moved)
            np.testing.assert_allclose(tb[:, 4], ta[:, 4], rtol=0, atol=1e-6 * ta[:, 4].max())


@pytest.mark.mpi
def test_pair_origin_rounds_the_centre_and_is_zero_near_the_origin():
    """The same origin on every rank, whatever each rank holds (one rank nothing); 0 for
    a surface within ORIGIN_NEAR s of the origin (s: the power of two above its size);
    else the centre of its box, so that X − o is small, and exact far from 0."""
    comm = MPI.COMM_WORLD
    pts = np.array([[0.0, 0.5], [0.3, 0.5], [0.7, 0.5], [1.0, 0.5]])
    if comm.size == 1:
        mine = pts
    else:  # rank 0 holds no slave facet
        mine = np.array_split(pts, comm.size - 1)[comm.rank - 1] if comm.rank else pts[:0]
    # size L = 1, s = 2: the origin for a centre within 16 of the origin
    assert np.all(pair_origin(comm, mine) == 0.0)
    assert np.all(pair_origin(comm, mine + [ORIGIN_NEAR * 2.0 - 1.0, 0.0]) == 0.0)
    assert np.any(pair_origin(comm, mine + [ORIGIN_NEAR * 2.0 + 1.0, 0.0]) != 0.0)
    for shift in ([0.0, 1e4], [1e4 + 0.37, -3e5], [-7.1e3, 1e4]):
        X = mine + shift
        o = pair_origin(comm, X)
        assert all(other == o.tolist() for other in comm.allgather(o.tolist()))
        np.testing.assert_allclose(o, np.asarray(shift) + 0.5, rtol=1e-15)  # the centre
        assert np.abs(X - o).max(initial=0.0) <= 0.5, (shift, o)  # at most L/2
        np.testing.assert_array_equal((X - o) + o, X)  # X − o exact (Sterbenz)


@pytest.mark.mpi
@pytest.mark.mpi_not3
def test_a_frictional_patch_far_from_the_origin_runs_as_at_the_origin(shared_tmp):
    """The press-slide patch shifted by (0, 1e4): it stopped after 6 cutbacks ("Uzawa
    augmentation stalled"). Now the unshifted run's Uzawa rounds (3, 3, 3, 2), contact
    forces to 1e-8 (2.5e-10 measured) and nodal pressures; the unshifted pair's origin is
    0 (it runs as before, to the last bit). Serially and on 2 ranks (mpi_not3, session
    66: the origin is the slave nodes' bounding box by a min and a max allreduce, on any
    number of ranks; test_pair_origin_rounds_the_centre_and_is_zero_near_the_origin
    checks it on 3 ranks, one of them without slave facets)."""
    shift = np.array([0.0, 1e4])
    out0, out_far = shared_tmp / "fric_at0", shared_tmp / "fric_far"
    at0, o0 = _run(_frictional(_mesh(shared_tmp, "fric0", FRICTIONAL, [0, 0])), out0)
    far, o = _run(_frictional(_mesh(shared_tmp, "fric_far", FRICTIONAL, shift)), out_far)
    assert np.all(o0 == 0.0) and np.all(o == [0.5, 1e4]), (o0, o)  # the slave's centre
    _compare(at0, far, out0, out_far, shift)


@pytest.mark.parametrize("far", [1e4, 1e6])
def test_a_frictionless_patch_far_from_the_origin_runs_as_at_the_origin(shared_tmp, far):
    """Frictionless, Uzawa to 1e-8, shifted by (1e4, 1e4): the rounds stalled at
    multiplier changes of 5e-6 to 1.5e-5 (the gaps' round-off times ε_N over p). Now 3
    rounds as unshifted, forces to 1e-8 (2.4e-12 measured). At 1e6 the contact surface's
    XDMF could not be written ("21 surface dof(s) without a volume dof": its dofs were
    matched to the volume's within 1e-10 of the surface's size, below the coordinates'
    round-off there; output.SURFACE_MATCH_ULPS)."""
    shift = np.array([far, far])
    out0, out_far = shared_tmp / "fl_at0", shared_tmp / f"fl_far_{far:g}"
    at0, _ = _run(_frictionless(_mesh(shared_tmp, "fl0", FRICTIONLESS, [0, 0])), out0)
    msh = _mesh(shared_tmp, f"fl_far_{far:g}", FRICTIONLESS, shift)
    far_run, _ = _run(_frictionless(msh), out_far)
    _compare(at0, far_run, out0, out_far, shift)
    assert (out_far / "contact_upper_bottom.xdmf").exists()


def test_the_exact_update_step_has_a_floor_above_the_round_off(shared_tmp, monkeypatch):
    """Without the pair's origin (o = 0 forced), the coordinates 1e4 from the origin keep
    their round-off, 1.8e-12, and the nodal law's (ε_N times that) was 0.7 to 1.6 times
    the frictional exact update's difference step (EXACT_FD_STEP times the multipliers):
    its differences were noise, and the run stopped as above. The step's floor
    (EXACT_FD_ROUND_OFF times the law's round-off) alone lets it end with at most one
    Uzawa round more per step than the unshifted run (4, 3, 3, 3 against 3, 3, 3, 2)."""
    monkeypatch.setattr(contact, "pair_origin", lambda comm, X: np.zeros(X.shape[-1]))
    shift = np.array([0.0, 1e4])
    at0, _ = _run(_frictional(_mesh(shared_tmp, "fric0", FRICTIONAL, [0, 0])), shared_tmp / "a")
    far, o = _run(_frictional(_mesh(shared_tmp, "fric_far", FRICTIONAL, shift)), shared_tmp / "b")
    assert np.all(o == 0.0)
    assert far["status"] == "ok", far.get("error")
    for a, b in zip(at0["steps"], far["steps"], strict=True):
        assert b["uzawa_rounds"] <= a["uzawa_rounds"] + 1, (a["uzawa_rounds"], b["uzawa_rounds"])
        fa, fb = (np.asarray(s["contact_force"][PAIR]) for s in (a, b))
        assert np.linalg.norm(fb - fa) <= 1e-6 * np.linalg.norm(fa), (fa, fb)


@pytest.mark.parametrize(
    ("du", "step", "said"),
    [
        (np.array([0.0, np.nan]), np.zeros(2), "plain (not finite)"),
        (np.zeros(2), np.array([np.inf, 0.0]), "plain (not finite)"),
        (np.array([0.0, 2.5]), np.zeros(2), "plain (displacement 2.5 > 1 margin)"),
        (np.array([0.0, 1.5]), np.zeros(2), "newton (3 products)"),
    ],
)
def test_an_unusable_exact_update_falls_back_to_the_plain_one(du, step, said):
    """The exact update's δu is added to u before the next solve: one that is not finite,
    or larger than EXACT_DU_MAX search margins, is not used (the plain update is), as
    where GMRES fails."""
    term = types.SimpleNamespace(comm=MPI.COMM_SELF, margin=2.0, displacement_update=None)
    info = {}
    used = contact.MortarContact._exact_outcome(term, True, 3, du, step, info)
    assert info["exact_update"] == said
    assert used == said.startswith("newton")
    assert (term.displacement_update is du) == used
