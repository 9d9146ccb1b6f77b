"""Tests of dolfinx_mortar.scene: parsing, defaults and validation of TOML scenes.

Pure Python: no dolfinx, no MPI.
"""

import copy
import dataclasses
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from dolfinx_mortar import scene as scene_mod
from dolfinx_mortar.errors import SceneError
from dolfinx_mortar.scene import (
    OUTPUT_FIELDS,
    ContactPair,
    check_components,
    check_groups,
    interpolate_path,
    load_scene,
    parse_scene,
)

# The example of SCENES.md, verbatim (comments included).
EXAMPLE = """
title = "2D Hertz, cylinder on block"     # free text
kinematics = "finite"                     # "finite" (default) or "small"

[mesh]
file = "hertz2d.msh"      # gmsh .msh (format 4.1 or 2.2), relative to the scene file
# or a built-in generator, for the benchmark geometries:
# generator = "hertz2d"   # see `dolfinx-mortar generators`
# [mesh.params]           # generator parameters, e.g. R = 8.0, h_contact = 0.05
# The mesh's dimension decides 2D (plane strain) or 3D.
# Physical groups are referred to by NAME everywhere below.

[[material]]
region = "cylinder"        # physical group of cells
model = "neo-hookean"      # "neo-hookean" | "saint-venant-kirchhoff" | "linear-elastic"
E = 200.0
nu = 0.3

[[contact]]
slave = "cylinder_surface" # physical group of facets (carries the mixed fields)
master = "block_top"       # physical group of facets
friction = 0.0             # Coulomb coefficient mu; 0 = frictionless
recovery = "lumped"        # "unconstrained" | "lumped" | "constrained"
integration = "element"    # "element" (slave quadrature, as in the paper) | "segment" | "node"
penalty = 1.0e4            # normal penalty epsilon_N, or "auto" (documented rule)
penalty_tangential = 1.0e4 # epsilon_T, default = penalty
uzawa_tol = 1.0e-6         # relative tolerance on multiplier change; 0 = pure penalty
uzawa_max = 20

[[dirichlet]]
boundary = "block_bottom"  # physical group of facets
components = [0, 1]        # default: all
# piecewise-linear path: rows of [t, value_0, value_1, ...] (one value per listed component)
path = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]

[[traction]]               # Neumann: reference-configuration traction vector
boundary = "cylinder_top"
path = [[0.0, 0.0, 0.0], [1.0, 0.0, -0.625]]

[steps]
t_end = 1.0
n = 10                     # initial number of equal steps
max_cutbacks = 6           # halve a step that fails, up to this many times
output_times = []          # extra times that must be hit exactly; output is written at
                           # every converged step in any case

[solver]
rtol = 1.0e-9              # SNES relative residual tolerance
atol = 1.0e-10
max_it = 25
linear = "mumps"           # direct by default; PETSc options may be given too:
# [solver.petsc] ksp_type = "gmres", pc_type = "gamg", ...

[output]
dir = "results/hertz2d"    # overridden by --out
fields = ["displacement", "contact_pressure", "tangential_traction", "gap", "contact_state"]
"""

BASE = Path("/scenes")
DELETE = object()


def example() -> dict:
    """A fresh decoded copy of the SCENES.md example."""
    return tomllib.loads(EXAMPLE)


def minimal() -> dict:
    """The smallest valid scene."""
    return {
        "mesh": {"generator": "hertz2d"},
        "material": [{"region": "body", "model": "neo-hookean", "E": 1.0, "nu": 0.3}],
    }


def mutate(data: dict, where: tuple, value) -> dict:
    """Copy of ``data`` with the entry at ``where`` set to ``value`` (or deleted)."""
    data = copy.deepcopy(data)
    node = data
    for k in where[:-1]:
        node = node[k]
    if value is DELETE:
        del node[where[-1]]
    else:
        node[where[-1]] = value
    return data


def raises(data: dict, key: str, phrase: str) -> SceneError:
    """Assert that parsing ``data`` raises a SceneError on ``key`` mentioning ``phrase``."""
    with pytest.raises(SceneError) as info:
        parse_scene(data, BASE, "/scenes/demo.toml")
    err = info.value
    assert err.key == key, str(err)
    assert phrase in err.reason, str(err)
    assert "\n" not in str(err)
    assert str(err) == f"{key}: {err.reason}"
    return err


# --------------------------------------------------------------------------- valid scenes


def test_example_parses_with_documented_values():
    s = parse_scene(example(), BASE, "/scenes/hertz.toml")
    assert s.title == "2D Hertz, cylinder on block"
    assert s.kinematics == "finite"
    assert s.mesh.file == BASE / "hertz2d.msh"
    assert s.mesh.generator is None and s.mesh.params == {}
    (m,) = s.materials
    assert (m.region, m.model, m.E, m.nu) == ("cylinder", "neo-hookean", 200.0, 0.3)
    (c,) = s.contacts
    assert c == ContactPair(
        slave="cylinder_surface",
        master="block_top",
        friction=0.0,
        recovery="lumped",
        integration="element",
        penalty=1.0e4,
        penalty_tangential=1.0e4,
        uzawa_tol=1e-6,
        uzawa_max=20,
    )
    assert c.name == "cylinder_surface:block_top"
    (d,) = s.dirichlet
    assert d.boundary == "block_bottom"
    assert d.components == (0, 1)
    assert d.path == ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    (t,) = s.tractions
    assert t.boundary == "cylinder_top"
    assert t.path == ((0.0, 0.0, 0.0), (1.0, 0.0, -0.625))
    assert t.value(0.5) == (0.0, -0.3125)
    assert (s.steps.t_end, s.steps.n, s.steps.max_cutbacks, s.steps.output_times) == (
        1.0,
        10,
        6,
        (),
    )
    assert (s.solver.rtol, s.solver.atol, s.solver.max_it, s.solver.linear) == (
        1e-9,
        1e-10,
        25,
        "mumps",
    )
    assert s.solver.line_search == "l2" and s.solver.petsc == {}
    assert s.output.dir == BASE / "results" / "hertz2d"
    assert s.output.fields == OUTPUT_FIELDS
    assert s.source == "/scenes/hertz.toml" and s.base_dir == BASE
    assert not s.frictional
    check_groups(
        s,
        {"cylinder": 1, "block": 2},
        {"cylinder_surface": 3, "block_top": 4, "block_bottom": 5, "cylinder_top": 6},
    )
    check_components(s, 2)


