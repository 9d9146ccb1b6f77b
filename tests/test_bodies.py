"""The bodies of the mesh, whether the Dirichlet conditions hold them
(``ContactProblem.bodies_held``), and the contact predictor that follows: only a pair with
a free body gets the tangent-only stiffness of the nodes nearest to contact while nothing
touches (``MortarContact.free_body``)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import patch_press_scene
from mpi4py import MPI

from dolfinx_mortar.mesh import load_mesh
from dolfinx_mortar.problem import ContactProblem, body_labels, rigid_modes

pytestmark = pytest.mark.mpi

MATERIALS = [("lower", "linear-elastic", 100.0, 0.3), ("upper", "linear-elastic", 100.0, 0.3)]


@pytest.fixture(scope="module")
def patch2d():
    return load_mesh(MPI.COMM_WORLD, generator="patch2d")


def _cells(md, group: str) -> np.ndarray:
    return md.cell_tags.indices[md.cell_tags.values == md.cell_groups[group]]


def test_the_two_blocks_are_two_bodies(patch2d):
    """patch2d's blocks touch nowhere: two bodies, each block's cells one of them on
    every rank (the labels are joined across the partition's ghost nodes)."""
    problem = ContactProblem(patch2d, MATERIALS)
    cell_body, block_body = body_labels(problem.V)
    comm = problem.comm
    labels = {}
    for group in ("lower", "upper"):
        mine = set(cell_body[_cells(patch2d, group)].tolist())
        labels[group] = set().union(*comm.allgather(mine))
        assert len(labels[group]) == 1, (group, labels[group])
    assert labels["lower"] | labels["upper"] == {0, 1}
    assert block_body.min(initial=0) >= 0 and block_body.max(initial=1) <= 1


@pytest.mark.parametrize(
    ("upper_top", "upper_held"),
    [
        (None, True),  # all components of the top face prescribed: held
        ((1,), False),  # only u_y on the top face: free to slide along x
        ("none", False),  # no condition on the upper block: held by contact only
    ],
)
def test_bodies_held_by_their_dirichlet_conditions(patch2d, upper_top, upper_held):
    """A body is held where its rigid motions have full rank at its constrained dofs."""
    path2 = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]
    dirichlet = [("lower_bottom", None, path2)]
    if upper_top is None:
        dirichlet.append(("upper_top", None, [[0.0, 0.0, 0.0], [1.0, 0.0, -0.01]]))
    elif upper_top != "none":
        dirichlet.append(("upper_top", upper_top, [[0.0, 0.0], [1.0, -0.01]]))
    problem = ContactProblem(patch2d, MATERIALS, dirichlet=dirichlet)
    assert problem.bodies_held(_cells(patch2d, "lower"))
    assert problem.bodies_held(_cells(patch2d, "upper")) == upper_held
    both = np.concatenate([_cells(patch2d, "lower"), _cells(patch2d, "upper")])
    assert problem.bodies_held(both) == upper_held


def test_a_body_held_at_one_node_is_free():
    """One clamped node leaves the rotation about it: rank 2 of 3 in 2D, 3 of 6 in 3D."""
    for gdim, n_modes in ((2, 3), (3, 6)):
        comps = np.arange(gdim)
        r = np.tile([0.3, -0.2, 0.1][:gdim], (gdim, 1))
        m = rigid_modes(r, comps, gdim)
        assert m.shape == (gdim, n_modes)
        assert np.linalg.matrix_rank(m) == gdim


def test_rigid_modes_are_rigid_motions():
    """The mode values at (r, component) are the components of the translations and of
    ω × r for the unit rotation vectors ω."""
    rng = np.random.default_rng(0)
    r = rng.standard_normal((5, 3))
    for c in range(3):
        m = rigid_modes(r, np.full(5, c), 3)
        for a in range(3):
            assert np.allclose(m[:, a], float(a == c))
            assert np.allclose(m[:, 3 + a], np.cross(np.eye(3)[a], r)[:, c])
    m2 = rigid_modes(r[:, :2], np.array([0, 1, 0, 1, 0]), 2)
    assert np.allclose(m2[:, 2], [-r[0, 1], r[1, 0], -r[2, 1], r[3, 0], -r[4, 1]])


