"""Bulk mechanics against closed-form homogeneous solutions, serial and under MPI.

Homogeneous states are represented exactly by P1/Q1 (and P2) displacements, so
the reactions must match the analytic values to round-off (1e-8 relative).
"""

import numpy as np
import pytest
import ufl
from mpi4py import MPI
from scipy.optimize import brentq

from dolfinx_mortar.bulk import lame
from dolfinx_mortar.runner import run
from dolfinx_mortar.scene import parse_scene

E, NU = 200.0, 0.3


def _table(msh, dim, model, kinematics, right_ux) -> dict:
    """A block with the left, bottom (and back) faces on rollers and the right end pulled
    by ``right_ux`` over two steps, as a scene table."""
    fixed = [
        {"boundary": "left", "components": [0], "path": [[0.0, 0.0], [1.0, 0.0]]},
        {"boundary": "bottom", "components": [1], "path": [[0.0, 0.0], [1.0, 0.0]]},
        {"boundary": "right", "components": [0], "path": [[0.0, 0.0], [1.0, right_ux]]},
    ]
    if dim == 3:
        fixed.append({"boundary": "back", "components": [2], "path": [[0.0, 0.0], [1.0, 0.0]]})
    return {
        "kinematics": kinematics,
        "mesh": {"file": str(msh)},
        "material": [{"region": "body", "model": model, "E": E, "nu": NU}],
        "dirichlet": fixed,
        "steps": {"t_end": 1.0, "n": 2},
    }


def _scene(msh, dim, model, kinematics, right_ux, out):
    data = _table(msh, dim, model, kinematics, right_ux)
    data["output"] = {"dir": str(out), "fields": ["displacement"]}
    return parse_scene(data, msh.parent)


def _reaction_right(summary):
    return summary["steps"][-1]["reactions"]["right"][0]


@pytest.mark.mpi
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("quads", [False, True])
def test_small_strain_uniaxial(block_msh, shared_tmp, dim, quads):
    """Uniaxial stress by prescribed end displacement: F = E' δ/L · A (E' = E/(1−ν²) in plane strain)."""
    msh = block_msh(dim, n=3, quads=quads)
    delta, L = 1e-3, 2.0
    s = run(
        _scene(msh, dim, "linear-elastic", "small", delta, shared_tmp / f"out_s{dim}{quads}"),
        MPI.COMM_WORLD,
    )
    assert s["status"] == "ok"
    assert s["modelled"]["bulk"] == "linear"  # evaluated as K0 x + f (LinearBulk)
    Eeff, area = (E / (1 - NU**2), 1.0) if dim == 2 else (E, 1.0)
    expected = Eeff * delta / L * area
    assert _reaction_right(s) == pytest.approx(expected, rel=1e-8)
    assert s["steps"][-1]["reactions"]["left"][0] == pytest.approx(-expected, rel=1e-8)


@pytest.mark.mpi
@pytest.mark.parametrize("dim", [2, 3])
def test_reactions_only_where_prescribed_and_once(block_msh, shared_tmp, dim):
    """summary.json's reactions: the force of each boundary in the components it
    prescribes, a dof prescribed by several boundaries counted in the first of them.

    A block clamped on its left face (every component), on rollers at the bottom (and
    back), pulled at its right end: the clamp's edges on the roller faces are prescribed
    by both. With no load but the prescribed displacements, the reactions of all
    boundaries sum to zero (global equilibrium), the rollers and the pulled end have no
    force in the components they leave free, and the clamp balances the pull. Counting the
    shared edges in both boundaries (before session 34) broke the sum: the rollers
    reported the clamp's lateral corner forces as well."""
    msh = block_msh(dim, n=3)
    data = _table(msh, dim, "linear-elastic", "small", 1e-3)
    clamp = data["dirichlet"][0]  # the left face clamped
    clamp["components"] = list(range(dim))
    clamp["path"] = [[0.0] * (dim + 1), [1.0] + [0.0] * dim]
    data["output"] = {"dir": str(shared_tmp / f"out_r{dim}"), "fields": ["displacement"]}
    s = run(parse_scene(data, msh.parent), MPI.COMM_WORLD)
    assert s["status"] == "ok"
    reac = {k: np.asarray(v) for k, v in s["steps"][-1]["reactions"].items()}
    scale = abs(reac["right"][0])
    assert scale > 0.05
    for name, prescribed in (("bottom", 1), ("right", 0), ("back", 2)):
        if name in reac:
            free = [c for c in range(dim) if c != prescribed]
            assert np.all(reac[name][free] == 0.0), (name, reac[name])
    total = sum(reac.values())
    assert np.abs(total).max() <= 1e-10 * scale, (total, reac)
    assert reac["left"][0] == pytest.approx(-reac["right"][0], rel=1e-10)
    # the clamp restrains the lateral (Poisson) contraction: its corner forces in y are
    # not zero, and the roller's share excludes them
    assert abs(reac["left"][1]) > 1e-6 * scale, reac["left"]