def test_defaults_are_filled():
    s = parse_scene(
        {
            "mesh": {"generator": "patch2d"},
            "material": [{"region": "body", "model": "saint-venant-kirchhoff", "E": 5, "nu": 0}],
            "contact": [{"slave": "a", "master": "b"}],
            "dirichlet": [{"boundary": "bottom", "path": [[0, 0, 0]]}],
        },
        BASE,
        "/scenes/patch.toml",
    )
    assert s.title == "patch"
    assert s.kinematics == "finite"
    m = s.materials[0]
    assert isinstance(m.E, float) and m.E == 5.0 and m.nu == 0.0
    c = s.contacts[0]
    assert c.friction == 0.0
    assert c.recovery == "lumped" and c.tangential_recovery == "lumped"
    assert c.tangential_frame == "slave"
    assert c.integration == "element" and c.quadrature_degree is None
    assert c.penalty == "auto"
    assert c.penalty_tangential is None and c.penalty_t == "auto"
    assert c.uzawa_tol == 1e-6 and c.uzawa_max == 20 and c.uzawa_acceleration == "auto"
    assert s.dirichlet[0].components is None
    assert s.tractions == ()
    assert s.steps == scene_mod.Steps(t_end=1.0, n=10, max_cutbacks=6, output_times=())
    assert s.solver.rtol == 1e-9 and s.solver.atol == "auto"
    assert s.solver.max_it == 25 and s.solver.linear == "mumps"
    assert s.solver.line_search == "l2" and s.solver.petsc == {}
    assert s.output.dir == BASE / "results" / "patch"
    assert s.output.fields == (
        "displacement",
        "contact_pressure",
        "tangential_traction",
        "gap",
        "contact_state",
    )


def test_defaults_for_dict_source():
    s = parse_scene(minimal(), BASE)
    assert s.title == "scene" and s.source == "<dict>"
    assert s.output.dir == BASE / "results" / "scene"
    assert s.contacts == () and s.dirichlet == ()


def test_penalty_tangential_default_and_explicit():
    data = mutate(example(), ("contact", 0, "penalty_tangential"), DELETE)
    c = parse_scene(data, BASE).contacts[0]
    assert c.penalty_tangential is None and c.penalty_t == 1.0e4
    data = mutate(example(), ("contact", 0, "penalty_tangential"), "auto")
    assert parse_scene(data, BASE).contacts[0].penalty_t == "auto"
    data = mutate(example(), ("contact", 0, "penalty"), 3)
    assert parse_scene(data, BASE).contacts[0].penalty == 3.0


def test_friction_and_small_kinematics():
    data = mutate(example(), ("contact", 0, "friction"), 0.3)
    data["kinematics"] = "small"
    data["material"][0]["model"] = "linear-elastic"
    s = parse_scene(data, BASE)
    assert s.frictional and s.contacts[0].friction == 0.3
    assert s.kinematics == "small" and s.materials[0].model == "linear-elastic"


def test_generator_params_and_solver_petsc():
    data = minimal()
    data["mesh"]["params"] = {"R": 8.0, "n": 4, "name": "x", "quad": True}
    data["solver"] = {"linear": "petsc", "petsc": {"ksp_type": "gmres", "-ksp_rtol": 1e-8}}
    data["solver"]["line_search"] = "bt"
    s = parse_scene(data, BASE)
    assert s.mesh.generator == "hertz2d" and s.mesh.file is None
    assert s.mesh.params == {"R": 8.0, "n": 4, "name": "x", "quad": True}
    assert s.solver.linear == "petsc" and s.solver.line_search == "bt"
    assert s.solver.petsc == {"ksp_type": "gmres", "ksp_rtol": 1e-8}


def test_output_times_sorted_and_fields_subset():
    data = minimal()
    data["steps"] = {"t_end": 2.0, "output_times": [2, 0.5, 1.5, 0.5]}
    data["output"] = {"fields": ["gap", "displacement"], "dir": "/abs/out"}
    s = parse_scene(data, BASE)
    assert s.steps.output_times == (0.5, 1.5, 2.0)
    assert s.output.fields == ("gap", "displacement")
    assert s.output.dir == Path("/abs/out")


def test_relative_paths_resolved_against_scene_dir():
    data = example()
    data["mesh"]["file"] = "meshes/a.msh"
    data["output"]["dir"] = "out/x"
    s = parse_scene(data, Path("/some/dir"))
    assert s.mesh.file == Path("/some/dir/meshes/a.msh")
    assert s.output.dir == Path("/some/dir/out/x")
    data["mesh"]["file"] = "/abs/b.msh"
    assert parse_scene(data, Path("/some/dir")).mesh.file == Path("/abs/b.msh")


def test_a_relative_base_dir_is_taken_from_the_current_directory(tmp_path, monkeypatch):
    """``parse_scene(data, Path("proj"))`` resolves against the current directory at parse
    time, as :func:`load_scene` does: a later os.chdir (a host program's) does not move
    the output or the mesh (the output once went to the directory of the run)."""
    data = example()
    data["mesh"]["file"] = "a.msh"
    data["output"]["dir"] = "results/p"
    monkeypatch.chdir(tmp_path)
    s = parse_scene(data, Path("proj"))
    monkeypatch.chdir("/")
    assert s.output.dir == tmp_path / "proj" / "results" / "p"
    assert s.mesh.file == tmp_path / "proj" / "a.msh"


def test_load_scene_from_file(tmp_path, monkeypatch):
    sub = tmp_path / "cases"
    sub.mkdir()
    text = EXAMPLE.replace('title = "2D Hertz, cylinder on block"', "").replace(
        'dir = "results/hertz2d"', ""
    )
    f = sub / "my_hertz.toml"
    f.write_text(text)
    s = load_scene(f)
    assert s.title == "my_hertz"
    assert s.source == str(f)
    assert s.base_dir == sub.resolve()
    assert s.mesh.file == sub.resolve() / "hertz2d.msh"
    assert s.output.dir == sub.resolve() / "results" / "my_hertz"
    assert load_scene(str(f)) == s
    # named relative to the working directory: the source is still absolute (summary.json
    # said "cases/my_hertz.toml", which named no file once the directory was forgotten)
    monkeypatch.chdir(tmp_path)
    assert load_scene("cases/../cases/my_hertz.toml").source == str(f.resolve())


def test_dataclasses_are_frozen():
    s = parse_scene(example(), BASE)
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.title = "x"
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.materials[0].E = 1.0


def test_a_generator_registered_in_the_registry_is_accepted(monkeypatch):
    from dolfinx_mortar import generators as G

    data = minimal()
    data["mesh"]["generator"] = "spiral9d"
    raises(data, "mesh.generator", "unknown generator 'spiral9d'")
    monkeypatch.setitem(G.GENERATORS, "spiral9d", G.GENERATORS["hertz2d"])
    assert parse_scene(data, BASE).mesh.generator == "spiral9d"
    assert "spiral9d" in scene_mod.KNOWN_GENERATORS