LIFT_OFF = {
    "title": "a press, then lift-off: the contact opens while clamps hold both bodies",
    "kinematics": "small",
    "mesh": {"generator": "hertz2d", "params": {"h_contact": 0.2}},
    "material": [
        {"region": r, "model": "linear-elastic", "E": 200.0, "nu": 0.3}
        for r in ("cylinder", "block")
    ],
    "contact": [{"slave": "cylinder_surface", "master": "block_top"}],
    "dirichlet": [
        {"boundary": "block_bottom", "path": [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]]},
        {"boundary": "symmetry", "components": [0], "path": [[0.0, 0.0], [3.0, 0.0]]},
        {
            "boundary": "cylinder_top",
            "components": [1],
            "path": [[0.0, 0.0], [1.0, -0.1], [2.0, 0.02], [3.0, 0.05]],
        },
    ],
    "steps": {"t_end": 3.0, "n": 6},
}


def test_a_press_lifted_off_ends_without_contact(shared_tmp):
    """Both bodies are held by their Dirichlet conditions (the cylinder by its top's u_y
    and the symmetry plane's u_x), so the pair gets the contact predictor only up to a
    solve's first Jacobian. Before, once the contact opened, the predictor's tangent-only
    penalty stiffness made Newton contract ‖R‖ by 0.3 % per iteration: the step to t = 2
    failed after 6 cutbacks at t = 1.877, with a hint blaming a free body. Now that step
    opens the contact in a few exact Newton iterations, and the two steps with the bodies
    apart converge at once; the run ends with no force and no node in contact."""
    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    out = shared_tmp / "lift_off"
    summary = run(parse_scene(LIFT_OFF, out), MPI.COMM_WORLD, out_dir=out)
    steps = summary["steps"]
    assert summary["status"] == "ok" and len(steps) == 6, summary.get("error")
    assert [s["cutbacks"] for s in steps] == [0] * 6
    pair = "cylinder_surface:block_top"
    assert max(abs(f) for f in steps[1]["contact_force"][pair]) > 1.0  # pressed
    for st in steps[3:]:  # t = 2, 2.5, 3: apart (measured 3, 2, 0 Newton iterations)
        assert st["contact_force"][pair] == [0.0, 0.0] and st["active_nodes"] == 0
        assert sum(st["newton_iterations"]) <= 4, st["newton_iterations"]