@pytest.mark.mpi
@pytest.mark.parametrize("first", ["left", "bottom"])
def test_the_first_prescription_of_a_shared_node_wins(block_msh, first):
    """The corner (0, 0) lies on the left face (clamped) and on the bottom (u_y = −1e-3):
    it takes the value of the entry declared first, as docs/scenes.md says and as its
    reaction is booked. It took the last one's (dolfinx applies a list of conditions in
    order, the last write holding), while its reaction went to the first."""
    msh = block_msh(2, n=3)
    data = _table(msh, 2, "linear-elastic", "small", 0.0)
    entries = {d["boundary"]: d for d in data["dirichlet"]}
    entries["left"].update(components=[0, 1], path=[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    entries["bottom"]["path"] = [[0.0, 0.0], [1.0, -1e-3]]
    order = [first, "bottom" if first == "left" else "left", "right"]
    data["dirichlet"] = [entries[name] for name in order]
    box = {}
    s = run(parse_scene(data, msh.parent), MPI.COMM_WORLD, setup=lambda p: box.update(p=p))
    assert s["status"] == "ok", s["error"]
    problem = box["p"]
    X = problem.V.tabulate_dof_coordinates()
    u = problem.u.x.array.reshape(-1, 2)
    corner = np.flatnonzero(np.linalg.norm(X[:, :2], axis=1) < 1e-12)
    want = 0.0 if first == "left" else -1e-3
    assert np.all(u[corner, 1] == want), u[corner]
    assert MPI.COMM_WORLD.allreduce(corner.size) > 0
    X_left, F_left = problem.nodal_reactions("left")
    at_corner = np.linalg.norm(X_left[:, :2], axis=1) < 1e-12
    # the corner's y reaction is the first entry's: the clamp's only where it came first
    booked = MPI.COMM_WORLD.allreduce(float(np.abs(F_left[at_corner, 1]).sum()))
    assert (booked > 0.0) == (first == "left")
    # a field on a component an entry of the same boundary prescribes: refused (the
    # field overrode the scene's entry, silently)
    with pytest.raises(ValueError, match=r"components \[1\] of 'bottom' are already"):
        problem.add_dirichlet_field("bottom", lambda t, x: np.zeros((2, x.shape[1])))
    problem.destroy()


@pytest.mark.mpi
def test_nodal_reactions_and_a_boundary_in_two_entries(block_msh):
    """ContactProblem.nodal_reactions: per owned node, the forces that sum to
    reactions(); a boundary named by two [[dirichlet]] entries (the pulled end's x, then
    its y held) reports both components under its name."""
    msh = block_msh(2, n=3)
    data = _table(msh, 2, "linear-elastic", "small", 1e-3)
    data["dirichlet"].append(
        {"boundary": "right", "components": [1], "path": [[0.0, 0.0], [1.0, 0.0]]}
    )
    box = {}
    s = run(parse_scene(data, msh.parent), MPI.COMM_WORLD, setup=lambda p: box.update(p=p))
    reac = s["steps"][-1]["reactions"]
    problem = box["p"]  # at the converged final state
    X, F = problem.nodal_reactions("right")
    assert X.shape == (F.shape[0], 3) and F.shape[1] == 2
    assert np.all(np.abs(X[:, 0] - 2.0) < 1e-12)  # the right end, x = 2
    total = MPI.COMM_WORLD.allreduce(F.sum(axis=0))
    assert total == pytest.approx(reac["right"], rel=1e-12, abs=1e-14)
    assert abs(reac["right"][0]) > 0.05 and abs(reac["right"][1]) > 0.0, reac
    with pytest.raises(KeyError):
        problem.nodal_reactions("nowhere")


def _neo_hooke_uniaxial(stretch, dim):
    """P11 of compressible neo-Hooke in uniaxial stress (plane strain in 2D): lateral P22 = 0 by root find."""
    lm, mu = lame(E, NU)
    nlat = 1 if dim == 2 else 2

    def p22(l2):
        J = stretch * l2**nlat
        return mu * (l2 - 1 / l2) + lm * np.log(J) / l2

    l2 = brentq(p22, 0.3, 1.5)
    J = stretch * l2**nlat
    return mu * (stretch - 1 / stretch) + lm * np.log(J) / stretch


@pytest.mark.mpi
@pytest.mark.parametrize("dim", [2, 3])
def test_neo_hookean_uniaxial_stretch(block_msh, shared_tmp, dim):
    """Finite stretch λ = 1.3: the reaction equals P11(λ)·A from the closed-form response."""
    msh = block_msh(dim, n=2, quads=(dim == 2))
    L, stretch = 2.0, 1.3
    s = run(
        _scene(msh, dim, "neo-hookean", "finite", (stretch - 1) * L, shared_tmp / f"out_nh{dim}"),
        MPI.COMM_WORLD,
    )
    assert s["status"] == "ok"
    assert s["modelled"]["bulk"] == "nonlinear"
    assert _reaction_right(s) == pytest.approx(_neo_hooke_uniaxial(stretch, dim), rel=1e-8)


@pytest.mark.mpi
def test_svk_and_p2(block_msh, shared_tmp):
    """Saint Venant–Kirchhoff on a P2 mesh: uniaxial stretch, P11 = λ S11 with S from E_green."""
    msh = block_msh(2, n=2, order=2)
    L, stretch = 2.0, 1.1
    s = run(
        _scene(
            msh, 2, "saint-venant-kirchhoff", "finite", (stretch - 1) * L, shared_tmp / "out_svk"
        ),
        MPI.COMM_WORLD,
    )
    lm, mu = lame(E, NU)
    # plane strain, S22 = 0: E11 = (λ²−1)/2; S22 = lm (E11+E22) + 2 mu E22 = 0
    E11 = (stretch**2 - 1) / 2
    E22 = -lm * E11 / (lm + 2 * mu)
    S11 = lm * (E11 + E22) + 2 * mu * E11
    assert s["modelled"]["displacement_degree"] == 2
    assert _reaction_right(s) == pytest.approx(stretch * S11, rel=1e-8)


@pytest.mark.mpi
@pytest.mark.parametrize("dim, quads", [(2, False), (2, True), (3, False), (3, True)])
def test_p2_every_cell_type(block_msh, shared_tmp, dim, quads):
    """P2 geometry and displacement on triangles, 9-node quadrilaterals, 10-node tetrahedra
    and 27-node hexahedra, read from a .msh 2.2 file: the uniaxial reaction to 1e-8."""
    msh = block_msh(dim, n=2, quads=quads, order=2, version=2.2)
    delta, L = 1e-3, 2.0
    out = shared_tmp / f"out_p2_{dim}{quads}"
    s = run(_scene(msh, dim, "linear-elastic", "small", delta, out), MPI.COMM_WORLD)
    assert s["modelled"]["displacement_degree"] == 2
    Eeff = E / (1 - NU**2) if dim == 2 else E
    assert _reaction_right(s) == pytest.approx(Eeff * delta / L, rel=1e-8)


def test_solver_leaves_no_petsc_options(block_msh, shared_tmp):
    """A run removes the options its solver wrote to PETSc's global database, so a later
    run in the same process (benchmarks, tests) starts from the documented defaults, not
    from the last solver's divergence tolerance or line search."""
    from petsc4py import PETSc

    from dolfinx_mortar.solver import SolverSettings

    prefix = SolverSettings().prefix
    opts = PETSc.Options()
    before = {k for k in opts.getAll() if k.startswith(prefix)}
    msh = block_msh(2, n=2)
    s = run(
        _scene(msh, 2, "linear-elastic", "small", 1e-3, shared_tmp / "out_opts"), MPI.COMM_WORLD
    )
    assert s["status"] == "ok"
    after = {k for k in opts.getAll() if k.startswith(prefix)}
    assert after == before


def test_host_options_of_the_prefix_are_set_aside_and_put_back(block_msh, shared_tmp):
    """Options of the solver's prefix that a host program put in PETSc's database: the
    solver overwrote those it sets (a host's snes_linesearch_type bt was ignored), read
    the others, and deleted both at the end (a helper's probe). They are now set aside for
    the run, which gives the same result as without them, and put back with their
    values."""
    from petsc4py import PETSc

    from dolfinx_mortar.solver import SolverSettings

    prefix = SolverSettings().prefix
    opts = PETSc.Options()
    msh = block_msh(2, n=2)
    plain = run(_scene(msh, 2, "linear-elastic", "small", 1e-3, shared_tmp / "o1"), MPI.COMM_WORLD)
    host = {
        prefix + "snes_linesearch_type": "bt",
        prefix + "snes_max_it": "1",
        prefix + "ksp_type": "cg",
    }
    for key, value in host.items():
        opts[key] = value
    try:
        hosted = run(
            _scene(msh, 2, "linear-elastic", "small", 1e-3, shared_tmp / "o2"), MPI.COMM_WORLD
        )
        kept = {k: opts.getString(k) for k in host}
    finally:
        for key in host:
            opts.delValue(key)
    assert hosted["status"] == "ok", hosted["error"]
    assert [st["residual_norms"] for st in hosted["steps"]] == [
        st["residual_norms"] for st in plain["steps"]
    ]
    assert kept == host


@pytest.mark.mpi
@pytest.mark.parametrize("dim, quads", [(2, True), (2, False), (3, True)])
def test_linear_bulk_equals_assembly(block_msh, dim, quads):
    """A linear-elastic bulk is evaluated as K₀ x̃ + f(t) and its Jacobian inserted from
    the stored K_D (problem.LinearBulk). At a state whose constrained dofs differ from
    their prescribed values, under a traction, both equal dolfinx's assembly with the
    lifting to round-off, and so do the reactions (residual without the conditions);
    on 1–3 ranks."""
    from dolfinx_mortar.problem import LinearBulk
    from dolfinx_mortar.runner import prepare

    msh = block_msh(dim, n=3, quads=quads)
    data = _table(msh, dim, "linear-elastic", "small", 2e-3)
    data["traction"] = [
        {"boundary": "top", "path": [[0.0] + [0.0] * dim, [1.0, 0.5, -1.5, 0.2][: dim + 1]]}
    ]
    scene = parse_scene(data, msh.parent)
    problem, _ = prepare(scene, MPI.COMM_WORLD)
    assert isinstance(problem.linear_bulk, LinearBulk)
    rng = np.random.default_rng(7 + MPI.COMM_WORLD.rank)
    x = problem.u.vector.copy()
    x.array[:] = 1e-3 * rng.standard_normal(x.array.size)
    x.ghostUpdate()
    problem.update_contact(x)  # u = x: the assembly evaluates the forms at u
    got, ref = x.duplicate(), x.duplicate()
    A_got, A_ref = problem.create_matrix(), problem.create_matrix()
    for t in (0.5, 1.0):  # the loads follow the time
        problem.set_time(t)
        for apply_bcs in (True, False):
            problem.residual(x, got, apply_bcs)
            linear, problem.linear_bulk = problem.linear_bulk, None
            problem.residual(x, ref, apply_bcs)
            problem.linear_bulk = linear
            assert ref.norm() > 1e-3
            assert (got - ref).norm() <= 1e-12 * ref.norm()
        problem.jacobian(x, A_got)
        linear, problem.linear_bulk = problem.linear_bulk, None
        problem.jacobian(x, A_ref)
        problem.linear_bulk = linear
        A_got.axpy(-1.0, A_ref)
        assert A_got.norm() <= 1e-12 * A_ref.norm()
    for obj in (x, got, ref, A_got, A_ref):
        obj.destroy()


def _signature(form) -> bytes:
    """The signature of a compiled form (FFCx's JIT cache key)."""
    import cffi

    return cffi.FFI().string(form.ufcx_form.signature)


@pytest.mark.parametrize(
    "model, kinematics",
    [("linear-elastic", "small"), ("neo-hookean", "finite"), ("saint-venant-kirchhoff", "finite")],
)
def test_scenes_differing_in_the_moduli_share_the_compiled_forms(block_msh, model, kinematics):
    """The built-in laws take λ and μ as constants of the compiled kernels, not literals:
    two materials that differ in E and ν alone give forms of one signature (one FFCx
    compilation), and the tangent at u = 0, linear in (λ, μ), is λ K_λ + μ K_μ with the
    values of each: K(E₂, ν₂) from K of two other materials."""
    from dolfinx_mortar.runner import prepare

    msh = block_msh(2, n=2, quads=False)
    moduli = [(E, NU), (3.5 * E, 0.1), (0.25 * E, 0.45)]
    problems, jacobians = [], []
    for E_, nu_ in moduli:
        data = _table(msh, 2, model, kinematics, 1e-3)
        data["material"][0].update(E=E_, nu=nu_)
        problem, _ = prepare(parse_scene(data, msh.parent), MPI.COMM_SELF)
        x = problem.u.vector.copy()
        x.set(0.0)
        A = problem.create_matrix()
        problem.jacobian(x, A)
        problems.append(problem)
        jacobians.append(A)
        x.destroy()
    for problem in problems[1:]:
        assert _signature(problem.J_form) == _signature(problems[0].J_form)
        assert _signature(problem.F_form) == _signature(problems[0].F_form)
    # K = λ K_λ + μ K_μ: solve for K_λ, K_μ from the first two, predict the third
    lm = np.array([lame(E_, nu_) for E_, nu_ in moduli])
    dense = [A.convert("dense").getDenseArray() for A in jacobians]
    free = np.abs(dense[0] - dense[1]).max(axis=1) > 0  # rows the conditions leave alone
    ab = np.linalg.solve(lm[:2].T, np.eye(2))  # K_λ = ab[0,0] K₀ + ab[1,0] K₁, ...
    K_l = ab[0, 0] * dense[0] + ab[1, 0] * dense[1]
    K_m = ab[0, 1] * dense[0] + ab[1, 1] * dense[1]
    predicted = lm[2, 0] * K_l + lm[2, 1] * K_m
    assert free.sum() > 10
    assert np.allclose(predicted[free], dense[2][free], rtol=0, atol=1e-10 * np.abs(dense[2]).max())
    for A in jacobians:
        A.destroy()


# ---------------------------------------------------------------- laws of one's own
def _hand_neo_hooke(F, E_, nu_):
    """The compressible neo-Hookean ψ of bulk.py, written as a user would (plane strain)."""

    lm, mu = lame(E_, nu_)
    d = F.ufl_shape[0]
    J = ufl.det(F)
    I1 = ufl.tr(F.T * F) + (1.0 if d == 2 else 0.0)
    return mu / 2 * (I1 - 3 - 2 * ufl.ln(J)) + lm / 2 * ufl.ln(J) ** 2


@pytest.fixture
def no_laws(monkeypatch):
    """An empty registry of laws for the test (the process's own is left as it was)."""
    from dolfinx_mortar import laws

    monkeypatch.setattr(laws, "_LAWS", {})
    return laws


@pytest.mark.mpi
@pytest.mark.parametrize("dim", [2, 3])
def test_registered_law_uniaxial_stretch(block_msh, shared_tmp, no_laws, dim):
    """A law registered from Python (here neo-Hooke written by hand) is named in the scene
    and gives the closed-form uniaxial reaction, as the built-in law does, to 1e-8."""
    from dolfinx_mortar import register_law

    register_law("hand-neo-hooke", _hand_neo_hooke)
    msh = block_msh(dim, n=2, quads=(dim == 2))
    L, stretch = 2.0, 1.3
    out = shared_tmp / f"out_law{dim}"
    s = run(_scene(msh, dim, "hand-neo-hooke", "finite", (stretch - 1) * L, out), MPI.COMM_WORLD)
    assert s["status"] == "ok"
    assert s["modelled"]["materials"] == {"body": "hand-neo-hooke"}
    origin = s["modelled"]["laws"]["hand-neo-hooke"]
    assert origin.startswith("test_bulk._hand_neo_hooke (") and origin.endswith("test_bulk.py)")
    assert s["modelled"]["bulk"] == "nonlinear" and s["modelled"]["jacobian_symmetric"]
    assert _reaction_right(s) == pytest.approx(_neo_hooke_uniaxial(stretch, dim), rel=1e-8)


def test_register_law_rejects_what_it_cannot_use(no_laws):
    from dolfinx_mortar import register_law

    for name, psi, match in (
        ("neo-hookean", _hand_neo_hooke, "built-in"),
        ("", _hand_neo_hooke, "non-empty"),
    ):
        with pytest.raises(ValueError, match=match):
            register_law(name, psi)
    # a wrong type is a TypeError (it was a ValueError; QA, session 65)
    for name, psi, match in (
        ("law", 3.0, "must be callable, got float 3.0"),
        (7, _hand_neo_hooke, "the name must be a string, got int$"),
        (_hand_neo_hooke, "law", r"got function \(the name comes first"),
    ):
        with pytest.raises(TypeError, match=match):
            register_law(name, psi)
    register_law("law", _hand_neo_hooke)
    register_law("law", _hand_neo_hooke)  # the same function again: nothing changes
    with pytest.raises(ValueError, match="already registered"):
        register_law("law", lambda F, E, nu: 0 * F[0, 0])
    other = lambda F, E, nu: 2 * _hand_neo_hooke(F, E, nu)  # noqa: E731
    register_law("law", other, replace=True)
    assert no_laws.registered_law("law") is other
    assert no_laws.model_names()[-1] == "law"


def test_scene_names_a_registered_law_only(block_msh, no_laws):
    """An unknown model is a scene error that points at register_law; once registered
    the name parses (finite kinematics only: "small" keeps linear elasticity)."""
    from dolfinx_mortar import SceneError, register_law

    msh = block_msh(2, n=2)
    data = _table(msh, 2, "hand-neo-hooke", "finite", 0.1)
    with pytest.raises(SceneError, match="register_law") as err:
        parse_scene(data, msh.parent)
    assert err.value.key == "material[0].model"
    register_law("hand-neo-hooke", _hand_neo_hooke)
    assert parse_scene(data, msh.parent).materials[0].model == "hand-neo-hooke"
    with pytest.raises(SceneError, match='needs model = "linear-elastic"'):
        parse_scene(_table(msh, 2, "hand-neo-hooke", "small", 0.1), msh.parent)


def test_a_law_registered_again_after_parsing_is_refused(block_msh, no_laws):
    """A scene keeps the law it was parsed with: a run looks laws up by name, and after
    ``register_law(name, other, replace=True)`` a scene parsed before ran the new law
    while summary.json named the same (a helper's probe). ``prepare`` (``run``,
    ``check``) now refuses it, naming the material; parsed again, it runs."""
    from dolfinx_mortar import SceneError, register_law
    from dolfinx_mortar.runner import prepare

    msh = block_msh(2, n=2)
    data = _table(msh, 2, "hand-neo-hooke", "finite", 0.1)
    register_law("hand-neo-hooke", _hand_neo_hooke)
    scene = parse_scene(data, msh.parent)
    assert scene.laws == (("hand-neo-hooke", _hand_neo_hooke),)
    register_law("hand-neo-hooke", lambda F, E, nu: 1.01 * _hand_neo_hooke(F, E, nu), replace=True)
    with pytest.raises(SceneError, match="registered again after the scene was parsed") as err:
        prepare(scene, MPI.COMM_SELF)
    assert err.value.key == "material[0].model"
    problem, _ = prepare(parse_scene(data, msh.parent), MPI.COMM_SELF)
    problem.destroy()


@pytest.mark.mpi
@pytest.mark.parametrize(
    "psi, match",
    [
        (lambda F, E, nu: F, r"must return a UFL scalar, got shape \(2, 2\)"),
        (lambda F, E, nu: 1.0, "must return a UFL scalar, got float"),
        (lambda F, E, nu: 1 / 0, "failed: ZeroDivisionError"),
        (lambda F, E, nu: 0 * ufl.det(F), "at most linear in F"),
        (lambda F, E, nu: E * ufl.tr(F), "at most linear in F"),
    ],
    ids=["matrix", "float", "raises", "zero", "linear"],
)
def test_a_bad_law_is_one_scene_error_on_every_rank(block_msh, shared_tmp, no_laws, psi, match):
    """A registered ψ that does not give a UFL scalar, or one at most linear in F (no
    stiffness: an IndexError traceback from dolfinx's sparsity pattern), stops the run
    before the problem is built, with the same SceneError (key material[0].model) on every
    rank."""
    from dolfinx_mortar import SceneError, register_law

    register_law("bad", psi)
    msh = block_msh(2, n=2)
    scene = _scene(msh, 2, "bad", "finite", 0.1, shared_tmp / "out_bad")
    with pytest.raises(SceneError, match=match) as err:
        run(scene, MPI.COMM_WORLD)
    assert err.value.key == "material[0].model"
    assert "\n" not in str(err.value)


def test_a_law_is_checked_at_the_reference_state(no_laws, caplog):
    """check_law reads the law's small-strain moduli and stress at F = I (UFL's second
    derivative of ψ there): a law written for other moduli than the material's E and ν,
    or one that is not stress-free, gets a warning; neo-Hooke written by hand none, in 2D
    and 3D."""
    import logging

    from dolfinx_mortar import register_law
    from dolfinx_mortar.bulk import check_law

    def fixed(F, E_, nu_):  # neo-Hooke with E = 100, nu = 0.25 whatever the material says
        return _hand_neo_hooke(F, 100.0, 0.25)

    def prestressed(F, E_, nu_):
        return _hand_neo_hooke(F, E_, nu_) + 3.0 * ufl.tr(F)

    for name, psi in (("hand", _hand_neo_hooke), ("fixed", fixed), ("pre", prestressed)):
        register_law(name, psi)
    with caplog.at_level(logging.WARNING, logger="dolfinx_mortar.bulk"):
        for dim in (2, 3):
            check_law("hand", E, NU, dim, "k")
            check_law("neo-hookean", E, NU, dim, "k")  # built in: not checked
        assert caplog.records == []
        check_law("fixed", E, NU, 3, "k")
        (rec,) = caplog.records
        assert "'fixed': its small-strain moduli at F = I are E = 100, nu = 0.25" in rec.message
        caplog.clear()
        check_law("pre", E, NU, 2, "k")
        (rec,) = caplog.records
        assert "'pre' is not stress-free at F = I (largest |P_ij| = 3)" in rec.message
        caplog.clear()
        check_law("pre", E, NU, 2, "k", "upper")
        (rec,) = caplog.records
        assert "law 'pre' (region 'upper') is not stress-free at F = I" in rec.message


@pytest.mark.mpi
def test_a_law_warning_names_its_region(no_laws, caplog, tmp_path):
    """Two regions (patch2d's lower and upper blocks) of one registered law whose moduli
    are not the materials' (neo-Hooke with E = 100, ν = 0.25; the materials say E = 200,
    ν = 0.3 and E = 50, ν = 0.3): prepare() logs one warning per region, each naming its
    region and the material's own E; the warnings named only the law, twice alike.
    Serial and on every rank of 2–3."""
    import logging

    from dolfinx_mortar import register_law
    from dolfinx_mortar.runner import prepare

    register_law("fixed", lambda F, E_, nu_: _hand_neo_hooke(F, 100.0, 0.25))
    scene = parse_scene(
        {
            "kinematics": "finite",
            "mesh": {"generator": "patch2d", "params": {"n_lower": 2, "n_upper": 3, "n_y": 1}},
            "material": [
                {"region": "lower", "model": "fixed", "E": 200.0, "nu": NU},
                {"region": "upper", "model": "fixed", "E": 50.0, "nu": NU},
            ],
            "steps": {"n": 1},
        },
        tmp_path,
    )
    with caplog.at_level(logging.WARNING, logger="dolfinx_mortar.bulk"):
        problem, _ = prepare(scene, MPI.COMM_WORLD)
    problem.destroy()
    messages = [r.message for r in caplog.records if r.name == "dolfinx_mortar.bulk"]
    assert len(messages) == 2
    lower, upper = messages
    head = "law 'fixed' (region '{}'): its small-strain moduli at F = I are E = 100, nu = 0.25"
    assert lower.startswith(head.format("lower")) and "material gives E = 200, nu" in lower
    assert upper.startswith(head.format("upper")) and "material gives E = 50, nu" in upper


@pytest.mark.mpi
@pytest.mark.parametrize(
    "model, kinematics", [("linear-elastic", "small"), ("neo-hookean", "finite")]
)
def test_constrained_rows_are_scaled_by_the_bulk_stiffness(block_msh, model, kinematics):
    """The rows of constrained dofs hold s_i (x_i − ū_i) in the residual and s_i on the
    Jacobian's diagonal, with s_i (ContactProblem.dirichlet_scale) the dof's own
    |diagonal| of the bulk stiffness at the initial state (K₀ assembled here by dolfinx
    without the conditions), on 1–3 ranks; they held x − ū and 1, a length among
    forces."""
    from dolfinx.fem.petsc import assemble_matrix, set_bc

    from dolfinx_mortar.runner import prepare

    msh = block_msh(2, n=3, quads=True)
    problem, _ = prepare(
        parse_scene(_table(msh, 2, model, kinematics, 2e-3), msh.parent), MPI.COMM_WORLD
    )
    comm = problem.comm
    K = assemble_matrix(problem.J_form)  # at u = 0
    K.assemble()
    diag = K.getDiagonal()
    n = problem.V.dofmap.index_map.size_local * problem.V.dofmap.index_map_bs
    free = problem.global_dofs[:n] >= 0
    constrained = ~free
    local, rows, s = problem.dirichlet_scale()
    assert np.array_equal(local, np.flatnonzero(constrained))
    assert np.array_equal(rows, problem.global_dofs_all[local])
    assert np.allclose(s, np.abs(diag.array_r[:n][constrained]), rtol=1e-12, atol=0.0)
    assert comm.allreduce(int(constrained.sum())) > 0
    assert comm.allreduce(float(s.min(initial=np.inf)), op=MPI.MIN) > 10.0  # E = 100
    problem.set_time(1.0)  # ū = 2e-3 on the right end's x
    x = problem.u.vector.copy()
    x.array[:] = 1e-4 * np.arange(x.array.size) / max(x.array.size, 1)
    problem.update_contact(x)
    b = x.duplicate()
    problem.residual(x, b)
    ubar = x.duplicate()
    ubar.set(0.0)
    set_bc(ubar, problem.bcs)  # ū on the constrained dofs
    expect = s * (x.array_r[:n] - ubar.array_r[:n])[constrained]
    assert np.allclose(b.array_r[:n][constrained], expect, rtol=1e-12, atol=1e-15)
    A = problem.create_matrix()
    problem.jacobian(x, A)
    d = A.getDiagonal()
    assert np.allclose(d.array_r[:n][constrained], s, rtol=1e-12)
    for obj in (K, diag, x, b, ubar, A, d):
        obj.destroy()


@pytest.mark.mpi
def test_min_det_F_of_homogeneous_and_corner_folded_states(block_msh):
    """ContactProblem.min_det_F on the 2 × 1 block of 3 × 3 Q1 cells (SVK): u = (F₀ − I)X
    gives det F₀ at every point checked (72: 4 Gauss points and 4 vertices per cell),
    0.6 for a stretch with shear, −1 at all 72 for the mirror y → −y. The corner node
    (2, 1) moved to X₀ + s(X₃ − X₀) in its one cell [4/3, 2] × [2/3, 1] (X₀ the opposite
    corner) gives det F = 1 + c(ξ + η), c = s − 1, in the cell's reference coordinates:
    with s = 0.4, −0.2 at the moved vertex and 1 − 0.6 · 2 · 0.7887 = 0.054 at the
    nearest Gauss point, so only the vertex sees the fold. On 1–3 ranks."""
    from dolfinx_mortar.runner import prepare

    msh = block_msh(2, n=3, quads=True)
    data = _table(msh, 2, "saint-venant-kirchhoff", "finite", 0.0)
    problem, _ = prepare(parse_scene(data, msh.parent), MPI.COMM_WORLD)
    try:
        for F0, expected, inverted in (
            ([[1.2, 0.1], [0.0, 0.5]], 0.6, 0),
            ([[1.0, 0.0], [0.0, -1.0]], -1.0, 72),
        ):
            H = np.array(F0) - np.eye(2)
            problem.u.interpolate(lambda x, H=H: H @ x[:2])
            det = problem.min_det_F()
            assert det.value == pytest.approx(expected, rel=1e-12)
            assert (det.inverted, det.checked, det.region) == (inverted, 72, "body")
        s, corner, opposite = 0.4, np.array([2.0, 1.0]), np.array([4.0 / 3.0, 2.0 / 3.0])
        u = problem.u.x.array.reshape(-1, 2)
        X = problem.V.tabulate_dof_coordinates()[:, :2]
        u[:] = 0.0
        u[np.linalg.norm(X - corner, axis=1) < 1e-9] = (s - 1.0) * (corner - opposite)
        det = problem.min_det_F()
        assert det.value == pytest.approx(2 * s - 1, rel=1e-12)
        assert det.point == pytest.approx(tuple(corner), abs=1e-12)
        assert det.inverted == 1 and det.checked == 72
        assert "det F = -0.2 at X = (2, 1) in region 'body'; 1 of 72 points" in det.describe()
    finally:
        problem.destroy()


@pytest.mark.mpi
def test_nonfinite_cause_names_inverted_elements(block_msh):
    """ContactProblem.nonfinite_cause, which the solver's message of a solve stopped on a
    non-finite residual quotes: on the 2 × 1 block of 3 × 3 Q1 cells (neo-Hookean, whose
    stress has ln J), u = (F₀ − I)X with F₀ the mirror y → −y inverts every cell: the bulk
    residual is NaN, and the cause names det F = −1 at all 72 points; for a stretch every
    part is finite (""); a NaN in the iterate is named before any assembly. On 1–3 ranks."""
    from dolfinx_mortar.runner import prepare

    msh = block_msh(2, n=3, quads=True)
    data = _table(msh, 2, "neo-hookean", "finite", 0.0)
    problem, _ = prepare(parse_scene(data, msh.parent), MPI.COMM_WORLD)
    x = problem.u.vector.copy()
    try:
        for F0, cause in (
            ([[1.2, 0.1], [0.0, 0.9]], ""),
            (
                [[1.0, 0.0], [0.0, -1.0]],
                "the bulk residual at inverted elements (det F = -1 at X = (",
            ),
        ):
            H = np.array(F0) - np.eye(2)
            problem.u.interpolate(lambda x, H=H: H @ x[:2])
            problem.u.vector.copy(x)
            b = x.duplicate()
            problem.residual(x, b, apply_bcs=False)
            assert np.all(np.isfinite(b.array_r)) == (cause == "")
            b.destroy()
            what = problem.nonfinite_cause(x)
            assert what.startswith(cause) and (cause == "") == (what == ""), what
            if cause:
                assert "in region 'body'; 72 of 72 points checked have det F <= 0)" in what
        x.array[:] = np.nan
        assert problem.nonfinite_cause(x) == "the Newton iterate itself"
    finally:
        x.destroy()
        problem.destroy()