def test_the_accepted_generators_are_the_registry():
    # One list: the scene accepts exactly the names of generators.GENERATORS.
    from dolfinx_mortar import generators as G

    assert scene_mod.KNOWN_GENERATORS == frozenset(G.GENERATORS)
    assert "KNOWN_GENERATORS" in scene_mod.__all__
    with pytest.raises(AttributeError):
        scene_mod.KNOWN_GENERATORS.add("x")  # a snapshot, not a second registry
    data = minimal()
    for name in G.GENERATORS:
        data["mesh"]["generator"] = name
        assert parse_scene(data, BASE).mesh.generator == name
    data["mesh"]["generator"] = "hertz2e"
    known = ", ".join(sorted(G.GENERATORS))
    raises(
        data,
        "mesh.generator",
        f"unknown generator 'hertz2e' (choices: {known}); did you mean 'hertz2d'?",
    )


def test_module_does_not_import_dolfinx():
    code = (
        "import sys, dolfinx_mortar.scene\n"
        "bad = {'dolfinx', 'mpi4py', 'petsc4py', 'numpy'} & set(sys.modules)\n"
        "assert not bad, bad\n"
    )
    root = Path(__file__).resolve().parents[1]
    subprocess.run([sys.executable, "-c", code], check=True, cwd=root)


# --------------------------------------------------------------------------- file errors


def test_toml_syntax_error_names_file_and_line(tmp_path):
    f = tmp_path / "broken.toml"
    f.write_text('title = "x"\n[mesh\nfile = "a.msh"\n')
    with pytest.raises(SceneError) as info:
        load_scene(f)
    msg = str(info.value)
    assert info.value.key == ""
    assert str(f) in msg and "line 2" in msg and "TOML syntax error" in msg
    assert "\n" not in msg


def test_missing_file(tmp_path):
    with pytest.raises(SceneError, match="cannot read scene file"):
        load_scene(tmp_path / "nope.toml")