def test_a_body_held_by_contact_keeps_the_predictor():
    """The hertz2d demo's cylinder is free along y (a symmetry plane and a traction):
    its pair keeps the predictor that brings it into contact."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "demos"))
    import demo_hertz2d

    from dolfinx_mortar.runner import prepare
    from dolfinx_mortar.scene import parse_scene

    problem, _ = prepare(parse_scene(demo_hertz2d.scene(0), Path(".")), MPI.COMM_WORLD)
    (term,) = problem.contacts
    assert term.free_body
    problem, _ = prepare(parse_scene(LIFT_OFF, Path(".")), MPI.COMM_WORLD)
    assert not problem.contacts[0].free_body


@pytest.mark.mpi
def test_a_light_first_load_brings_a_curved_body_into_contact(shared_tmp):
    """hertz2d's coarse half model under 1/100 of its load: the cylinder, held by contact
    alone, touches the block at one point. The lumped gap of that node averages the gap
    over its facet, about h²/(12 R) > 0, and the contact predictor's springs of the
    penalty's stiffness moved the body by only F/(ε A) per Newton step: ‖R‖ crept down
    by 0.2–1 % per iteration and the run stopped after 6 cutbacks. The springs now soften
    from the solve's second Jacobian on, so that a step closes the gap
    (contact.MortarContact._predictor_scale): every step converges without a cutback, and
    the contact force carries the load."""
    from test_contact_parallel import HERTZ2D

    from dolfinx_mortar.runner import run
    from dolfinx_mortar.scene import parse_scene

    data = {
        **HERTZ2D,
        "traction": [{"boundary": "cylinder_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.00625]]}],
        "steps": {"n": 4},
    }
    s = run(parse_scene(data, shared_tmp), MPI.COMM_WORLD, out_dir=shared_tmp / "light")
    assert s["status"] == "ok", s["error"]
    assert all(st["cutbacks"] == 0 for st in s["steps"]), [st["cutbacks"] for st in s["steps"]]
    assert max(sum(st["newton_iterations"]) for st in s["steps"]) <= 8, s["steps"]
    (fy,) = [st["contact_force"]["cylinder_surface:block_top"][1] for st in s["steps"][-1:]]
    assert abs(fy - 0.05) <= 1e-6 * 0.05, fy


def _hertz3d_press(block_symmetry: bool):
    """The coarse hertz3d quarter model pressed by a traction on the sphere's top: the
    block held in u_z at its bottom, and on the generator's symmetry planes
    (``block_symmetry``, which hold both bodies) or, as in the probe's scene whose block
    symmetry faces were in unnamed groups, not (the sphere's top held in u_x, u_y then)."""
    path1 = [[0.0, 0.0], [1.0, 0.0]]
    dirichlet = [{"boundary": "block_bottom", "components": [2], "path": path1}]
    if block_symmetry:
        dirichlet += [
            {"boundary": name, "components": [c], "path": path1}
            for c, name in enumerate(("symmetry_x", "symmetry_y"))
        ]
    else:
        top = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]
        dirichlet.append({"boundary": "sphere_top", "components": [0, 1], "path": top})
    return {
        "title": "hertz3d",
        "kinematics": "small",
        "mesh": {"generator": "hertz3d", "params": {"h_contact": 1.0, "h_far": 5.0}},
        "material": [
            {"region": r, "model": "linear-elastic", "E": 200.0, "nu": 0.3}
            for r in ("sphere", "block")
        ],
        "contact": [{"slave": "sphere_surface", "master": "block_top"}],
        "dirichlet": dirichlet,
        "traction": [
            {"boundary": "sphere_top", "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, -0.1]]}
        ],
    }


@pytest.mark.parametrize(
    ("scene", "name", "expected"),
    [
        # u_y only, frictionless: free along x
        (patch_press_scene(lower_bottom=(1,)), "'lower'", ["translation along x"]),
        (
            patch_press_scene(lower_bottom=(1,), friction=0.3),
            None,
            [],
        ),  # friction can hold it (stick)
        (patch_press_scene(lower_bottom=(0, 1)), None, []),  # clamped
        (
            _hertz3d_press(False),
            "'block'",
            ["translation along x", "translation along y", "rotation about z"],
        ),
        (_hertz3d_press(True), None, []),
    ],
)
def test_unheld_motions(scene, name, expected):
    """``ContactProblem.unheld_motions``: the rigid motions that the Dirichlet conditions
    leave free and a frictionless pair cannot hold (tangential to its whole master
    surface). patch2d's lower block held in u_y only slides along its flat top; with
    friction nothing is claimed. hertz3d's block held in u_z at its bottom only (the
    probe's scene) is free in x, y and the rotation about z; the sphere, held by contact
    alone along z (the normal), is not named (a sound scene: Hertz loaded by a force).
    The same answer on every rank (1–3)."""
    from pathlib import Path

    from dolfinx_mortar.runner import prepare
    from dolfinx_mortar.scene import parse_scene

    problem, _ = prepare(parse_scene(scene, Path(".")), MPI.COMM_WORLD)
    found = problem.unheld_motions()
    if not expected:
        assert found == []
        return
    (body,) = found
    assert body.name == name and body.motions(problem.gdim) == expected
    assert body.pairs == [problem.contacts[0].name]
    assert body.describe(problem.gdim).startswith(f"body {name} is free in translation along x")


def test_free_rigid_motion():
    """``ContactProblem.free_rigid_motion``: the cylinder of :func:`stick_only_scene` is
    held in u_y along its top (which holds its y translation and its rotation) and free
    along x; the block is clamped. A step that translates the cylinder by 0.3 along x
    and bends the block moves the pair's bodies 0.3 along their free motions (the fit is
    exact for a rigid motion); a translation along y (the prescribed approach) and the
    block's deformation count nothing. ``floating``: the cylinder floats (nothing holds
    it along x) where its pair is open, not where it is closed. The same on every rank
    (1–3)."""
    from pathlib import Path

    from conftest import stick_only_scene

    from dolfinx_mortar.runner import prepare
    from dolfinx_mortar.scene import parse_scene

    problem, _ = prepare(parse_scene(stick_only_scene(), Path(".")), MPI.COMM_WORLD)
    cell_body, block_body = body_labels(problem.V)
    n_own = problem.V.dofmap.index_map.size_local
    x = problem.V.tabulate_dof_coordinates()[:n_own]
    cyl = _cells(problem.mesh_data, "cylinder")
    label = problem.comm.allreduce(int(cell_body[cyl].max(initial=-1)), MPI.MAX)
    on_cyl = block_body[:n_own] == label
    du = np.zeros((n_own, 2))
    du[~on_cyl, 0] = 0.01 * x[~on_cyl, 1] ** 2  # the block bends
    du[on_cyl, 0] = 0.3
    assert np.allclose(problem.free_rigid_motion(du.ravel()), [0.3], rtol=1e-12)
    du[on_cyl] = [0.0, -0.2]
    assert np.allclose(problem.free_rigid_motion(du.ravel()), [0.0], atol=1e-12)
    # ``floating``: the cylinder, free along x, is held by no closed pair while its one
    # pair is open, and by it where it is closed
    assert problem.floating([False]).tolist() == [True]
    assert problem.floating([True]).tolist() == [False]


@pytest.mark.parametrize(("gap0", "at_start"), [(0.005, True), (0.0, False)])
def test_stick_only_motions(gap0, at_start):
    """``ContactProblem.stick_only_motions``: the cylinder of :func:`stick_only_scene`,
    free along x but for stick (its pair is frictional; the normal of the flat block top
    holds no translation along it); ``stick_only_at_start``: named where no slave node is
    in contact at t = 0 (gap0 = 0.005), not where the cylinder's lowest node touches the
    block (gap0 = 0). patch2d's lower block held in u_y only, pressed by a frictional
    upper block it touches at t = 0, is free along x but for stick, and not named at the
    start. The same answer on every rank (1–3)."""
    from pathlib import Path

    from conftest import stick_only_scene

    from dolfinx_mortar.runner import prepare
    from dolfinx_mortar.scene import parse_scene

    problem, _ = prepare(parse_scene(stick_only_scene(gap0), Path(".")), MPI.COMM_WORLD)
    assert problem.unheld_motions() == []
    (body,) = problem.stick_only_motions()
    assert body.name == "'cylinder'" and body.motions(2) == ["translation along x"]
    assert body.pairs == ["cylinder_surface:block_top"]
    assert [b.name for b in problem.stick_only_at_start()] == (["'cylinder'"] if at_start else [])
    scene = patch_press_scene(lower_bottom=(1,), friction=0.3)
    problem, _ = prepare(parse_scene(scene, Path(".")), MPI.COMM_WORLD)
    (body,) = problem.stick_only_motions()
    assert body.name == "'lower'" and body.motions(2) == ["translation along x"]
    assert problem.stick_only_at_start() == []


def test_free_rigid_motion_along_the_surface():
    """``free_rigid_motion(..., tangential=True)`` counts only the motions that the
    contact's normal cannot hold either: in :func:`_hertz3d_press` (frictionless, the
    block held in u_z at its bottom only, the sphere by contact alone along z), a step
    that moves the sphere 0.4 down (the force-driven approach, along the normal) and the
    block 0.1 along x moves the pair's bodies 0.4 along their free motions, and 0.1
    along those that nothing holds (the block's x). The same on every rank (1–3)."""
    from pathlib import Path

    from dolfinx_mortar.runner import prepare
    from dolfinx_mortar.scene import parse_scene

    problem, _ = prepare(parse_scene(_hertz3d_press(False), Path(".")), MPI.COMM_WORLD)
    cell_body, block_body = body_labels(problem.V)
    n_own = problem.V.dofmap.index_map.size_local
    sphere = _cells(problem.mesh_data, "sphere")
    label = problem.comm.allreduce(int(cell_body[sphere].max(initial=-1)), MPI.MAX)
    on_sphere = block_body[:n_own] == label
    du = np.zeros((n_own, 3))
    du[on_sphere, 2] = -0.4
    du[~on_sphere, 0] = 0.1
    assert np.allclose(problem.free_rigid_motion(du.ravel()), [0.4], rtol=1e-12)
    assert np.allclose(problem.free_rigid_motion(du.ravel(), tangential=True), [0.1], rtol=1e-12)


def _patch_free(friction: float = 0.0, lower=None, upper=None, press: bool = False) -> dict:
    """:func:`patch_press_scene` with the Dirichlet conditions replaced: ``lower`` and
    ``upper`` the components held at zero on lower_bottom and upper_top (None: no
    condition there); ``press`` a traction of 0.5 pressing upper_top down."""
    scene = patch_press_scene(friction=friction)
    scene["dirichlet"] = [
        {"boundary": name, "components": list(comps), "path": [[0.0] * (1 + len(comps))]}
        for name, comps in (("lower_bottom", lower), ("upper_top", upper))
        if comps is not None
    ]
    if press:
        scene["traction"] = [{"boundary": "upper_top", "path": [[0.0, 0.0, 0.0], [1.0, 0.0, -0.5]]}]
    return scene


ALL_2D = ["translation along x", "translation along y", "rotation in the plane"]


@pytest.mark.parametrize(
    ("scene", "joint", "bodies"),
    [
        # no [[dirichlet]] at all: each block is held by the other's surface along y and in
        # rotation (named free along x only), the two together by nothing
        (_patch_free(), ALL_2D, ["'lower'", "'upper'"]),
        # stick acts between the bodies: it holds no joint motion either
        (_patch_free(friction=0.3), ALL_2D, []),
        # the lower block clamped, the upper pressed onto it by a traction: sound (the
        # upper block named free along x by its own warning, nothing new)
        (_patch_free(lower=(0, 1), press=True), [], ["'upper'"]),
        # both held in u_y only: the joint x translation is what each body's own warning
        # names already
        (_patch_free(lower=(1,), upper=(1,)), [], ["'lower'", "'upper'"]),
        (_hertz3d_press(False), [], ["'block'"]),
        (_hertz3d_press(True), [], []),
    ],
)
def test_unheld_joint_motions(scene, joint, bodies):
    """``ContactProblem.unheld_joint_motions``: bodies joined by contact that the Dirichlet
    conditions of none of them hold against the same rigid motion of all (the null space
    of the sum of their Gram matrices): patch2d's two blocks with no [[dirichlet]] at all
    are free together in all three rigid motions (such a motion keeps every gap), with or
    without friction, though each block alone is held by the other's surface along y and
    in rotation (``unheld_motions`` names each along x only, frictionless). A clamped
    lower block holds the pair; blocks each held in u_y only are free together along x
    only, which each block's own warning says (not named again). The same answer on every
    rank (1–3)."""
    from pathlib import Path

    from dolfinx_mortar.runner import prepare
    from dolfinx_mortar.scene import parse_scene

    problem, _ = prepare(parse_scene(scene, Path(".")), MPI.COMM_WORLD)
    assert sorted(b.name for b in problem.unheld_motions()) == bodies  # by label: any order
    for b in problem.unheld_motions() if problem.gdim == 2 else ():
        assert b.motions(problem.gdim) == ["translation along x"]
    found = problem.unheld_joint_motions()
    answers = problem.comm.allgather([(g.name, g.modes.round(12).tolist()) for g in found])
    assert all(a == answers[0] for a in answers), answers
    if not joint:
        assert found == []
        return
    (group,) = found
    assert group.bodies == ["'lower'", "'upper'"] and group.name == "'lower' and 'upper'"
    assert group.pairs == [problem.contacts[0].name] == ["upper_bottom:lower_top"]
    assert group.motions(problem.gdim) == joint
    assert np.allclose(group.modes @ group.modes.T, np.eye(len(joint)), atol=1e-12)
    assert group.describe(problem.gdim) == (
        "bodies 'lower' and 'upper' are free together in translation along x, translation "
        "along y and rotation in the plane"
    )


def test_the_warnings_of_bodies_held_by_contact_alone(caplog):
    """The set-up warnings' words (no solve; fake bodies). A frictionless body held by
    contact alone: where its pairs take element integration the line says that their
    quadrature error on non-matching meshes is a small load along the free motions and
    offers segment integration (a probe's frictionless stack of three blocks, the middle
    one held by contact alone and pressed normal to it, stopped after 6 cutbacks with
    element integration, the middle block drifted along x, and completed with segments;
    held along x with element integration, its pairs carried lateral contact forces of
    4.9e-8 and -2.2e-8 against 0.1 normal, 1e-15 with segments); with segments, or in no
    pair, it says nothing of them. A body that only stick holds "may escape": it said
    it escapes and the run stops, and the probe's frictional stack started from a gap
    completed with the exact solution. Each is one line."""
    import logging
    from types import SimpleNamespace

    from dolfinx_mortar.problem import UnheldBody
    from dolfinx_mortar.runner import stick_only_text, unheld_text, warn_unheld_bodies

    modes = np.eye(3)[:1]  # translation along x
    middle = UnheldBody("'middle'", modes, ["a:b", "c:d"])
    line = unheld_text(middle, 2, ["a:b", "c:d"])
    assert line == (
        "body 'middle' is free in translation along x: no [[dirichlet]] condition holds "
        "these motions, and its frictionless contact (a:b, c:d) cannot: they keep every gap "
        "of the pair; the Jacobian is singular along them, and the run may fail (it does "
        "where a load pushes the body along them; element integration's quadrature error on "
        "non-matching meshes is such a load, a small one): hold them with [[dirichlet]] "
        'components, or, where no load acts along them, integration = "segment" for a:b, c:d'
    )
    for plain in (unheld_text(middle, 2), unheld_text(UnheldBody("'x'", modes, []), 2)):
        assert plain.endswith("along them): hold them with [[dirichlet]] components")
        assert "segment" not in plain
    stick = stick_only_text(
        SimpleNamespace(describe=lambda gdim: "body 'c' is free", pairs=["a:b"]), 2
    )
    assert "(it may escape, and the run stop)" in stick and "it escapes" not in stick
    # the runner's warning names the element pairs only
    contacts = [SimpleNamespace(name="a:b", integration="element")]
    contacts.append(SimpleNamespace(name="c:d", integration="segment"))
    problem = SimpleNamespace(
        gdim=2,
        contacts=contacts,
        unheld_motions=lambda: [middle],
        unheld_joint_motions=lambda: [],
        stick_only_at_start=lambda: [],
    )
    with caplog.at_level(logging.WARNING, logger="dolfinx_mortar.runner"):
        warn_unheld_bodies(problem)
    (record,) = caplog.records
    assert record.getMessage() == unheld_text(middle, 2, ["a:b"])
    assert record.getMessage().endswith('integration = "segment" for a:b')
    assert "\n" not in record.getMessage()