def test_validation_error_from_file(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text(EXAMPLE.replace("nu = 0.3", "nu = 0.5"))
    with pytest.raises(SceneError) as info:
        load_scene(f)
    assert info.value.key == "material[0].nu"


# --------------------------------------------------------------------------- validation table

# (where, value, expected key, phrase in the reason); applied to the SCENES.md example.
CASES = [
    # unknown keys, with suggestions
    (("materials",), [], "materials", "did you mean 'material'"),
    (("material", 0, "nuu"), 0.3, "material[0].nuu", "did you mean 'nu'"),
    (("contact", 0, "frction"), 0.1, "contact[0].frction", "did you mean 'friction'"),
    (("mesh", "fille"), "a", "mesh.fille", "unknown key (allowed: file, generator, params)"),
    (("steps", "nsteps"), 3, "steps.nsteps", "unknown key"),
    (("solver", "max_iter"), 3, "solver.max_iter", "did you mean 'max_it'"),
    (("output", "feilds"), [], "output.feilds", "did you mean 'fields'"),
    (("dirichlet", 0, "component"), [0], "dirichlet[0].component", "did you mean 'components'"),
    (("traction", 0, "value"), 1, "traction[0].value", "unknown key"),
    # missing required keys
    (("mesh",), DELETE, "mesh", "required key is missing"),
    (("material",), DELETE, "material", "at least one [[material]]"),
    (("material",), [], "material", "at least one [[material]]"),
    (("material", 0, "region"), DELETE, "material[0].region", "required key is missing"),
    (("material", 0, "model"), DELETE, "material[0].model", "required key is missing"),
    (("material", 0, "E"), DELETE, "material[0].E", "required key is missing"),
    (("material", 0, "nu"), DELETE, "material[0].nu", "required key is missing"),
    (("contact", 0, "slave"), DELETE, "contact[0].slave", "required key is missing"),
    (("contact", 0, "master"), DELETE, "contact[0].master", "required key is missing"),
    (("dirichlet", 0, "boundary"), DELETE, "dirichlet[0].boundary", "required key is missing"),
    (("dirichlet", 0, "path"), DELETE, "dirichlet[0].path", "required key is missing"),
    (("traction", 0, "boundary"), DELETE, "traction[0].boundary", "required key is missing"),
    (("traction", 0, "path"), DELETE, "traction[0].path", "required key is missing"),
    # wrong types
    (("title",), 3, "title", "expected a string, got integer"),
    (("material",), {"region": "a"}, "material", "array of tables ([[material]])"),
    (("contact",), "a", "contact", "array of tables"),
    (("material", 0, "E"), True, "material[0].E", "expected a number, got boolean true"),
    (("material", 0, "E"), "200", "material[0].E", "expected a number, got string"),
    (("material", 0, "region"), ["a"], "material[0].region", "expected a string, got array"),
    (("material", 0, "region"), " ", "material[0].region", "must not be empty"),
    (("contact", 0, "friction"), False, "contact[0].friction", "expected a number"),
    (("contact", 0, "uzawa_max"), 2.0, "contact[0].uzawa_max", "expected an integer, got float"),
    (("contact", 0, "uzawa_max"), True, "contact[0].uzawa_max", "expected an integer"),
    (("steps", "n"), 10.0, "steps.n", "expected an integer, got float"),
    (("steps",), 3, "steps", "expected a table"),
    (("mesh", "file"), 3, "mesh.file", "expected a string"),
    (("dirichlet", 0, "path"), "0 0 0", "dirichlet[0].path", "expected an array of rows"),
    (("dirichlet", 0, "components"), 0, "dirichlet[0].components", "expected an array"),
    (("output", "fields"), "gap", "output.fields", "expected an array of strings"),
    (("steps", "output_times"), 0.5, "steps.output_times", "expected an array of numbers"),
    (("material", 0, "E"), math.nan, "material[0].E", "finite"),
    (("material", 0, "E"), math.inf, "material[0].E", "finite"),
    # material values
    (("material", 0, "E"), 0.0, "material[0].E", "must be > 0"),
    (("material", 0, "E"), -200, "material[0].E", "must be > 0, got -200"),
    (("material", 0, "nu"), 0.5, "material[0].nu", "(-1, 0.5)"),
    (("material", 0, "nu"), 0.7, "material[0].nu", "got 0.7"),
    (("material", 0, "nu"), -1, "material[0].nu", "(-1, 0.5)"),
    (("material", 0, "model"), "neohookean", "material[0].model", "did you mean 'neo-hookean'"),
    (("material", 0, "model"), "mooney", "material[0].model", '"saint-venant-kirchhoff"'),
    (("material", 0, "model"), "linear-elastic", "material[0].model", "not objective"),
    (("kinematics",), "large", "kinematics", 'choices: "finite", "small"'),
    # contact values
    (("contact", 0, "friction"), -0.1, "contact[0].friction", "must be >= 0"),
    (("contact", 0, "recovery"), "lump", "contact[0].recovery", '"unconstrained", "lumped"'),
    (("contact", 0, "integration"), "mortar", "contact[0].integration", '"segment", "node"'),
    (("contact", 0, "quadrature_degree"), 1, "contact[0].quadrature_degree", "must be >= 2"),
    (("contact", 0, "quadrature_degree"), 31, "contact[0].quadrature_degree", "<= 30, got 31"),
    (("contact", 0, "quadrature_degree"), 6.0, "contact[0].quadrature_degree", "an integer"),
    (("contact", 0, "penalty"), 0, "contact[0].penalty", "must be > 0"),
    (("contact", 0, "penalty"), -1e4, "contact[0].penalty", "must be > 0"),
    (("contact", 0, "penalty"), "big", "contact[0].penalty", "\"auto\", got 'big'"),
    (("contact", 0, "penalty"), True, "contact[0].penalty", "got boolean"),
    (("contact", 0, "penalty_tangential"), 0.0, "contact[0].penalty_tangential", "> 0"),
    (("contact", 0, "penalty_tangential"), "x", "contact[0].penalty_tangential", '"auto"'),
    (
        ("contact", 0, "tangential_weights"),
        "biorthogonal",
        "contact[0].tangential_weights",
        '"dual"',
    ),
    (
        ("contact", 0, "tangential_recovery"),
        "mortar",
        "contact[0].tangential_recovery",
        '"constrained"',
    ),
    (("contact", 0, "tangential_frame"), "covariant", "contact[0].tangential_frame", '"master"'),
    (("contact", 0, "uzawa_tol"), -1e-6, "contact[0].uzawa_tol", "must be >= 0"),
    (("contact", 0, "uzawa_max"), 0, "contact[0].uzawa_max", "must be >= 1"),
    (("contact", 0, "uzawa_max"), 1, "contact[0].uzawa_max", "1 Uzawa round cannot converge"),
    (
        ("contact", 0, "uzawa_acceleration"),
        "broyden",
        "contact[0].uzawa_acceleration",
        '"anderson"',
    ),
    (("contact", 0, "master"), "cylinder_surface", "contact[0].master", "same group"),
    # paths
    (("dirichlet", 0, "path"), [], "dirichlet[0].path", "path is empty"),
    (("traction", 0, "path"), [[0, 0, 0], [1, 0]], "traction[0].path", "unequal length"),
    (("traction", 0, "path"), [[0, 0, 0], [1, 0, math.nan]], "traction[0].path", "not a finite"),
    (("traction", 0, "path"), [[0, 0, math.inf]], "traction[0].path", "not a finite"),
    (("traction", 0, "path"), [[1, 0, 0], [0, 0, 1]], "traction[0].path", "path not sorted in t"),
    (("traction", 0, "path"), [[0, 0, 0], [0, 0, 1]], "traction[0].path", "path not sorted in t"),
    (("traction", 0, "path"), [[0, 0, "1"]], "traction[0].path", "not a number"),
    (("traction", 0, "path"), [[0, 0, True]], "traction[0].path", "not a number"),
    (("traction", 0, "path"), [[0]], "traction[0].path", "need [t, v, ...]"),
    (("traction", 0, "path"), [0, 1], "traction[0].path", "row 0 is not an array"),
    (("traction", 0, "path"), [[0, 1]], "traction[0].path", "[t, T_x, T_y]"),
    (("dirichlet", 0, "path"), [[0, 0]], "dirichlet[0].path", "1 + 2 entries"),
    # components
    (("dirichlet", 0, "components"), [0, 0], "dirichlet[0].components", "distinct"),
    (("dirichlet", 0, "components"), [0.0, 1], "dirichlet[0].components", "must be integers"),
    (("dirichlet", 0, "components"), [True], "dirichlet[0].components", "must be integers"),
    (("dirichlet", 0, "components"), [-1, 0], "dirichlet[0].components", ">= 0"),
    (("dirichlet", 0, "components"), [], "dirichlet[0].components", "must not be empty"),
    # steps
    (("steps", "n"), 0, "steps.n", "must be >= 1"),
    (("steps", "t_end"), 0.0, "steps.t_end", "must be > 0"),
    (("steps", "t_end"), -1, "steps.t_end", "must be > 0"),
    (("steps", "max_cutbacks"), -1, "steps.max_cutbacks", "must be >= 0"),
    (("steps", "output_times"), [0.0], "steps.output_times", "outside (0, t_end]"),
    (("steps", "output_times"), [0.5, 1.5], "steps.output_times", "1.5 outside (0, t_end]"),
    (("steps", "output_times"), ["a"], "steps.output_times", "expected a number"),
    # solver
    (("solver", "rtol"), 0.0, "solver.rtol", "must be > 0"),
    (("solver", "atol"), -1e-10, "solver.atol", "must be >= 0"),
    (("solver", "atol"), "tight", "solver.atol", 'expected a number >= 0 or "auto"'),
    (("solver", "atol"), True, "solver.atol", 'expected a number >= 0 or "auto"'),
    (("solver", "max_it"), 0, "solver.max_it", "must be >= 1"),
    (("solver", "linear"), "cg", "solver.linear", '"mumps", "lu", "superlu_dist", "petsc"'),
    (("solver", "line_search"), "newton", "solver.line_search", '"basic", "bt", "l2", "cp"'),
    (("solver", "petsc"), {"a": {"b": 1}}, "solver.petsc.a", "got table"),
    (("solver", "petsc"), {"a": [1]}, "solver.petsc.a", "got array"),
    (("solver", "petsc"), "ksp_type=cg", "solver.petsc", "expected a table"),
    # output
    (("output", "fields"), ["displacement", "stress"], "output.fields", "unknown value 'stress'"),
    (("output", "fields"), ["gap", "gap"], "output.fields", "listed twice"),
    (("output", "dir"), "", "output.dir", "must not be empty"),
    # mesh
    (("mesh", "generator"), "hertz2d", "mesh", "exactly one of mesh.file and mesh.generator"),
    (("mesh",), {}, "mesh", "(neither given)"),
    (("mesh", "params"), {"R": 1.0}, "mesh.params", "only allowed with mesh.generator"),
    (("mesh",), {"generator": "hertz"}, "mesh.generator", "did you mean 'hertz2d'"),
    (("mesh",), {"generator": "hertz2d", "params": {"R": [1]}}, "mesh.params.R", "got array"),
    (("mesh",), {"generator": "hertz2d", "params": 1}, "mesh.params", "expected a table"),
]


@pytest.mark.parametrize(
    ("where", "value", "key", "phrase"),
    CASES,
    ids=[f"{c[2]}-{i}" for i, c in enumerate(CASES)],
)
def test_validation_errors(where, value, key, phrase):
    raises(mutate(example(), where, value), key, phrase)


@pytest.mark.parametrize(
    ("where", "value", "key", "reason"),
    [
        (("material", 0, "E"), 10**400, "material[0].E", "must be a finite number, got 1e+400"),
        (("contact", 0, "penalty"), -(10**400), "contact[0].penalty", "got -1e+400"),
        (
            ("traction", 0, "path"),
            [[0.0, 0.0, 0.0], [1.0, 0.0, -(12345 * 10**396)]],
            "traction[0].path",
            "row 1 entry 2 is not a finite number: -1.234e+400",
        ),
    ],
    ids=["E", "penalty", "path"],
)
def test_integers_too_big_for_a_float(where, value, key, reason):
    """TOML's integers are unbounded: one too big for a float (``E = 1`` and 400 zeros)
    is a finite-number error naming the key (it was an OverflowError traceback)."""
    with pytest.raises(SceneError) as info:
        parse_scene(mutate(example(), where, value), BASE)
    assert info.value.key == key and reason in info.value.reason, str(info.value)


@pytest.mark.parametrize(
    ("where", "value", "key"),
    [
        (("solver",), {"max_it": 9999999999999}, "solver.max_it"),
        (("steps", "max_cutbacks"), 2**31, "steps.max_cutbacks"),
        (("contact", 0, "uzawa_max"), -(2**63), "contact[0].uzawa_max"),
    ],
    ids=["max_it", "max_cutbacks", "uzawa_max"],
)
def test_integers_beyond_a_c_int(where, value, key):
    """PETSc's and gmsh's integers are C ints: a larger scene integer is an error naming
    the key (max_it was an OverflowError traceback)."""
    with pytest.raises(SceneError) as info:
        parse_scene(mutate(example(), where, value), BASE)
    assert info.value.key == key and "at most 2147483647" in info.value.reason, str(info.value)


@pytest.mark.parametrize(
    ("value", "reason"),
    [
        (4294967297, "must be at most 2147483647 in magnitude (a C int), got 4294967297"),
        (10**400, "must be at most 2147483647 in magnitude (a C int), got 1e+400"),
        ("99999999999", "must be at most 2147483647 in magnitude (a C int), got 99999999999"),
        ("nan", "must be a finite number, got nan"),
        (" 1e400", "must be a finite number, got 1e400"),
    ],
)
def test_petsc_numbers_obey_the_scene_rules(value, reason):
    """[solver.petsc] values go to PETSc, whose integers are C ints: snes_max_it =
    4294967297 wrapped to 1 (the SNES stopped after one iteration) and a 400-digit
    integer was accepted; a string that is a number obeys the same rules (session 52)."""
    with pytest.raises(SceneError) as info:
        parse_scene(mutate(example(), ("solver",), {"petsc": {"snes_max_it": value}}), BASE)
    assert str(info.value) == f"solver.petsc.snes_max_it: {reason}"


@pytest.mark.parametrize(("friction", "ok"), [(1e6, True), (1.0000001e6, False), (1e308, False)])
def test_friction_is_bounded(friction, ok):
    """friction = 1e308 ran with a leaked RuntimeWarning (μ p ε_T overflowed): at most
    scene.MAX_FRICTION = 1e6 (session 52)."""
    scene = mutate(example(), ("contact", 0, "friction"), friction)
    if ok:
        assert parse_scene(scene, BASE).contacts[0].friction == friction
        return
    with pytest.raises(SceneError) as info:
        parse_scene(scene, BASE)
    assert info.value.key == "contact[0].friction" and "at most 1e+06" in info.value.reason


def test_petsc_values_within_the_rules_pass():
    petsc = {"snes_max_it": 2147483647, "ksp_rtol": "1e-8", "ksp_type": "gmres", "a": True}
    sc = parse_scene(mutate(example(), ("solver",), {"petsc": petsc}), BASE)
    assert sc.solver.petsc == petsc


@pytest.mark.parametrize("max_it", [2147483647, 10**9])
def test_max_it_is_bounded(max_it):
    """solver.max_it sizes the SNES's residual history: 2147483647 overflowed PETSc's
    integer there and 1e9 asked for 15 GiB, both with a traceback."""
    with pytest.raises(SceneError) as info:
        parse_scene(mutate(example(), ("solver",), {"max_it": max_it}), BASE)
    assert info.value.key == "solver.max_it" and "at most 100000" in info.value.reason


def test_a_slave_name_too_long_for_its_output_files():
    """contact_<SLAVE>_<step>.csv must fit the 255 bytes of a file name (a 240-character
    name stopped the run with ENAMETOOLONG after the set-up)."""
    with pytest.raises(SceneError) as info:
        parse_scene(mutate(example(), ("contact", 0, "slave"), "s" * 240), BASE)
    assert info.value.key == "contact[0].slave" and "too long" in info.value.reason
    parse_scene(mutate(example(), ("contact", 0, "slave"), "s" * 200), BASE)


def _bc(boundary, components=None):
    n = 2 if components is None else len(components)
    d = {"boundary": boundary, "path": [[0.0] + [0.0] * n, [1.0] + [0.0] * n]}
    if components is not None:
        d["components"] = components
    return d


@pytest.mark.parametrize(
    ("second", "reason"),
    [
        (_bc("block_bottom", [1]), "component 1 of 'block_bottom' is already prescribed by"),
        (_bc("block_bottom"), "component 0 of 'block_bottom' is already prescribed by"),
    ],
    ids=["same-component", "all-components"],
)
def test_dirichlet_prescribing_a_component_twice(second, reason):
    """Two ``[[dirichlet]]`` prescribing the same component of the same boundary are a
    scene error naming the second and the first (the second was silently ignored)."""
    data = example()
    data["dirichlet"] = [_bc("block_bottom", [0, 1]), _bc("symmetry", [0]), second]
    with pytest.raises(SceneError) as info:
        parse_scene(data, BASE)
    assert str(info.value) == f"dirichlet[2]: {reason} dirichlet[0]"


def test_dirichlet_on_one_boundary_in_distinct_components_or_shared_nodes():
    """The same boundary in distinct components, and different boundaries (which may share
    nodes), stay legal; so do all components of one boundary after another's."""
    data = example()
    data["dirichlet"] = [_bc("b", [0]), _bc("b", [1]), _bc("c"), _bc("d", [1]), _bc("e")]
    assert len(parse_scene(data, BASE).dirichlet) == 5
    data["dirichlet"] = [_bc("b"), _bc("b")]
    with pytest.raises(SceneError, match=r"dirichlet\[1\]: all components of 'b'"):
        parse_scene(data, BASE)


def test_nu_accepts_int_and_negative():
    s = parse_scene(mutate(example(), ("material", 0, "nu"), 0), BASE)
    assert s.materials[0].nu == 0.0
    s = parse_scene(mutate(example(), ("material", 0, "nu"), -0.99), BASE)
    assert s.materials[0].nu == -0.99


def test_small_kinematics_needs_linear_elastic():
    data = example()
    data["kinematics"] = "small"
    raises(data, "material[0].model", 'needs model = "linear-elastic"')


def test_duplicate_material_region():
    data = example()
    data["material"].append(dict(data["material"][0]))
    raises(data, "material[1].region", "already used by material[0]")


def test_error_in_second_table_is_indexed():
    data = example()
    data["contact"].append({"slave": "a", "master": "b", "recovery": "exact"})
    raises(data, "contact[1].recovery", "unknown value 'exact'")


# --------------------------------------------------------------------------- interpolate_path


def test_interpolate_path():
    path = ((0.0, 0.0, 10.0), (1.0, 2.0, 10.0), (3.0, 2.0, 0.0))
    assert interpolate_path(path, -1.0) == (0.0, 10.0)
    assert interpolate_path(path, 0.0) == (0.0, 10.0)
    assert interpolate_path(path, 0.25) == (0.5, 10.0)
    assert interpolate_path(path, 1.0) == (2.0, 10.0)
    assert interpolate_path(path, 2.0) == pytest.approx((2.0, 5.0))
    assert interpolate_path(path, 3.0) == (2.0, 0.0)
    assert interpolate_path(path, 7.0) == (2.0, 0.0)
    assert interpolate_path(((0.5, 1.0, 2.0, 3.0),), 0.0) == (1.0, 2.0, 3.0)
    assert interpolate_path([[0, 0], [2, 4]], 1) == (2.0,)
    assert all(isinstance(v, float) for v in interpolate_path([[0, 0], [2, 4]], 1))


def test_bc_value_uses_path():
    s = parse_scene(example(), BASE)
    assert s.dirichlet[0].value(0.3) == (0.0, 0.0)
    assert s.tractions[0].value(2.0) == (0.0, -0.625)


# --------------------------------------------------------------------------- check_groups

CELLS = {"cylinder": 1, "block": 2}
FACETS = {"cylinder_surface": 3, "block_top": 4, "block_bottom": 5, "cylinder_top": 6}


@pytest.mark.parametrize(
    ("where", "value", "key"),
    [
        (("contact", 0, "slave"), "surf", "contact[0].slave"),
        (("contact", 0, "master"), "top", "contact[0].master"),
        (("dirichlet", 0, "boundary"), "bottom", "dirichlet[0].boundary"),
        (("traction", 0, "boundary"), "load", "traction[0].boundary"),
        (("material", 0, "region"), "cyl", "material[0].region"),
    ],
)
def test_check_groups_missing(where, value, key):
    s = parse_scene(mutate(example(), where, value), BASE)
    with pytest.raises(SceneError) as info:
        check_groups(s, CELLS, FACETS)
    assert info.value.key == key
    assert f"physical group '{value}' not found" in info.value.reason


def test_check_groups_exact_message():
    s = parse_scene(mutate(example(), ("contact", 0, "slave"), "foo"), BASE)
    with pytest.raises(SceneError) as info:
        check_groups(s, {"cylinder": 1}, {"a": 1, "b": 2, "c": 3})
    assert str(info.value) == (
        "contact[0].slave: physical group 'foo' not found among facet groups (available: a, b, c)"
    )


def test_check_groups_wrong_dimension():
    s = parse_scene(mutate(example(), ("contact", 0, "master"), "block"), BASE)
    with pytest.raises(SceneError) as info:
        check_groups(s, CELLS, FACETS)
    assert info.value.key == "contact[0].master"
    assert "'block' is a cell group, not a facet group" in info.value.reason

    s = parse_scene(mutate(example(), ("material", 0, "region"), "block_top"), BASE)
    with pytest.raises(SceneError) as info:
        check_groups(s, CELLS, FACETS)
    assert info.value.key == "material[0].region"
    assert "'block_top' is a facet group, not a cell group" in info.value.reason


def test_check_groups_suggests_close_name():
    s = parse_scene(mutate(example(), ("contact", 0, "master"), "block_tops"), BASE)
    with pytest.raises(SceneError, match="did you mean 'block_top'"):
        check_groups(s, CELLS, FACETS)


# --------------------------------------------------------------------------- check_components


def test_check_components():
    s = parse_scene(example(), BASE)
    check_components(s, 2)
    with pytest.raises(SceneError) as info:
        check_components(s, 3)  # traction rows have 1 + 2 entries
    assert info.value.key == "traction[0].path" and "1 + 3 entries" in info.value.reason

    data = mutate(example(), ("dirichlet", 0, "components"), [2])
    data["dirichlet"][0]["path"] = [[0, 0], [1, 0.1]]
    s = parse_scene(data, BASE)
    with pytest.raises(SceneError) as info:
        check_components(s, 2)
    assert info.value.key == "dirichlet[0].components"
    assert "out of range [0, 2)" in info.value.reason

    data = mutate(example(), ("dirichlet", 0, "components"), DELETE)
    data["traction"][0]["path"] = [[0, 0, 0, 0]]
    s = parse_scene(data, BASE)  # 2D rows for all components
    with pytest.raises(SceneError) as info:
        check_components(s, 3)
    assert info.value.key == "dirichlet[0].path"
    assert "1 + 3 entries for all components" in info.value.reason
    data["dirichlet"][0]["path"] = [[0, 0, 0, 0]]
    check_components(parse_scene(data, BASE), 3)


def test_dump_scene_round_trip(tmp_path):
    """dump_scene writes what load_scene reads back as the same scene: nested tables
    ([mesh.params]), arrays of tables, paths, strings with quotes, booleans."""
    import sys

    from dolfinx_mortar.scene import dump_scene

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "demos"))
    import demo_cattaneo2d
    import demo_hertz2d

    for data in (demo_hertz2d.scene(0, 1, "segment"), demo_cattaneo2d.scene()):
        data = dict(data, title='a "quoted" title', solver={"petsc": {"snes_monitor": True}})
        path = tmp_path / "s.toml"
        path.write_text(dump_scene(data))
        back = scene_mod.load_scene(path)
        assert back == scene_mod.parse_scene(data, tmp_path, source=back.source)


@pytest.mark.parametrize("bad, key", [(float("nan"), "steps.t_end"), (None, "steps.t_end")])
def test_dump_scene_refuses_values_toml_cannot_hold(bad, key):
    from dolfinx_mortar.scene import dump_scene

    with pytest.raises(SceneError) as exc:
        dump_scene({"steps": {"t_end": bad}})
    assert exc.value.key == key


class _BytesPath:
    """An os.PathLike whose path is bytes (pathlib refuses it with a TypeError)."""

    def __fspath__(self):
        return b"/scenes"


@pytest.mark.parametrize(
    "call, key, shown",
    [
        (lambda: parse_scene(example(), None), "parse_scene.base_dir", "NoneType None"),
        (lambda: parse_scene(example(), 3), "parse_scene.base_dir", "integer 3"),
        (lambda: parse_scene(example(), b"/scenes"), "parse_scene.base_dir", "bytes b'/scenes'"),
        (lambda: parse_scene(example(), _BytesPath()), "parse_scene.base_dir", "_BytesPath"),
        (lambda: load_scene(None), "load_scene.path", "NoneType None"),
        (lambda: load_scene(["a.toml"]), "load_scene.path", "array ['a.toml']"),
    ],
    ids=[
        "base_dir-None",
        "base_dir-int",
        "base_dir-bytes",
        "base_dir-bytes-pathlike",
        "path-None",
        "path-list",
    ],
)
def test_a_path_argument_that_is_not_a_path(call, key, shown):
    """parse_scene's base_dir and load_scene's path are a string or a pathlib.Path; else
    one SceneTypeError naming the argument (session 53: ``parse_scene(data, None)`` was
    a bare TypeError from ``Path(None)``)."""
    from dolfinx_mortar.errors import SceneTypeError

    with pytest.raises(SceneTypeError) as info:
        call()
    assert info.value.key == key
    assert info.value.reason.startswith(
        f"expected a path (a string or a pathlib.Path), got {shown}"
    )


def test_parse_scene_source_is_a_string():
    """``source`` (for the default title and output directory) is a string: None was an
    AttributeError (``'NoneType' object has no attribute 'startswith'``)."""
    from dolfinx_mortar.errors import SceneTypeError

    with pytest.raises(SceneTypeError) as info:
        parse_scene(example(), BASE, source=None)
    assert str(info.value) == "parse_scene.source: expected a string, got NoneType None"
    assert parse_scene(example(), str(BASE)) == parse_scene(example(), BASE)


@pytest.mark.parametrize(
    "where, key, shown",
    [((), "scene", "integer key 1"), (("contact", 0), "contact[0]", "NoneType key None")],
    ids=["top", "contact"],
)
def test_a_key_that_is_not_a_string(where, key, shown):
    """A Python caller's dict with a key that is not a string (``{1: 2}``, ``{None: 2}``)
    is one SceneTypeError naming the table (session 52: a TypeError from difflib)."""
    from dolfinx_mortar.errors import SceneTypeError

    data = example()
    table = data
    for w in where:
        table = table[w]
    table[1 if not where else None] = 2
    with pytest.raises(SceneTypeError) as info:
        parse_scene(data, BASE)
    assert str(info.value) == f"{key}: keys must be strings, got {shown}"


@pytest.mark.parametrize(
    "name, value",
    [
        ("recovery", "mixed"),
        ("integration", "mortar"),
        ("tangential_weights", "petrov"),
        ("tangential_recovery", "exact"),
        ("tangential_frame", "covariant"),
    ],
)
def test_mortar_contact_names_a_bad_option(name, value):
    """The Python API (``MortarContact(...)``) checks its options as the scene does: one
    SceneError naming the key and the choices, before it looks at the problem."""
    from dolfinx_mortar.contact import MortarContact

    with pytest.raises(SceneError) as err:
        MortarContact(None, "slave", "master", key="contact[0]", **{name: value})
    assert err.value.key == f"contact[0].{name}"
    assert repr(value) in str(err.value) and "is not one of" in str(err.value)


@pytest.mark.parametrize(
    "name, value, error",
    [
        ("penalty", -5.0, ValueError),
        ("penalty", 0.0, ValueError),
        ("penalty", "big", ValueError),
        ("penalty_tangential", -1.0, ValueError),
        ("friction", -0.3, ValueError),
        ("friction", "high", TypeError),
        ("uzawa_tol", -1e-6, ValueError),
        ("uzawa_max", 0, ValueError),
        ("uzawa_max", 1, ValueError),
        ("uzawa_max", 2.5, TypeError),
        ("uzawa_acceleration", "broyden", ValueError),
        ("uzawa_acceleration", 3, TypeError),
    ],
)
def test_mortar_contact_checks_its_numbers_as_the_scene_does(name, value, error):
    """``MortarContact(...)``'s numbers follow ``[[contact]]``'s rules, with the scene's
    reason (one definition, ``scene.contact_numbers``), before it looks at the problem: a
    ValueError or TypeError keyed ``KEY.NAME``. A penalty <= 0 ran and let the bodies pass
    through each other, a negative friction ran frictionless (describe() said -0.3), a
    uzawa_tol < 0 ended in "Uzawa stalled" and uzawa_max = 0 in "did not converge in 0
    rounds"."""
    from dolfinx_mortar.contact import MortarContact

    with pytest.raises(error) as err:
        MortarContact(None, "slave", "master", key="contact[0]", **{name: value})
    assert isinstance(err.value, SceneError)
    assert err.value.key == f"contact[0].{name}"
    scene_err = raises(mutate(example(), ("contact", 0, name), value), f"contact[0].{name}", "")
    assert scene_err.reason == err.value.reason
    assert isinstance(scene_err, error)


def test_one_uzawa_round_is_refused_where_it_cannot_converge():
    """``uzawa_max = 1`` with 0 < ``uzawa_tol`` < 1 is refused with one error naming
    ``contact[i].uzawa_max`` and the two ways out: the multipliers start at 0, so the
    first round's relative change max|p̂ − λ| / max p̂ is 1 in the first loaded step (a
    probe's stack of blocks: "did not converge in 1 rounds ({... 'multiplier_change':
    1.0 ...})" after 6 cutbacks). With ``uzawa_tol = 0`` (pure penalty) or ≥ 1 (the
    first round ends the rounds) one round is taken, as is any tolerance with 2."""
    data = mutate(example(), ("contact", 0, "uzawa_max"), 1)
    err = raises(mutate(data, ("contact", 0, "uzawa_tol"), 0.5), "contact[0].uzawa_max", "")
    assert err.reason == (
        "1 Uzawa round cannot converge to uzawa_tol = 0.5: the multipliers start at 0, so "
        "the first round's relative change is 1 in the first step whose contact carries "
        "load; set uzawa_tol = 0 for pure penalty, or uzawa_max >= 2 (default 20) for the "
        "augmented Lagrangian"
    )
    for tol in (0.0, 1.0, 10.0):
        c = parse_scene(mutate(data, ("contact", 0, "uzawa_tol"), tol), BASE, "/s.toml")
        assert (c.contacts[0].uzawa_max, c.contacts[0].uzawa_tol) == (1, tol)
    data = mutate(example(), ("contact", 0, "uzawa_max"), 2)
    assert parse_scene(data, BASE, "/s.toml").contacts[0].uzawa_max == 2


@pytest.mark.parametrize(
    "value, error, reason",
    [
        (0, ValueError, "must be >= 2, got 0"),
        (-3, ValueError, "must be >= 2, got -3"),
        (1, ValueError, "must be >= 2, got 1"),
        (31, ValueError, "must be <= 30, got 31"),
        (2.5, TypeError, "expected an integer, got float 2.5"),
        (True, TypeError, "expected an integer, got boolean"),
    ],
)
def test_mortar_contact_checks_its_quadrature_degree(value, error, reason):
    """``MortarContact(quadrature_degree=...)``: None (the facet type's default) or an
    integer >= 1, checked before the problem is looked at (before any collective;
    ``scene.quadrature_degree_choice``), a SceneError or SceneTypeError keyed
    ``KEY.quadrature_degree``. 0 stood for the default, -3 was a C++ length error in the
    set-up, 1 a singular mortar mass matrix, and 2.5 a basix TypeError; degree 31 would be a collapsed Gauss–Jacobi rule
    of 256 points per triangle, growing as degree² (the bound: scene.MAX_QUADRATURE_DEGREE).
    The scene's ``[[contact]] quadrature_degree`` has the same rule
    (test_a_pair_takes_a_quadrature_degree)."""
    from dolfinx_mortar.contact import MortarContact
    from dolfinx_mortar.scene import quadrature_degree_choice

    with pytest.raises(error) as err:
        MortarContact(None, "slave", "master", key="contact[0]", quadrature_degree=value)
    assert isinstance(err.value, SceneError)
    assert err.value.key == "contact[0].quadrature_degree"
    assert reason in err.value.reason
    assert quadrature_degree_choice("contact", None) is None
    assert quadrature_degree_choice("contact", 3) == 3


def test_a_pair_takes_a_quadrature_degree():
    """``[[contact]] quadrature_degree``: the pair's slave facet rule (element) or segment
    rule (segment), kept as given; with node integration, which has no rule, an error
    keyed by the key (it would be ignored), in the scene and in MortarContact alike."""
    from dolfinx_mortar.contact import MortarContact

    for integration in ("element", "segment"):
        data = example()
        data["contact"][0].update(integration=integration, quadrature_degree=6)
        c = parse_scene(data, BASE).contacts[0]
        assert c.quadrature_degree == 6 and c.integration == integration
    data = example()
    data["contact"][0].update(integration="node", quadrature_degree=6)
    with pytest.raises(SceneError) as err:
        parse_scene(data, BASE)
    assert err.value.key == "contact[0].quadrature_degree"
    assert "node integration has no quadrature rule" in err.value.reason
    with pytest.raises(SceneError) as err:
        MortarContact(None, "s", "m", integration="node", quadrature_degree=4, key="c")
    assert err.value.key == "c.quadrature_degree"
    # node integration without the key is what it was
    data["contact"][0].pop("quadrature_degree")
    assert parse_scene(data, BASE).contacts[0].quadrature_degree is None


def test_the_default_degree_follows_the_facet_integration_and_friction():
    """A pair without ``quadrature_degree``: degree 12 on P1 triangles with element
    integration and no friction (the tetrahedral patch test, BENCHMARKS.md §94), the facet
    type's DEFAULT_QUADRATURE_DEGREE otherwise (4 on P1 triangles with friction or with
    segments, 7 on P1 lines and quadrilaterals, ...)."""
    from dolfinx_mortar.contact import DEFAULT_QUADRATURE_DEGREE, default_quadrature_degree
    from dolfinx_mortar.kernels.shape import INTERVAL1, QUAD1, TRIANGLE1, TRIANGLE2

    assert default_quadrature_degree(TRIANGLE1, "element", False) == 12
    assert default_quadrature_degree(TRIANGLE1, "element", True) == 4
    assert default_quadrature_degree(TRIANGLE1, "segment", False) == 4
    for ftype in (INTERVAL1, QUAD1, TRIANGLE2):
        for integration in ("element", "segment"):
            for frictional in (False, True):
                got = default_quadrature_degree(ftype, integration, frictional)
                assert got == DEFAULT_QUADRATURE_DEGREE[ftype]


def test_numpy_values_are_taken_as_toml_numbers_and_arrays():
    """A Python caller's NumPy values (np.int64 for ``steps.n`` and generator parameters,
    np.float32, an array for a ``path``) parse as TOML's integers, floats and arrays (the
    integers were refused: "expected an integer, got int64 2")."""
    np = pytest.importorskip("numpy")
    data = example()
    data["steps"]["n"] = np.int64(3)
    data["material"][0]["E"] = np.float32(200.0)
    data["dirichlet"][0]["path"] = np.array(data["dirichlet"][0]["path"], dtype=float)
    s = parse_scene(data, Path("/some/dir"))
    assert s.steps.n == 3 and type(s.steps.n) is int
    assert s.materials[0].E == 200.0
    assert s.dirichlet[0].path == parse_scene(example(), Path("/some/dir")).dirichlet[0].path
    gen = {"generator": "patch2d", "params": {"n_lower": np.int64(2), "L": np.float64(1.5)}}
    s = parse_scene({**example(), "mesh": gen}, Path("/some/dir"))
    assert s.mesh.params["n_lower"] == 2 and type(s.mesh.params["n_lower"]) is int
