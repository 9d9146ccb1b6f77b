"""Scene files: parse and validate the declarative TOML input (see ``SCENES.md``).

A scene is read with :mod:`tomllib` and turned into frozen dataclasses. This module
is pure Python (no dolfinx, no MPI, no numpy) so that every rank can call it.
Every problem is reported as a :class:`~dolfinx_mortar.errors.SceneError` whose
``key`` is the dotted path of the offending entry (``material[1].nu``,
``contact[0].recovery``, ``steps.n``, ...) and whose ``reason`` is one line.

Units: the package is unit-agnostic; all quantities must use one consistent set
(e.g. length in mm, force in N, stress in MPa). "time" is the pseudo-time of the
load path.

Schema (``*`` = required; defaults in brackets)::

    title        string                      [scene file stem]
    kinematics   "finite" | "small"          ["finite"]

    [mesh] *     exactly one of:
      file       string, gmsh .msh path, relative to the scene file's directory
      generator  string, a name registered in generators.GENERATORS
      [mesh.params]  table of int / float / string / bool (only with generator)

    [[material]] *   one or more; distinct regions
      region *   string, physical group of cells
      model *    "neo-hookean" | "saint-venant-kirchhoff" | "linear-elastic" | a law
                 registered with dolfinx_mortar.register_law (``--laws FILE``)
                 (kinematics "small" requires "linear-elastic"; "finite" forbids it)
      E *        float > 0 (Young's modulus, stress units)
      nu *       float in (-1, 0.5) (Poisson's ratio)

    [[contact]]      zero or more
      slave *    string, physical group of facets (carries the mixed fields)
      master *   string, physical group of facets, != slave
      friction   float in [0, 1e6], Coulomb coefficient mu    [0.0]
      recovery   "unconstrained" | "lumped" | "constrained"   ["lumped"]
      integration "element" | "segment" | "node"             ["element"]
      quadrature_degree  int in [2, MAX_QUADRATURE_DEGREE = 30]  [None = the pair's
                 default, contact.default_quadrature_degree] (the slave
                 facet rule of "element", the segments' rule of "segment";
                 "node" has none: an error there)
      penalty    float > 0 (stress / length) or "auto"        ["auto"]
                 (at most contact.MAX_PENALTY_RATIO = 1e10 × the auto value)
      penalty_tangential  float > 0 or "auto"                 [None = penalty]
      tangential_weights  "auto" | "standard" | "dual"        ["auto"]
                 ("auto": "dual" with linear-elastic (small-strain) bodies and
                 the lumped tangential recovery, "standard" elsewhere)
      tangential_recovery "unconstrained" | "lumped" | "constrained"  ["lumped"]
      tangential_frame "slave" | "master"                     ["slave"]
                 (the plane of the tangential components: the convected slave
                 frame, or the master's convected covariant basis, METHOD.md §1)
      uzawa_tol  float >= 0 (relative; 0 = pure penalty)     [1e-6]
                 (>= 1: without friction the first round ends every step's
                 rounds and the multipliers stay 0: pure penalty)
      uzawa_max  int >= 1; >= 2 where 0 < uzawa_tol < 1       [20]
      uzawa_acceleration  "auto" | "aitken" | "anderson" | "none" | "newton"  ["auto"]
                 ("newton": with friction tangential_recovery = "lumped"
                 only; "auto": "newton" on the pairs with recovery = "lumped"
                 where it applies, "aitken" elsewhere)

    [[dirichlet]]    zero or more
      boundary * string, physical group of facets
      components list of distinct int >= 0 (< gdim)          [None = all]
      path *     rows [t, v_0, v_1, ...] (one value per component; length units)

    [[traction]]     zero or more (reference-configuration traction vector)
      boundary * string, physical group of facets
      path *     rows [t, T_x, T_y(, T_z)] (stress units)

    [steps]
      t_end        float > 0                   [1.0]
      n            int in [1, MAX_STEPS]       [10]
      max_cutbacks int >= 0                    [6]
      output_times list of float in (0, t_end] [[]]

    [solver]
      rtol         float in (0, 1)             [1e-9]
      atol         float >= 0 | "auto"         ["auto": 1e-10, never looser than
                                               rtol × the forces]
      max_it       int in [1, 100000]          [25]
      linear       "mumps" | "lu" | "superlu_dist" | "petsc"  ["mumps"]
                   ("petsc": use the [solver.petsc] options as given)
      line_search  "basic" | "bt" | "l2" | "cp"               ["l2"]
      step_depth_limit  float >= 0: the deepest penetration, in units of the
                   slave facet size h_I, that one Newton step may give a slave node
                   out of contact (the step is shortened), in every solve; 0 =
                   in first-contact solves only, with solver.FIRST_CONTACT_DEPTH_LIMIT [0]
      [solver.petsc]  table of PETSc options: string / int / float / bool values
                      (true: a bare flag, e.g. snes_monitor = true);
                      snes_linesearch_maxstep must be > 0

    [output]
      dir          string, relative to the scene file's directory
                   ["results/<scene file stem>"]
      fields       list of "displacement", "contact_pressure",
                   "tangential_traction", "gap", "contact_state"   [all]

Paths (load paths) are piecewise linear in t with constant extrapolation outside
the listed times; rows must have equal length, finite numbers and strictly
increasing t.

Public API: :func:`load_scene`, :func:`parse_scene`, :func:`dump_scene`,
:func:`check_groups`, :func:`check_components`, :func:`interpolate_path`, the
checks the Python API shares with the scene (:func:`contact_numbers`,
:func:`solver_options`, :func:`problem_inputs`, :func:`check_regions_covered`,
:func:`uzawa_acceleration_choice`, :func:`quadrature_degree_choice`), the
dataclasses, and :data:`KNOWN_GENERATORS` (a read-only snapshot of the names
registered in :data:`dolfinx_mortar.generators.GENERATORS`, the one list of
generators; a generator registered there is accepted by ``mesh.generator``).
"""

from __future__ import annotations

import bisect
import difflib
import json
import math
import os
import re
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dolfinx_mortar.errors import SceneError, SceneTypeError
from dolfinx_mortar.laws import model_names, registered_law

__all__ = [
    "KNOWN_GENERATORS",
    "LoadPath",
    "KINEMATICS",
    "RECOVERIES",
    "INTEGRATIONS",
    "LINEAR_SOLVERS",
    "LINE_SEARCHES",
    "OUTPUT_FIELDS",
    "Scene",
    "MeshSpec",
    "Material",
    "ContactPair",
    "DirichletBC",
    "TractionBC",
    "Steps",
    "SolverOptions",
    "OutputOptions",
    "load_scene",
    "parse_scene",
    "dump_scene",
    "check_groups",
    "check_components",
    "check_regions_covered",
    "contact_numbers",
    "uzawa_acceleration_choice",
    "quadrature_degree_choice",
    "solver_options",
    "problem_inputs",
    "path_argument",
    "interpolate_path",
]


def _generator_names() -> frozenset[str]:
    """The names accepted by ``mesh.generator``: the keys of
    :data:`dolfinx_mortar.generators.GENERATORS`, read at each call, so a generator
    registered there is accepted by the scene. Imported here, not at the top, because
    ``generators`` imports this module (it imports no gmsh until it builds)."""
    from dolfinx_mortar.generators import GENERATORS

    return frozenset(GENERATORS)


#: Names accepted by ``mesh.generator``: a frozenset snapshot of the keys of
#: :data:`dolfinx_mortar.generators.GENERATORS` taken at each access (the module
#: ``__getattr__`` below; declared, not bound, so that the access reaches it). Read-only:
#: register a generator in ``generators.GENERATORS`` to have the scene accept it.
KNOWN_GENERATORS: frozenset[str]


def __getattr__(name: str) -> Any:
    if name == "KNOWN_GENERATORS":
        return _generator_names()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: Allowed values of ``kinematics``.
KINEMATICS = ("finite", "small")
#: Allowed values of ``contact.recovery`` (METHOD.md section 3).
RECOVERIES = ("unconstrained", "lumped", "constrained")
#: Allowed values of ``contact.integration`` (METHOD.md section 7).
INTEGRATIONS = ("element", "segment", "node")
#: The highest ``contact.quadrature_degree``: basix's rules up to it are the
#: Xiao–Gimbutas ones (171 points on a triangle, 256 on a quadrilateral); above it they are
#: collapsed Gauss–Jacobi products whose point count grows as degree², and every point is
#: a projection per slave facet and Newton iteration. Degree 12 already brings element
#: integration on unstructured tetrahedral patches within 1.6 % (BENCHMARKS.md §4).
MAX_QUADRATURE_DEGREE = 30
#: The lowest ``contact.quadrature_degree``: a rule must integrate the mortar mass matrix
#: ∫ N_I N_J dA of linear facets exactly (degree 1 left it singular: the unconstrained and
#: constrained recoveries stopped with "singular mortar mass matrix"); quadratic facets
#: need 4 (:class:`~dolfinx_mortar.contact.MortarContact` checks that).
MIN_QUADRATURE_DEGREE = 2
#: Allowed values of ``contact.tangential_weights``: the dual (biorthogonal) basis Ψ_I of the
#: slave facets or the standard basis Φ_I (docs/method-notes.md, "Dual tangential weights");
#: the first is the default, resolved per pair by
#: :func:`dolfinx_mortar.contact.resolve_tangential_weights`.
TANGENTIAL_WEIGHTS = ("auto", "dual", "standard")
#: Allowed values of ``contact.tangential_frame`` (the first is the default): the convected
#: orthonormal slave frame, or the master's convected covariant basis (docs/method-notes.md,
#: "Friction"; :class:`dolfinx_mortar.friction.MasterFrames`).
TANGENTIAL_FRAMES = ("slave", "master")
#: Allowed values of ``contact.uzawa_acceleration`` (docs/method-notes.md, "Uzawa
#: augmentation"; the first is the default: "newton" on the lumped pairs, else "aitken",
#: which switches to "newton" in a step whose rounds contract slowly where it applies).
UZAWA_ACCELERATIONS = ("auto", "aitken", "anderson", "none", "newton")


def exact_update_applies(friction: float, recovery: str, tangential_recovery: str) -> bool:
    """Whether ``uzawa_acceleration = "newton"`` (the exact multiplier update) is
    available for a pair: any normal recovery (the unconstrained and constrained ones
    since session 47, with the finite-difference update), and with friction (μ > 0) the
    lumped tangential one. "auto" resolves to "newton" only on the pairs with the lumped
    normal recovery among them (:func:`exact_update_default`), and on the others a step
    whose Aitken rounds are predicted to take too many switches to it
    (``uzawa.AUTO_EXACT_BOUND``)."""
    return recovery in RECOVERIES and (friction == 0.0 or tangential_recovery == "lumped")


def exact_update_default(friction: float, recovery: str, tangential_recovery: str) -> bool:
    """Whether ``uzawa_acceleration = "auto"`` is the exact update on a pair: where it
    applies (:func:`exact_update_applies`) and the normal recovery is lumped (the mixed
    recoveries take it on request, and with "auto" in a step whose Aitken rounds contract
    slowly, session 52: docs/method-notes.md, "The exact update with the mixed normal
    recoveries"; :func:`dolfinx_mortar.uzawa.resolve_acceleration`)."""
    return recovery == "lumped" and exact_update_applies(friction, recovery, tangential_recovery)


#: Allowed values of ``solver.linear``.
LINEAR_SOLVERS = ("mumps", "lu", "superlu_dist", "petsc")
#: Allowed values of ``solver.line_search`` (PETSc SNES line searches).
LINE_SEARCHES = ("basic", "bt", "l2", "cp")
#: Allowed entries of ``output.fields`` (the default is all of them, in this order).
OUTPUT_FIELDS = (
    "displacement",
    "contact_pressure",
    "tangential_traction",
    "gap",
    "contact_state",
)

LoadPath = tuple[tuple[float, ...], ...]
"""A load path: rows ``(t, v_0, v_1, ...)`` with strictly increasing ``t``."""


# --------------------------------------------------------------------------- dataclasses


@dataclass(frozen=True)
class MeshSpec:
    """Where the mesh comes from: exactly one of ``file`` and ``generator`` is set.

    Attributes
    ----------
    file:
        Absolute path of a gmsh ``.msh`` file (resolved against the scene file's
        directory), or ``None``.
    generator:
        Name of a generator registered in
        :data:`dolfinx_mortar.generators.GENERATORS`, or ``None``.
    params:
        Generator parameters (lengths in the scene's length unit, etc.); empty
        for a mesh file.
    """

    file: Path | None
    generator: str | None
    params: dict[str, int | float | str | bool] = field(default_factory=dict)


@dataclass(frozen=True)
class Material:
    """A hyperelastic material assigned to one physical group of cells.

    Attributes
    ----------
    region:
        Name of the physical group of cells.
    model:
        ``"neo-hookean"``, ``"saint-venant-kirchhoff"``, ``"linear-elastic"`` or the
        name of a law registered with :func:`dolfinx_mortar.register_law`.
    E:
        Young's modulus (stress unit, e.g. MPa), > 0.
    nu:
        Poisson's ratio (dimensionless), in (-1, 0.5).
    """

    region: str
    model: str
    E: float
    nu: float


@dataclass(frozen=True)
class ContactPair:
    """One slave/master contact pair.

    Attributes
    ----------
    slave, master:
        Names of physical groups of facets; the slave carries the mixed fields.
    friction:
        Coulomb coefficient mu (dimensionless), >= 0; 0 = frictionless.
    recovery:
        ``"unconstrained"``, ``"lumped"`` or ``"constrained"`` (METHOD.md section 3).
    integration:
        ``"element"``, ``"segment"`` or ``"node"`` (METHOD.md section 7).
    quadrature_degree:
        Degree of the Gauss rule on each slave facet (``"element"``) or on each segment
        (``"segment"``), an integer in [2 (4 on quadratic facets),
        :data:`MAX_QUADRATURE_DEGREE`], or ``None``
        (default: :func:`dolfinx_mortar.contact.default_quadrature_degree`: 7 on P1 lines
        and quadrilaterals, 4 on P1 triangles (12 with element integration and no
        friction), 11 on P2 lines and quadrilaterals, 6 on P2 triangles). Not with
        ``"node"`` (its points are the slave nodes).
    penalty:
        Normal penalty epsilon_N (stress per length, e.g. MPa/mm), > 0, or ``"auto"``.
    penalty_tangential:
        Tangential penalty epsilon_T (stress per length), > 0, ``"auto"``, or
        ``None`` meaning "same as ``penalty``" (see :attr:`penalty_t`).
    tangential_weights:
        Weight functions of the tangential mixed field (friction only): ``"standard"``
        (the shape functions themselves), ``"dual"`` (the biorthogonal basis of the slave
        facets closed at t_n) or ``"auto"`` (default: ``"dual"`` where every body is
        linear-elastic, i.e. small strain, and the tangential recovery is lumped;
        ``"standard"`` elsewhere); docs/method-notes.md, "Dual tangential weights".
    tangential_recovery:
        Recovery of the tangential mixed fields (friction only): ``"lumped"`` (the nodal
        return mapping, default), ``"unconstrained"`` (τ = M⁻¹F) or ``"constrained"``
        (the Coulomb-cone projection with the full mortar matrix);
        docs/method-notes.md, "Tangential recoveries".
    tangential_frame:
        Where the tangential components live (friction only): ``"slave"`` (default: an
        orthonormal frame convected with the slave surface at each node) or ``"master"``
        (the paper's convected curvilinear coordinates of the master: covariant basis,
        metric and contravariant slip components at the material point the node faced
        at t_n); docs/method-notes.md, "Friction".
    uzawa_tol:
        Relative tolerance on the multiplier change (dimensionless), >= 0;
        0 = pure penalty. The change of a round is max|p̂ − λ| / max p̂, which is 1 in
        the first round of the first step whose contact carries load (λ starts at 0):
        a value >= 1 ends the rounds there and λ stays 0 (pure penalty, in effect).
    uzawa_max:
        Maximum number of Uzawa augmentations per load step, >= 1; >= 2 where
        0 < uzawa_tol < 1 (one round never converges there).
    uzawa_acceleration:
        Update of the multipliers between Uzawa rounds: ``"aitken"`` (Irons–Tuck
        relaxation), ``"anderson"`` (Anderson, depth 5), ``"none"`` (plain),
        ``"newton"`` (the exact update of the multipliers; with friction, pairs with the
        lumped tangential recovery only) or ``"auto"`` (default: ``"newton"`` on the
        pairs with the lumped recovery where it applies, ``"aitken"`` on the other pairs;
        :func:`dolfinx_mortar.uzawa.resolve_acceleration`).
    """

    slave: str
    master: str
    friction: float = 0.0
    recovery: str = "lumped"
    integration: str = "element"
    quadrature_degree: int | None = None
    penalty: float | str = "auto"
    penalty_tangential: float | str | None = None
    tangential_weights: str = "auto"
    tangential_recovery: str = "lumped"
    tangential_frame: str = "slave"
    uzawa_tol: float = 1e-6
    uzawa_max: int = 20
    uzawa_acceleration: str = "auto"

    @property
    def name(self) -> str:
        """``"SLAVE:MASTER"``, the key used in ``summary.json``."""
        return f"{self.slave}:{self.master}"

    @property
    def penalty_t(self) -> float | str:
        """Effective tangential penalty: ``penalty_tangential``, else ``penalty``."""
        return self.penalty if self.penalty_tangential is None else self.penalty_tangential


@dataclass(frozen=True)
class DirichletBC:
    """Prescribed displacement on a physical group of facets.

    Attributes
    ----------
    boundary:
        Name of the physical group of facets.
    components:
        Constrained displacement components (0 = x, 1 = y, 2 = z), or ``None``
        for all components.
    path:
        Rows ``(t, u_0, u_1, ...)``: one displacement value (length unit) per
        constrained component, piecewise linear in t.
    """

    boundary: str
    components: tuple[int, ...] | None
    path: LoadPath

    def value(self, t: float) -> tuple[float, ...]:
        """Prescribed displacement values at time ``t`` (see :func:`interpolate_path`)."""
        return interpolate_path(self.path, t)


@dataclass(frozen=True)
class TractionBC:
    """Reference-configuration traction vector on a physical group of facets.

    Attributes
    ----------
    boundary:
        Name of the physical group of facets.
    path:
        Rows ``(t, T_x, T_y[, T_z])``: force per unit reference area (stress
        unit), piecewise linear in t.
    """

    boundary: str
    path: LoadPath

    def value(self, t: float) -> tuple[float, ...]:
        """Traction vector at time ``t`` (see :func:`interpolate_path`)."""
        return interpolate_path(self.path, t)


@dataclass(frozen=True)
class Steps:
    """Load stepping.

    Attributes
    ----------
    t_end:
        Final pseudo-time, > 0; steps run from 0 to ``t_end``.
    n:
        Initial number of equal steps, in [1, MAX_STEPS].
    max_cutbacks:
        How many times a failed step may be halved, >= 0.
    output_times:
        Extra times in (0, t_end] that must be hit exactly (sorted, distinct).
    """

    t_end: float = 1.0
    n: int = 10
    max_cutbacks: int = 6
    output_times: tuple[float, ...] = ()


@dataclass(frozen=True)
class SolverOptions:
    """Nonlinear (SNES) and linear solver options.

    Attributes
    ----------
    rtol:
        SNES relative residual tolerance (dimensionless), > 0.
    atol:
        SNES absolute residual tolerance (force unit), >= 0, or ``"auto"`` (default):
        1e-10, but never looser than rtol × the size of the forces (the largest first
        residual norm of the solves so far; ``solver.AUTO_ATOL``).
    max_it:
        Maximum Newton iterations per solve, >= 1.
    linear:
        ``"mumps"``, ``"lu"``, ``"superlu_dist"`` (direct) or ``"petsc"`` (use
        :attr:`petsc` as given).
    line_search:
        SNES line search: ``"l2"`` (default: secant on the residual norm, robust when the
        active set changes; never beyond the full Newton step,
        :data:`dolfinx_mortar.solver.L2_MAX_STEP`), ``"basic"`` (full Newton step),
        ``"bt"``, ``"cp"``.
    petsc:
        Extra PETSc options, names without the leading ``-`` (``{"ksp_type": "gmres"}``).
    step_depth_limit:
        Penetration-limited Newton steps (dimensionless, >= 0): a Newton step is
        shortened so that no slave node out of contact penetrates deeper than
        ``step_depth_limit`` × h_I (the nodal facet size), in every solve; 0: only in
        first-contact solves, with ``solver.FIRST_CONTACT_DEPTH_LIMIT``.
    """

    rtol: float = 1e-9
    atol: float | str = "auto"
    max_it: int = 25
    linear: str = "mumps"
    line_search: str = "l2"
    petsc: dict[str, str | int | float | bool] = field(default_factory=dict)
    step_depth_limit: float = 0.0


@dataclass(frozen=True)
class OutputOptions:
    """What to write, and where.

    Attributes
    ----------
    dir:
        Output directory (absolute when the scene came from a file; the command
        line's ``--out`` overrides it).
    fields:
        Fields written per converged step, a subset of :data:`OUTPUT_FIELDS`.
    """

    dir: Path
    fields: tuple[str, ...] = OUTPUT_FIELDS


@dataclass(frozen=True)
class Scene:
    """A validated scene (see the module docstring for the schema).

    Attributes
    ----------
    title:
        Free text (default: the scene file's stem).
    kinematics:
        ``"finite"`` or ``"small"``.
    mesh, materials, contacts, dirichlet, tractions, steps, solver, output:
        The sections of the scene file, in file order.
    source:
        Where the scene came from (the absolute file path, or ``"<dict>"``).
    base_dir:
        Directory against which relative paths were resolved.
    laws:
        ``(name, psi)`` of each registered law the materials name, as registered when
        the scene was parsed: a run refuses the scene where one was registered again
        since (:func:`dolfinx_mortar.runner.prepare`).
    """

    title: str
    kinematics: str
    mesh: MeshSpec
    materials: tuple[Material, ...]
    contacts: tuple[ContactPair, ...]
    dirichlet: tuple[DirichletBC, ...]
    tractions: tuple[TractionBC, ...]
    steps: Steps
    solver: SolverOptions
    output: OutputOptions
    source: str
    base_dir: Path
    laws: tuple = ()

    @property
    def frictional(self) -> bool:
        """True when any contact pair has a positive friction coefficient."""
        return any(c.friction > 0.0 for c in self.contacts)


# --------------------------------------------------------------------------- helpers

_MISSING = object()


def _key(prefix: str, name: str) -> str:
    """Dotted key ``prefix.name`` (or ``name`` at top level)."""
    return f"{prefix}.{name}" if prefix else name


def _plain(value: Any) -> Any:
    """``value`` with NumPy scalars and arrays (a Python caller's, e.g. ``np.int64(4)``
    for ``steps.n`` or an array for a ``path``) made the Python numbers and lists that TOML
    gives, in nested tables and arrays, and a range a list (local)."""
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple | range):
        return [_plain(v) for v in value]
    if type(value).__module__ == "numpy" and hasattr(value, "tolist"):
        return _plain(value.tolist())  # a scalar gives a number, an array nested lists
    return value


def _type_name(value: Any) -> str:
    """TOML-flavoured name of the type of ``value`` for messages."""
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "float"
    if isinstance(value, str):
        return "string"
    if isinstance(value, Mapping):
        return "table"
    if isinstance(value, list | tuple):
        return "array"
    return type(value).__name__


def _show(value: Any) -> str:
    """Short representation of an offending value (a boolean as TOML writes it)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _suggest(word: str, choices: Sequence[str] | set[str]) -> str:
    """``"; did you mean 'x'?"`` for the closest choice, or an empty string (also where
    ``word`` or a choice is not a string: difflib would raise a TypeError)."""
    choices = [c for c in choices if isinstance(c, str)]
    if not choices or not isinstance(word, str):
        return ""
    close = difflib.get_close_matches(word, list(choices), n=len(choices), cutoff=0.6)
    if not close:
        return ""
    # best score first; ties broken alphabetically (difflib prefers the larger string)
    best = min(close, key=lambda c: (-difflib.SequenceMatcher(None, word, c).ratio(), c))
    return f"; did you mean '{best}'?"


def _check_keys(table: Mapping[str, Any], allowed: Sequence[str], prefix: str) -> None:
    """Reject keys of ``table`` not in ``allowed``."""
    for name in table:
        if name not in allowed:
            raise SceneError(
                _key(prefix, name),
                f"unknown key (allowed: {', '.join(allowed)}){_suggest(name, allowed)}",
            )


def _get(table: Mapping[str, Any], name: str, prefix: str, default: Any = _MISSING) -> Any:
    """``table[name]``, or ``default``; a missing required key raises SceneError."""
    if name in table:
        return table[name]
    if default is _MISSING:
        raise SceneError(_key(prefix, name), "required key is missing")
    return default


def _table(value: Any, key: str) -> Mapping[str, Any]:
    """Check that ``value`` is a table, its keys strings (a Python caller's dict may have
    others: ``{1: 2}``, ``{None: 0}``)."""
    if not isinstance(value, Mapping):
        raise SceneTypeError(key, f"expected a table, got {_type_name(value)} {_show(value)}")
    for name in value:
        if not isinstance(name, str):
            raise SceneTypeError(
                key, f"keys must be strings, got {_type_name(name)} key {_show(name)}"
            )
    return value


def _tables(value: Any, key: str) -> list[Mapping[str, Any]]:
    """Check that ``value`` is an array of tables (``[[key]]``)."""
    if isinstance(value, Mapping):
        raise SceneError(key, f"expected an array of tables ([[{key}]]), got a single table")
    if not isinstance(value, list | tuple):
        raise SceneTypeError(
            key, f"expected an array of tables ([[{key}]]), got {_type_name(value)}"
        )
    for i, item in enumerate(value):
        _table(item, f"{key}[{i}]")
    return list(value)


def _string(value: Any, key: str) -> str:
    """Check that ``value`` is a string."""
    if not isinstance(value, str):
        raise SceneTypeError(key, f"expected a string, got {_type_name(value)} {_show(value)}")
    return value


def _nonempty_string(value: Any, key: str) -> str:
    """Check that ``value`` is a non-blank string."""
    text = _string(value, key)
    if not text.strip():
        raise SceneError(key, "must not be empty")
    return text


def _choice(value: Any, key: str, choices: Sequence[str], hint: str = "") -> str:
    """Check that ``value`` is one of ``choices`` (``hint`` ends the error message)."""
    text = _string(value, key)
    if text not in choices:
        options = ", ".join(f'"{c}"' for c in choices)
        raise SceneError(
            key, f"unknown value {text!r} (choices: {options}){_suggest(text, choices)}{hint}"
        )
    return text


def finite_float(value: int | float) -> float | None:
    """``value`` (an int or a float) as a float, or None where that is not finite: a
    nan, an inf, or an integer too big for a float (TOML's integers are unbounded:
    ``E = 1`` followed by 400 zeros; float() raises OverflowError)."""
    try:
        x = float(value)
    except OverflowError:
        return None
    return x if math.isfinite(x) else None


def number_text(value: int | float) -> str:
    """``value`` for a message: an integer too big for a float as ``1e+400`` (its
    400-digit repr would fill the line), a float as Python prints it."""
    try:
        return str(float(value))
    except OverflowError:
        digits = str(abs(int(value)))
        fraction = digits[1:4].rstrip("0")
        mantissa = digits[0] + (f".{fraction}" if fraction else "")
        return f"{'-' if value < 0 else ''}{mantissa}e+{len(digits) - 1}"


def _number(value: Any, key: str) -> float:
    """Check that ``value`` is a finite number (int or float, not bool)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SceneTypeError(key, f"expected a number, got {_type_name(value)} {_show(value)}")
    x = finite_float(value)
    if x is None:
        raise SceneError(key, f"must be a finite number, got {number_text(value)}")
    return x


#: The longest file-name stem of a slave surface's output, in bytes (UTF-8): its files
#: add "_<step>.csv" (a step number of up to 10 digits) and ".tmp" while written, within
#: the 255 bytes of a file name (a 240-character slave name stopped the run with
#: ENAMETOOLONG after the set-up).
MAX_STEM_BYTES = 255 - len("_2147483647.csv.tmp")


def contact_stem(slave: str) -> str:
    """The file-name stem of a slave surface's output: ``contact_<SLAVE>``, with every
    character of the physical name other than a letter, a digit, "_", "." or "-" replaced
    by "_" (no path separators: the files stay in the output directory)."""
    return "contact_" + re.sub(r"[^\w.-]", "_", slave)


#: The largest magnitude of a scene's integers: PETSc's and gmsh's integers are C ints
#: (32 bits). Larger ones overflowed PETSc (``solver.max_it = 9999999999999``: a
#: traceback) or wrapped around in gmsh (a generator's ``n_y = 4294967298`` meshed as 2).
C_INT_MAX = 2**31 - 1


def c_int(value: int, key: str) -> int:
    """``value`` (an int) if |value| ≤ C_INT_MAX; else a SceneError keyed ``key``."""
    if abs(value) > C_INT_MAX:
        text = str(value) if abs(value) < 10**15 else number_text(value)
        raise SceneError(key, f"must be at most {C_INT_MAX} in magnitude (a C int), got {text}")
    return int(value)


def _integer(value: Any, key: str) -> int:
    """Check that ``value`` is an integer (not bool, not float) that fits a C int."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise SceneTypeError(key, f"expected an integer, got {_type_name(value)} {_show(value)}")
    return c_int(value, key)


def _positive(value: Any, key: str) -> float:
    """A finite number > 0."""
    x = _number(value, key)
    if x <= 0.0:
        raise SceneError(key, f"must be > 0, got {x:g}")
    return x


def _nonnegative(value: Any, key: str) -> float:
    """A finite number >= 0."""
    x = _number(value, key)
    if x < 0.0:
        raise SceneError(key, f"must be >= 0, got {x:g}")
    return x


def _int_at_least(value: Any, key: str, low: int) -> int:
    """An integer >= ``low``."""
    n = _integer(value, key)
    if n < low:
        raise SceneError(key, f"must be >= {low}, got {n}")
    return n


def count_at_least(value: Any, key: str, low: int) -> int:
    """An integer >= ``low`` (a NumPy integer taken) by the scene's rules, for a Python
    API's argument (local): SceneTypeError / SceneError keyed ``key``."""
    return _int_at_least(_plain(value), key, low)


def _auto_or(number, value: Any, key: str, bound: str) -> float | str:
    """The string ``"auto"``, or a number that ``number(value, key)`` checks (``bound``:
    its condition, for the message)."""
    if isinstance(value, str):
        if value != "auto":
            raise SceneError(key, f'expected a number {bound} or "auto", got {value!r}')
        return value
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SceneTypeError(
            key, f'expected a number {bound} or "auto", got {_type_name(value)} {_show(value)}'
        )
    return number(value, key)


def _penalty(value: Any, key: str) -> float | str:
    """A penalty: a finite number > 0 or the string ``"auto"``."""
    return _auto_or(_positive, value, key, "> 0")


def _scalar_table(value: Any, key: str, petsc: bool = False) -> dict[str, int | float | str | bool]:
    """A table whose values are scalars (int, float, string or bool), floats finite.
    ``petsc``: the values are PETSc option values, checked by :func:`petsc_value`."""
    table = _table(value, key)
    out: dict[str, int | float | str | bool] = {}
    for name, item in table.items():
        if not isinstance(item, bool | int | float | str):
            raise SceneTypeError(
                _key(key, name),
                f"expected an integer, float, string or boolean, got {_type_name(item)}",
            )
        if isinstance(item, float) and not math.isfinite(item):
            raise SceneError(_key(key, name), f"must be a finite number, got {item}")
        out[name] = petsc_value(item, _key(key, name)) if petsc else item
    return out


def petsc_value(item: int | float | str | bool, key: str) -> int | float | str | bool:
    """``item``, a PETSc option's value (``[solver.petsc]`` or ``-dm_KEY VALUE``), if its
    numbers obey the scene's rules; else a SceneError keyed ``key``. An integer, or a
    string that is one (``"99999999999"``), must fit a C int (PETSc's integers are C
    ints: ``snes_max_it = 4294967297`` wrapped to 1); a float, or a string that is a
    number (``"nan"``, ``"1e400"``), must be finite. Other strings and booleans pass
    (PETSc checks them)."""
    if isinstance(item, bool):
        return item
    if isinstance(item, int):
        return c_int(item, key)
    if isinstance(item, float):
        if not math.isfinite(item):
            raise SceneError(key, f"must be a finite number, got {item}")
        return item
    try:
        whole = int(item)
    except ValueError:
        pass
    else:
        c_int(whole, key)
        return item
    try:
        x = float(item)
    except ValueError:
        return item
    if not math.isfinite(x):
        raise SceneError(key, f"must be a finite number, got {item.strip()}")
    return item


def _path(value: Any, key: str) -> LoadPath:
    """Validate a load path: non-empty rows of equal length >= 2, finite, t increasing."""
    if not isinstance(value, list | tuple):
        raise SceneTypeError(
            key, f"expected an array of rows [t, v, ...], got {_type_name(value)} {_show(value)}"
        )
    if len(value) == 0:
        raise SceneError(key, "path is empty: give at least one row [t, v, ...]")
    rows: list[tuple[float, ...]] = []
    for i, row in enumerate(value):
        if not isinstance(row, list | tuple):
            raise SceneTypeError(
                key, f"row {i} is not an array [t, v, ...]: got {_type_name(row)} {_show(row)}"
            )
        if len(row) < 2:
            raise SceneError(key, f"row {i} has {len(row)} entries; need [t, v, ...]")
        numbers = []
        for j, item in enumerate(row):
            if isinstance(item, bool) or not isinstance(item, int | float):
                raise SceneTypeError(
                    key, f"row {i} entry {j} is not a number: {_type_name(item)} {_show(item)}"
                )
            x = finite_float(item)
            if x is None:
                raise SceneError(
                    key, f"row {i} entry {j} is not a finite number: {number_text(item)}"
                )
            numbers.append(x)
        if rows and len(numbers) != len(rows[0]):
            raise SceneError(
                key,
                f"rows of unequal length: row 0 has {len(rows[0])} entries, "
                f"row {i} has {len(numbers)}",
            )
        if rows and numbers[0] <= rows[-1][0]:
            raise SceneError(
                key,
                f"path not sorted in t: t = {numbers[0]:g} in row {i} does not exceed "
                f"t = {rows[-1][0]:g} in row {i - 1} (times must increase strictly)",
            )
        rows.append(tuple(numbers))
    return tuple(rows)


def interpolate_path(path: Sequence[Sequence[float]], t: float) -> tuple[float, ...]:
    """Values of a piecewise-linear load path at time ``t``.

    Parameters
    ----------
    path:
        Rows ``(t_k, v_k0, v_k1, ...)`` with strictly increasing ``t_k``.
    t:
        Time at which to evaluate.

    Returns
    -------
    tuple of float
        ``(v_0(t), v_1(t), ...)``: linear interpolation between neighbouring rows,
        constant extrapolation before the first and after the last row.
    """
    if len(path) == 0:
        raise ValueError("interpolate_path: empty path")
    times = [float(row[0]) for row in path]
    if t <= times[0]:
        return tuple(float(v) for v in path[0][1:])
    if t >= times[-1]:
        return tuple(float(v) for v in path[-1][1:])
    k = bisect.bisect_right(times, t)  # times[k-1] <= t < times[k]
    t0, t1 = times[k - 1], times[k]
    w = (t - t0) / (t1 - t0)
    row0, row1 = path[k - 1], path[k]
    return tuple(
        (1.0 - w) * float(a) + w * float(b) for a, b in zip(row0[1:], row1[1:], strict=True)
    )


# --------------------------------------------------------------------------- sections

_TOP_KEYS = (
    "title",
    "kinematics",
    "mesh",
    "material",
    "contact",
    "dirichlet",
    "traction",
    "steps",
    "solver",
    "output",
)
_MESH_KEYS = ("file", "generator", "params")
_MATERIAL_KEYS = ("region", "model", "E", "nu")
_CONTACT_KEYS = (
    "slave",
    "master",
    "friction",
    "recovery",
    "integration",
    "quadrature_degree",
    "penalty",
    "penalty_tangential",
    "tangential_weights",
    "tangential_recovery",
    "tangential_frame",
    "uzawa_tol",
    "uzawa_max",
    "uzawa_acceleration",
)
_DIRICHLET_KEYS = ("boundary", "components", "path")
_TRACTION_KEYS = ("boundary", "path")
_STEPS_KEYS = ("t_end", "n", "max_cutbacks", "output_times")
#: The most load steps ``steps.n`` may ask for (each writes its own output)
MAX_STEPS = 1_000_000
#: The most Newton iterations ``solver.max_it`` may allow per solve: the SNES keeps a
#: residual history of 2 max_it + 11 entries (max_it = 2147483647 overflowed PETSc's
#: integer, 1e9 failed to allocate it)
MAX_IT = 100_000
#: The largest Coulomb coefficient ``friction`` taken: measured coefficients are O(1),
#: and 1e6 already sticks everywhere; friction = 1e308 overflowed μ p ε_T in the
#: return mapping (a leaked RuntimeWarning).
MAX_FRICTION = 1e6
_SOLVER_KEYS = ("rtol", "atol", "max_it", "linear", "line_search", "petsc", "step_depth_limit")
_OUTPUT_KEYS = ("dir", "fields")


def path_argument(value: Any, key: str) -> Path:
    """``value``, a path argument of the Python API (a string or an ``os.PathLike`` such
    as a ``pathlib.Path``), as a Path; anything else a SceneTypeError keyed ``key``
    (local). ``Path(None)`` was a bare TypeError from pathlib."""
    if isinstance(value, str | os.PathLike):
        try:
            return Path(value)
        except TypeError:  # an os.PathLike whose __fspath__ gives bytes
            pass
    raise SceneTypeError(
        key,
        f"expected a path (a string or a pathlib.Path), got {_type_name(value)} {_show(value)}",
    )


def _resolve(text: str, base_dir: Path) -> Path:
    """``text`` as a path, relative ones taken against ``base_dir``."""
    p = Path(text).expanduser()
    return p if p.is_absolute() else base_dir / p


def _parse_mesh(value: Any, base_dir: Path) -> MeshSpec:
    """Parse ``[mesh]``."""
    table = _table(value, "mesh")
    _check_keys(table, _MESH_KEYS, "mesh")
    has_file, has_gen = "file" in table, "generator" in table
    if has_file == has_gen:
        which = "both" if has_file else "neither"
        raise SceneError(
            "mesh", f"give exactly one of mesh.file and mesh.generator ({which} given)"
        )
    if has_file:
        if "params" in table:
            raise SceneError("mesh.params", "only allowed with mesh.generator, not mesh.file")
        text = _nonempty_string(table["file"], "mesh.file")
        return MeshSpec(file=_resolve(text, base_dir), generator=None, params={})
    name = _nonempty_string(table["generator"], "mesh.generator")
    names = _generator_names()
    known = sorted(names)
    if name not in names:
        raise SceneError(
            "mesh.generator",
            f"unknown generator {name!r} (choices: {', '.join(known)}){_suggest(name, known)}",
        )
    params = _scalar_table(table.get("params", {}), "mesh.params")
    return MeshSpec(file=None, generator=name, params=params)


def _parse_material(table: Mapping[str, Any], prefix: str, kinematics: str | None) -> Material:
    """Parse one ``[[material]]`` (``kinematics`` None: the models are not checked
    against a kinematics)."""
    _check_keys(table, _MATERIAL_KEYS, prefix)
    region = _nonempty_string(_get(table, "region", prefix), _key(prefix, "region"))
    model = _choice(
        _get(table, "model", prefix),
        _key(prefix, "model"),
        model_names(),
        " (a law of your own is registered from Python with dolfinx_mortar.register_law)",
    )
    E = _number(_get(table, "E", prefix), _key(prefix, "E"))
    nu = _number(_get(table, "nu", prefix), _key(prefix, "nu"))
    if E <= 0.0:
        raise SceneError(_key(prefix, "E"), f"Young's modulus must be > 0, got {E:g}")
    if not -1.0 < nu < 0.5:
        raise SceneError(_key(prefix, "nu"), f"Poisson's ratio must lie in (-1, 0.5), got {nu:g}")
    if kinematics == "small" and model != "linear-elastic":
        raise SceneError(
            _key(prefix, "model"),
            f'kinematics = "small" needs model = "linear-elastic", got {model!r}',
        )
    if kinematics == "finite" and model == "linear-elastic":
        raise SceneError(
            _key(prefix, "model"),
            'model "linear-elastic" needs kinematics = "small" (small-strain linear '
            "elasticity in finite kinematics is not objective); use "
            '"saint-venant-kirchhoff" or "neo-hookean"',
        )
    return Material(region=region, model=model, E=E, nu=nu)


def contact_numbers(
    prefix: str,
    friction: Any,
    penalty: Any,
    penalty_tangential: Any,
    uzawa_tol: Any,
    uzawa_max: Any,
) -> tuple[float, float | str, float | str | None, float, int]:
    """The numbers of a contact pair, checked: ``(friction, penalty, penalty_tangential,
    uzawa_tol, uzawa_max)`` as float, float or "auto", the same or None, float and int.
    The one definition of their rules, for ``[[contact]]`` and for
    :class:`~dolfinx_mortar.contact.MortarContact`'s arguments (``prefix``: the key of the
    pair, ``contact[0]`` or the term's ``key``; local).

    Raises SceneError (a ValueError) keyed ``PREFIX.NAME`` for a friction < 0 or above
    :data:`MAX_FRICTION`, a penalty
    <= 0 (or a string other than "auto"), a uzawa_tol < 0, a uzawa_max < 1 or a
    uzawa_max = 1 with 0 < uzawa_tol < 1 (it can never converge: the first round's
    relative change is 1 where the multipliers start at 0), and
    SceneTypeError (a TypeError) for a value of the wrong type."""
    friction = _number(_plain(friction), _key(prefix, "friction"))
    if friction < 0.0:
        raise SceneError(
            _key(prefix, "friction"), f"friction coefficient must be >= 0, got {friction:g}"
        )
    if friction > MAX_FRICTION:
        raise SceneError(
            _key(prefix, "friction"),
            f"friction coefficient must be at most {MAX_FRICTION:g}, got {friction:g}",
        )
    penalty = _penalty(_plain(penalty), _key(prefix, "penalty"))
    if penalty_tangential is not None:
        penalty_tangential = _penalty(
            _plain(penalty_tangential), _key(prefix, "penalty_tangential")
        )
    uzawa_tol = _nonnegative(_plain(uzawa_tol), _key(prefix, "uzawa_tol"))
    uzawa_max = _int_at_least(_plain(uzawa_max), _key(prefix, "uzawa_max"), 1)
    if uzawa_max == 1 and 0.0 < uzawa_tol < 1.0:
        # the multipliers start at 0: in the first step whose contact carries load the
        # first round's change max|p̂ − λ| / max p̂ is 1 (contact.MortarContact.uzawa_update),
        # so one round never reaches a tolerance below 1 (the run cut back 6 times and
        # stopped with "did not converge in 1 rounds")
        raise SceneError(
            _key(prefix, "uzawa_max"),
            f"1 Uzawa round cannot converge to uzawa_tol = {uzawa_tol:g}: the multipliers "
            "start at 0, so the first round's relative change is 1 in the first step whose "
            "contact carries load; set uzawa_tol = 0 for pure penalty, or "
            "uzawa_max >= 2 (default 20) for the augmented Lagrangian",
        )
    return friction, penalty, penalty_tangential, uzawa_tol, uzawa_max


def uzawa_acceleration_choice(
    prefix: str, value: Any, friction: float, recovery: str, tangential_recovery: str
) -> str:
    """``value`` of ``uzawa_acceleration`` checked: one of :data:`UZAWA_ACCELERATIONS`, and
    "newton" only where the exact update applies (:func:`exact_update_applies`). The one
    definition of its rules, for ``[[contact]]`` and for
    :class:`~dolfinx_mortar.contact.MortarContact` (``prefix``: the key of the pair; local).
    Raises SceneError keyed ``PREFIX.uzawa_acceleration`` (SceneTypeError for a value
    that is not a string)."""
    key = _key(prefix, "uzawa_acceleration")
    acceleration = _choice(_plain(value), key, UZAWA_ACCELERATIONS)
    if acceleration == "newton" and not exact_update_applies(
        friction, recovery, tangential_recovery
    ):
        raise SceneError(
            key,
            '"newton" (the exact multiplier update) needs, with friction, '
            f'tangential_recovery = "lumped", got tangential_recovery = '
            f"{tangential_recovery!r} (friction = {friction:g})",
        )
    return acceleration


def quadrature_degree_choice(prefix: str, value: Any, integration: str = "element") -> int | None:
    """``quadrature_degree`` of a contact pair's slave facet rule checked (local): None
    (the facet type's default) or an integer in [:data:`MIN_QUADRATURE_DEGREE`,
    :data:`MAX_QUADRATURE_DEGREE`], with ``integration`` "element" or "segment" (on
    quadratic facets MortarContact asks for 4 at least). The rule of the scene's
    ``[[contact]] quadrature_degree`` and of
    :class:`~dolfinx_mortar.contact.MortarContact`'s argument. Raises SceneError keyed
    ``PREFIX.quadrature_degree`` for an integer < 2 (0 stood for the default, -3 was a
    C++ length error, 1 left the mortar mass matrix singular) or above the bound, and for a degree with ``integration = "node"``
    (which has no rule: it was ignored); SceneTypeError for a non-integer (2.5 was a
    basix TypeError)."""
    if value is None:
        return None
    key = _key(prefix, "quadrature_degree")
    degree = _int_at_least(_plain(value), key, MIN_QUADRATURE_DEGREE)
    if degree > MAX_QUADRATURE_DEGREE:
        raise SceneError(
            key,
            f"must be <= {MAX_QUADRATURE_DEGREE}, got {degree} (a rule's points grow as "
            "degree²; 12 brings element integration within 1.6 % on tetrahedral patches)",
        )
    if integration == "node":
        raise SceneError(
            key,
            "node integration has no quadrature rule (its points are the slave nodes): omit "
            'quadrature_degree, or choose integration = "element" or "segment"',
        )
    return degree


def _parse_contact(table: Mapping[str, Any], prefix: str) -> ContactPair:
    """Parse one ``[[contact]]``."""
    _check_keys(table, _CONTACT_KEYS, prefix)
    slave = _nonempty_string(_get(table, "slave", prefix), _key(prefix, "slave"))
    master = _nonempty_string(_get(table, "master", prefix), _key(prefix, "master"))
    if slave == master:
        raise SceneError(_key(prefix, "master"), f"slave and master are the same group {slave!r}")
    friction, penalty, penalty_t, uzawa_tol, uzawa_max = contact_numbers(
        prefix,
        table.get("friction", 0.0),
        table.get("penalty", "auto"),
        table.get("penalty_tangential"),
        table.get("uzawa_tol", 1e-6),
        table.get("uzawa_max", 20),
    )
    recovery = _choice(table.get("recovery", "lumped"), _key(prefix, "recovery"), RECOVERIES)
    integration = _choice(
        table.get("integration", "element"), _key(prefix, "integration"), INTEGRATIONS
    )
    quadrature_degree = quadrature_degree_choice(
        prefix, table.get("quadrature_degree"), integration
    )
    weights = _choice(
        table.get("tangential_weights", TANGENTIAL_WEIGHTS[0]),
        _key(prefix, "tangential_weights"),
        TANGENTIAL_WEIGHTS,
    )
    t_recovery = _choice(
        table.get("tangential_recovery", "lumped"),
        _key(prefix, "tangential_recovery"),
        RECOVERIES,
    )
    t_frame = _choice(
        table.get("tangential_frame", TANGENTIAL_FRAMES[0]),
        _key(prefix, "tangential_frame"),
        TANGENTIAL_FRAMES,
    )
    acceleration = uzawa_acceleration_choice(
        prefix,
        table.get("uzawa_acceleration", UZAWA_ACCELERATIONS[0]),
        friction,
        recovery,
        t_recovery,
    )
    return ContactPair(
        slave=slave,
        master=master,
        friction=friction,
        recovery=recovery,
        integration=integration,
        quadrature_degree=quadrature_degree,
        penalty=penalty,
        penalty_tangential=penalty_t,
        tangential_weights=weights,
        tangential_recovery=t_recovery,
        tangential_frame=t_frame,
        uzawa_tol=uzawa_tol,
        uzawa_max=uzawa_max,
        uzawa_acceleration=acceleration,
    )


def _parse_dirichlet(table: Mapping[str, Any], prefix: str) -> DirichletBC:
    """Parse one ``[[dirichlet]]``."""
    _check_keys(table, _DIRICHLET_KEYS, prefix)
    boundary = _nonempty_string(_get(table, "boundary", prefix), _key(prefix, "boundary"))
    components: tuple[int, ...] | None = None
    if "components" in table:
        key = _key(prefix, "components")
        raw = table["components"]
        if not isinstance(raw, list | tuple):
            raise SceneTypeError(
                key, f"expected an array of integers, got {_type_name(raw)} {_show(raw)}"
            )
        if len(raw) == 0:
            raise SceneError(key, "must not be empty (omit the key to constrain all components)")
        comps = []
        for item in raw:
            if isinstance(item, bool) or not isinstance(item, int):
                raise SceneTypeError(
                    key, f"components must be integers, got {_type_name(item)} {_show(item)}"
                )
            if item < 0:
                raise SceneError(key, f"component indices must be >= 0, got {item}")
            comps.append(int(item))
        if len(set(comps)) != len(comps):
            raise SceneError(key, f"components must be distinct, got {comps}")
        components = tuple(comps)
    path_key = _key(prefix, "path")
    path = _path(_get(table, "path", prefix), path_key)
    if components is not None and len(path[0]) != 1 + len(components):
        raise SceneError(
            path_key,
            f"rows must have 1 + {len(components)} entries [t, one value per component "
            f"{list(components)}], got {len(path[0])}",
        )
    if components is None and len(path[0]) not in (3, 4):
        raise SceneError(
            path_key,
            f"rows must be [t, u_x, u_y] (2D) or [t, u_x, u_y, u_z] (3D) when all components "
            f"are constrained, got {len(path[0])} entries",
        )
    return DirichletBC(boundary=boundary, components=components, path=path)


def _check_dirichlet_overlap(dirichlet: Sequence[DirichletBC], name: str = "dirichlet") -> None:
    """Reject a ``[[dirichlet]]`` that prescribes a component of a boundary that an
    earlier one prescribes already (the second was silently ignored). Different
    boundaries that share nodes stay legal (their first prescription wins, as the
    reactions document)."""
    earlier: dict[str, list[tuple[int, tuple[int, ...] | None]]] = {}
    for i, d in enumerate(dirichlet):
        for j, comps in earlier.get(d.boundary, []):
            if comps is None and d.components is None:
                raise SceneError(
                    f"{name}[{i}]",
                    f"all components of {d.boundary!r} are already prescribed by {name}[{j}]",
                )
            common = set(d.components or comps) & set(comps or d.components)
            if common:
                raise SceneError(
                    f"{name}[{i}]",
                    f"component {min(common)} of {d.boundary!r} is already prescribed by "
                    f"{name}[{j}]",
                )
        earlier.setdefault(d.boundary, []).append((i, d.components))


def _parse_traction(table: Mapping[str, Any], prefix: str) -> TractionBC:
    """Parse one ``[[traction]]``."""
    _check_keys(table, _TRACTION_KEYS, prefix)
    boundary = _nonempty_string(_get(table, "boundary", prefix), _key(prefix, "boundary"))
    path_key = _key(prefix, "path")
    path = _path(_get(table, "path", prefix), path_key)
    if len(path[0]) not in (3, 4):
        raise SceneError(
            path_key,
            f"rows must be [t, T_x, T_y] (2D) or [t, T_x, T_y, T_z] (3D), "
            f"got {len(path[0])} entries",
        )
    return TractionBC(boundary=boundary, path=path)


def _parse_steps(value: Any) -> Steps:
    """Parse ``[steps]``."""
    table = _table(value, "steps")
    _check_keys(table, _STEPS_KEYS, "steps")
    return steps_numbers(
        "steps",
        table.get("t_end", 1.0),
        table.get("n", 10),
        table.get("max_cutbacks", 6),
        table.get("output_times", []),
    )


def steps_numbers(prefix: str, t_end: Any, n: Any, max_cutbacks: Any, output_times: Any) -> Steps:
    """The numbers of a load path, checked by the scene's rules for ``[steps]`` (one
    definition: the scene's keys, prefix "steps", and
    :class:`~dolfinx_mortar.solver.LoadStepper`'s arguments, prefix "LoadStepper"): t_end
    a finite number > 0, n an integer in [1, MAX_STEPS], max_cutbacks an integer >= 0,
    output_times an array (a list, a tuple or a 1-D numpy array) of numbers in (0, t_end].
    Raises SceneError / SceneTypeError keyed ``<prefix>.<name>`` (local)."""
    t_end = _positive(_plain(t_end), f"{prefix}.t_end")
    n = _plain(n)
    if isinstance(n, int) and not isinstance(n, bool) and n > MAX_STEPS:  # before c_int's
        raise SceneError(f"{prefix}.n", f"at most {MAX_STEPS} load steps, got {n}")
    n = _int_at_least(n, f"{prefix}.n", 1)
    max_cutbacks = _int_at_least(_plain(max_cutbacks), f"{prefix}.max_cutbacks", 0)
    raw = _plain(output_times)
    if not isinstance(raw, list | tuple):
        raise SceneTypeError(
            f"{prefix}.output_times",
            f"expected an array of numbers, got {_type_name(raw)} {_show(raw)}",
        )
    times = []
    for item in raw:
        t = _number(item, f"{prefix}.output_times")
        if not 0.0 < t <= t_end:
            raise SceneError(
                f"{prefix}.output_times", f"time {t:g} outside (0, t_end] = (0, {t_end:g}]"
            )
        times.append(t)
    return Steps(
        t_end=t_end, n=n, max_cutbacks=max_cutbacks, output_times=tuple(sorted(set(times)))
    )


def solver_options(
    prefix: str,
    rtol: Any = 1e-9,
    atol: Any = "auto",
    max_it: Any = 25,
    linear: Any = "mumps",
    line_search: Any = "l2",
    petsc: Any = None,
    step_depth_limit: Any = 0.0,
) -> SolverOptions:
    """The solver options, checked: the one definition of their rules, for ``[solver]``
    and for :class:`~dolfinx_mortar.solver.SolverSettings` (``prefix``: ``solver`` or
    ``SolverSettings``; local). PETSc option names lose a leading ``-``.

    Raises SceneError (a ValueError) keyed ``PREFIX.NAME`` for a value out of range (rtol
    outside (0, 1), atol < 0 or a string other than "auto", max_it outside [1, MAX_IT],
    an unknown linear solver or line search, step_depth_limit < 0, a non-finite PETSc
    value), SceneTypeError (a TypeError) for a value of the wrong type."""
    key = prefix
    rtol = _positive(_plain(rtol), _key(key, "rtol"))
    if rtol >= 1.0:  # PETSc's SNESSetTolerances refuses it, in the middle of the run
        raise SceneError(
            _key(key, "rtol"), f"must be < 1 (a relative residual reduction), got {rtol:g}"
        )
    atol = _auto_or(_nonnegative, _plain(atol), _key(key, "atol"), ">= 0")
    max_it = _int_at_least(_plain(max_it), _key(key, "max_it"), 1)
    if max_it > MAX_IT:
        raise SceneError(_key(key, "max_it"), f"at most {MAX_IT} Newton iterations, got {max_it}")
    linear = _choice(linear, _key(key, "linear"), LINEAR_SOLVERS)
    line_search = _choice(line_search, _key(key, "line_search"), LINE_SEARCHES)
    petsc = _scalar_table(_plain({} if petsc is None else petsc), _key(key, "petsc"), petsc=True)
    petsc = {name.lstrip("-"): item for name, item in petsc.items()}
    depth = _nonnegative(_plain(step_depth_limit), _key(key, "step_depth_limit"))
    return SolverOptions(
        rtol=rtol,
        atol=atol,
        max_it=max_it,
        linear=linear,
        line_search=line_search,
        petsc=petsc,
        step_depth_limit=depth,
    )


def _parse_solver(value: Any) -> SolverOptions:
    """Parse ``[solver]``."""
    table = _table(value, "solver")
    _check_keys(table, _SOLVER_KEYS, "solver")
    return solver_options("solver", **table)


def _parse_output(value: Any, base_dir: Path, stem: str) -> OutputOptions:
    """Parse ``[output]``."""
    table = _table(value, "output")
    _check_keys(table, _OUTPUT_KEYS, "output")
    out_dir = _nonempty_string(table.get("dir", f"results/{stem}"), "output.dir")
    raw = table.get("fields", list(OUTPUT_FIELDS))
    if not isinstance(raw, list | tuple):
        raise SceneTypeError(
            "output.fields", f"expected an array of strings, got {_type_name(raw)} {_show(raw)}"
        )
    fields: list[str] = []
    for item in raw:
        name = _choice(item, "output.fields", OUTPUT_FIELDS)
        if name in fields:
            raise SceneError("output.fields", f"field {name!r} listed twice")
        fields.append(name)
    return OutputOptions(dir=_resolve(out_dir, base_dir), fields=tuple(fields))


def _stem(source: str) -> str:
    """Scene name from its source: the file stem, or ``"scene"`` for ``"<dict>"``-like."""
    if source.startswith("<"):
        return "scene"
    return Path(source).stem or "scene"


# --------------------------------------------------------------------------- public API


def parse_scene(data: Mapping[str, Any], base_dir: Path, source: str = "<dict>") -> Scene:
    """Validate a scene given as a (TOML-decoded) dictionary.

    Parameters
    ----------
    data:
        The decoded TOML document.
    base_dir:
        Directory against which relative ``mesh.file`` and ``output.dir`` are resolved
        (the scene file's directory), a string or a ``pathlib.Path``; a relative one is
        taken from the current directory now, so the scene does not depend on later
        changes of directory.
    source:
        Where the data came from (a string), for ``Scene.source`` and the default title
        and output directory (the file stem).

    Raises
    ------
    SceneError
        On the first problem found, naming the dotted key and the reason; a
        SceneTypeError (a TypeError) for a value of the wrong type, ``base_dir`` and
        ``source`` included (``parse_scene.base_dir: expected a path (a string or a
        pathlib.Path), got NoneType None``).
    """
    base_dir = path_argument(base_dir, "parse_scene.base_dir").absolute()
    _string(source, "parse_scene.source")
    table = _table(_plain(data), "scene")
    _check_keys(table, _TOP_KEYS, "")
    stem = _stem(source)

    title = _string(table.get("title", stem), "title")
    kinematics = _choice(table.get("kinematics", "finite"), "kinematics", KINEMATICS)
    mesh = _parse_mesh(_get(table, "mesh", ""), base_dir)

    if "material" not in table:
        raise SceneError("material", "required: at least one [[material]] table")
    material_tables = _tables(table["material"], "material")
    if not material_tables:
        raise SceneError("material", "required: at least one [[material]] table")
    materials = tuple(
        _parse_material(t, f"material[{i}]", kinematics) for i, t in enumerate(material_tables)
    )
    seen: dict[str, int] = {}
    for i, m in enumerate(materials):
        if m.region in seen:
            raise SceneError(
                f"material[{i}].region",
                f"region {m.region!r} already used by material[{seen[m.region]}]",
            )
        seen[m.region] = i

    contacts = tuple(
        _parse_contact(t, f"contact[{i}]")
        for i, t in enumerate(_tables(table.get("contact", []), "contact"))
    )
    pairs: dict[tuple[str, str], int] = {}
    stems: dict[str, int] = {}
    for i, c in enumerate(contacts):
        if (c.slave, c.master) in pairs:
            raise SceneError(
                f"contact[{i}]",
                f"the pair {c.slave}:{c.master} is contact[{pairs[c.slave, c.master]}] again",
            )
        if (c.master, c.slave) in pairs:
            raise SceneError(
                f"contact[{i}]",
                f"the pair {c.slave}:{c.master} is contact[{pairs[c.master, c.slave]}] with "
                "slave and master swapped: one pair per two surfaces (the mortar "
                "integrals of a second pass would count the contact twice)",
            )
        slave_of = next((j for (sl, _), j in pairs.items() if sl == c.slave), None)
        if slave_of is not None:
            raise SceneError(
                f"contact[{i}].slave",
                f"{c.slave!r} is already the slave of contact[{slave_of}]: each pair needs "
                "a slave surface of its own (the contact output, contact_<SLAVE>_<step>.csv "
                "and the slave's fields, is per slave surface); split the physical group by "
                "master",
            )
        file_stem = contact_stem(c.slave)
        if len(file_stem.encode()) > MAX_STEM_BYTES:
            raise SceneError(
                f"contact[{i}].slave",
                f"the name is too long for its output files: {len(file_stem.encode())} bytes in "
                f"contact_<SLAVE>, at most {MAX_STEM_BYTES}",
            )
        other = stems.get(file_stem)
        if other is not None:
            raise SceneError(
                f"contact[{i}].slave",
                f"{c.slave!r} and contact[{other}].slave {contacts[other].slave!r} would "
                f"write the same files {file_stem}_<step>.csv (characters other than letters, "
                "digits, '_', '.' and '-' become '_'): rename one of the physical groups",
            )
        stems[file_stem] = i
        pairs[c.slave, c.master] = i
    dirichlet = tuple(
        _parse_dirichlet(t, f"dirichlet[{i}]")
        for i, t in enumerate(_tables(table.get("dirichlet", []), "dirichlet"))
    )
    _check_dirichlet_overlap(dirichlet)
    tractions = tuple(
        _parse_traction(t, f"traction[{i}]")
        for i, t in enumerate(_tables(table.get("traction", []), "traction"))
    )
    steps = _parse_steps(table.get("steps", {}))
    solver = _parse_solver(table.get("solver", {}))
    output = _parse_output(table.get("output", {}), base_dir, stem)
    return Scene(
        title=title,
        kinematics=kinematics,
        mesh=mesh,
        materials=materials,
        contacts=contacts,
        dirichlet=dirichlet,
        tractions=tractions,
        steps=steps,
        solver=solver,
        output=output,
        source=source,
        base_dir=base_dir,
        laws=tuple(
            (name, registered_law(name))
            for name in dict.fromkeys(m.model for m in materials)
            if registered_law(name) is not None
        ),
    )


_TOML_POSITION = re.compile(r"\(at line (\d+), column (\d+)\)")


def load_scene(path: str | Path) -> Scene:
    """Read and validate a TOML scene file.

    Relative paths in the scene are resolved against the file's directory
    (made absolute, so the result does not depend on later changes of directory).

    Raises
    ------
    SceneError
        When the file cannot be read, is not valid TOML (the message names the
        file and line; ``key`` is ``""``), or fails validation (see
        :func:`parse_scene`); a SceneTypeError (a TypeError) keyed ``load_scene.path``
        where ``path`` is neither a string nor a ``pathlib.Path``.
    """
    path = path_argument(path, "load_scene.path").expanduser()
    try:
        # "utf-8-sig": a byte-order mark (editors on Windows write one) is not TOML
        text = path.read_bytes().decode("utf-8-sig")
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise SceneError("", f"cannot read scene file {path}: {reason}") from None
    except UnicodeDecodeError as exc:
        raise SceneError("", f"{path}: not a UTF-8 text file ({exc.reason})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message = str(exc)
        match = _TOML_POSITION.search(message)
        detail = _TOML_POSITION.sub("", message).strip()
        if match:
            where = f"{path}, line {match.group(1)}, column {match.group(2)}"
            raise SceneError("", f"{where}: TOML syntax error: {detail}") from None
        raise SceneError("", f"{path}: TOML syntax error: {detail}") from None
    # the absolute path (summary.json's ``source``): a relative one named no file once
    # the run's working directory was forgotten (QA, session 65)
    return parse_scene(data, path.resolve().parent, source=str(path.resolve()))


def _group_error(
    key: str,
    name: str,
    wanted: str,
    groups: Mapping[str, int],
    other: Mapping[str, int],
    other_kind: str,
) -> SceneError:
    """The SceneError for a physical group ``name`` missing from ``groups``."""
    available = ", ".join(sorted(groups)) or "none"
    if name in other:
        return SceneError(
            key,
            f"physical group {name!r} is a {other_kind} group, not a {wanted} group "
            f"(available {wanted} groups: {available})",
        )
    return SceneError(
        key,
        f"physical group {name!r} not found among {wanted} groups (available: {available})"
        f"{_suggest(name, list(groups))}",
    )


def check_facet_group(
    key: str, name: Any, facet_groups: Mapping[str, int], cell_groups: Mapping[str, int]
) -> str:
    """Check that ``name`` is a string naming a facet group (local; the groups are the same
    on every rank): ``name``, or SceneTypeError / SceneError naming ``key`` (a cell
    group named instead is said to be one). For the Python API's surface and boundary
    names (:class:`~dolfinx_mortar.contact.MortarContact`'s slave and master,
    :meth:`~dolfinx_mortar.problem.ContactProblem.add_dirichlet_field`'s name), which
    were a KeyError from the group table."""
    if not isinstance(name, str):
        raise SceneTypeError(key, f"expected a string, got {_type_name(name)} {_show(name)}")
    if name not in facet_groups:
        raise _group_error(key, name, "facet", facet_groups, cell_groups, "cell")
    return name


_SCENE_NAMES = ("material", "contact", "dirichlet", "traction")


def check_groups(
    scene: Scene,
    cell_groups: Mapping[str, int],
    facet_groups: Mapping[str, int],
    names: Sequence[str] = _SCENE_NAMES,
) -> None:
    """Check that every physical group the scene names exists with the right dimension.

    Parameters
    ----------
    scene:
        A parsed scene (or any object with its ``materials``, ``contacts``,
        ``dirichlet`` and ``tractions``).
    cell_groups, facet_groups:
        Physical group name -> tag, for cells (dimension tdim) and facets (tdim - 1).
    names:
        The key names of the four lists (the scene's by default; the Python API's
        :class:`~dolfinx_mortar.problem.ContactProblem` names its arguments).

    Raises
    ------
    SceneError
        Naming the key (``material[0].region``, ``contact[1].slave``, ...) when a
        material region is not a cell group or a contact / boundary name is not a
        facet group, or when two materials share a region.
    """
    mat, con, dir_, tra = names
    seen: dict[str, int] = {}
    for i, m in enumerate(scene.materials):
        key = f"{mat}[{i}].region"
        if m.region not in cell_groups:
            raise _group_error(key, m.region, "cell", cell_groups, facet_groups, "facet")
        if m.region in seen:
            raise SceneError(key, f"region {m.region!r} already used by {mat}[{seen[m.region]}]")
        seen[m.region] = i

    def facet(key: str, name: str) -> None:
        check_facet_group(key, name, facet_groups, cell_groups)

    for i, c in enumerate(scene.contacts):
        facet(f"{con}[{i}].slave", c.slave)
        facet(f"{con}[{i}].master", c.master)
    for i, d in enumerate(scene.dirichlet):
        facet(f"{dir_}[{i}].boundary", d.boundary)
    for i, tr in enumerate(scene.tractions):
        facet(f"{tra}[{i}].boundary", tr.boundary)


def check_regions_covered(
    regions: Sequence[str],
    cell_groups: Mapping[str, int],
    unnamed: Sequence[str] = (),
    key: str = "material",
    entry: str = "[[material]]",
) -> None:
    """Raise SceneError(``key``) unless every cell group is one of the material
    ``regions`` (a region without a material has no bulk stiffness: its contact
    stiffness divided by zero). ``unnamed``: the groups that had no name in the mesh file
    (named by their tag); ``entry``: what a region lacks, for the message (local)."""
    unused = sorted(set(cell_groups) - set(regions))
    if unused:
        names = [
            f"{n!r} (a physical group without a name: its tag)" if n in unnamed else f"{n!r}"
            for n in unused
        ]
        raise SceneError(key, f"cell group(s) {', '.join(names)} have no {entry}")


def check_components(scene: Scene, gdim: int, names: Sequence[str] = _SCENE_NAMES) -> None:
    """Check component indices and path row lengths against the mesh dimension.

    Dirichlet components must lie in ``[0, gdim)``; Dirichlet path rows have
    ``1 + len(components)`` entries (``1 + gdim`` when all components are
    constrained); traction path rows have ``1 + gdim`` entries. ``names``: as
    :func:`check_groups`'s.

    Raises
    ------
    SceneError
        Naming ``dirichlet[i].components``, ``dirichlet[i].path`` or
        ``traction[i].path``.
    """
    _, _, dir_, tra = names
    for i, d in enumerate(scene.dirichlet):
        if d.components is not None:
            bad = [c for c in d.components if not 0 <= c < gdim]
            if bad:
                raise SceneError(
                    f"{dir_}[{i}].components",
                    f"component {bad[0]} out of range [0, {gdim}) for a {gdim}D mesh",
                )
        n = gdim if d.components is None else len(d.components)
        if len(d.path[0]) != 1 + n:
            what = "all components" if d.components is None else f"components {list(d.components)}"
            raise SceneError(
                f"{dir_}[{i}].path",
                f"rows must have 1 + {n} entries for {what} of a {gdim}D mesh, "
                f"got {len(d.path[0])}",
            )
    for i, tr in enumerate(scene.tractions):
        if len(tr.path[0]) != 1 + gdim:
            raise SceneError(
                f"{tra}[{i}].path",
                f"rows must have 1 + {gdim} entries [t, traction vector] for a {gdim}D mesh, "
                f"got {len(tr.path[0])}",
            )


@dataclass(frozen=True)
class ProblemInputs:
    """The checked arguments of :class:`~dolfinx_mortar.problem.ContactProblem`, in the
    scene's dataclasses (see :func:`problem_inputs`)."""

    materials: tuple[Material, ...]
    dirichlet: tuple[DirichletBC, ...]
    tractions: tuple[TractionBC, ...]
    degree: int | None = None
    contacts: tuple[ContactPair, ...] = ()


#: The key names of :class:`~dolfinx_mortar.problem.ContactProblem`'s arguments
PROBLEM_NAMES = ("materials", "contacts", "dirichlet", "tractions")


def _entry(value: Any, key: str, fields: Sequence[str]) -> dict[str, Any]:
    """``value``, a sequence of len(fields) items, as a table ``{field: item}``."""
    value = _plain(value)
    if not isinstance(value, list | tuple) or len(value) != len(fields):
        raise SceneTypeError(
            key, f"expected a tuple ({', '.join(fields)}), got {_type_name(value)} {_show(value)}"
        )
    return dict(zip(fields, value, strict=True))


def problem_inputs(
    materials: Any,
    dirichlet: Any,
    tractions: Any,
    cell_groups: Mapping[str, int],
    facet_groups: Mapping[str, int],
    gdim: int,
    unnamed: Sequence[str] = (),
    degree: Any = None,
) -> ProblemInputs:
    """:class:`~dolfinx_mortar.problem.ContactProblem`'s ``materials`` (``(region, model,
    E, nu)`` each), ``dirichlet`` (``(boundary, components or None, path)``) and
    ``tractions`` (``(boundary, path)``) checked by the scene's rules for
    ``[[material]]``, ``[[dirichlet]]`` and ``[[traction]]`` (the same definitions:
    regions and boundaries that exist, every cell group a material, E > 0, ν in
    (−1, 0.5), known models, paths with rows of one length that fits the components and
    the mesh's dimension, finite numbers and strictly increasing t, components in
    [0, gdim), no component prescribed twice), and ``degree`` None or an integer >= 1.
    Keys name the argument: ``materials[1].nu``, ``dirichlet[0].path``,
    ``tractions[0].boundary``, ``degree``. ``unnamed``: the cell groups without a name in
    the mesh file (local).

    Raises SceneError (a ValueError) or SceneTypeError (a TypeError)."""
    mat, _, dir_, tra = PROBLEM_NAMES
    lists = {}
    for name, value in ((mat, materials), (dir_, dirichlet), (tra, tractions)):
        value = _plain(value) if type(value).__module__ == "numpy" else value
        # any iterable of entries (a generator too), but not a table or a string
        if isinstance(value, str | bytes | Mapping) or not isinstance(value, Iterable):
            raise SceneTypeError(
                name, f"expected a sequence of tuples, got {_type_name(value)} {_show(value)}"
            )
        lists[name] = list(value)
    if not lists[mat]:
        raise SceneError(mat, "required: at least one (region, model, E, nu)")
    mats = tuple(
        _parse_material(_entry(m, f"{mat}[{i}]", _MATERIAL_KEYS), f"{mat}[{i}]", None)
        for i, m in enumerate(lists[mat])
    )
    bcs = []
    for i, d in enumerate(lists[dir_]):
        table = _entry(d, f"{dir_}[{i}]", _DIRICHLET_KEYS)
        if table["components"] is None:
            del table["components"]
        bcs.append(_parse_dirichlet(_plain(table), f"{dir_}[{i}]"))
    _check_dirichlet_overlap(bcs, dir_)
    loads = tuple(
        _parse_traction(_plain(_entry(t, f"{tra}[{i}]", _TRACTION_KEYS)), f"{tra}[{i}]")
        for i, t in enumerate(lists[tra])
    )
    if degree is not None:
        degree = _int_at_least(_plain(degree), "degree", 1)
    inputs = ProblemInputs(mats, tuple(bcs), loads, degree)
    check_groups(inputs, cell_groups, facet_groups, PROBLEM_NAMES)
    check_regions_covered(
        [m.region for m in mats], cell_groups, unnamed, mat, "material (region, model, E, nu)"
    )
    check_components(inputs, gdim, PROBLEM_NAMES)
    return inputs


def _toml_value(value: Any, key: str) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        if not math.isfinite(value):
            raise SceneError(key, f"cannot write the non-finite number {value!r} to TOML")
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a valid TOML basic string
    if isinstance(value, Sequence):
        return "[" + ", ".join(_toml_value(v, key) for v in value) + "]"
    raise SceneError(key, f"cannot write a {_type_name(value)} to TOML")


def _toml_table(table: Mapping[str, Any], name: str, out: list[str]) -> None:
    def is_tables(v):
        return (
            isinstance(v, Sequence)
            and not isinstance(v, str)
            and v
            and all(isinstance(x, Mapping) for x in v)
        )

    for k, v in table.items():
        if not isinstance(v, Mapping) and not is_tables(v):
            out.append(f"{k} = {_toml_value(v, _key(name, k))}")
    for k, v in table.items():
        sub = f"{name}.{k}" if name else k
        if isinstance(v, Mapping):
            out.append(f"\n[{sub}]")
            _toml_table(v, sub, out)
        elif is_tables(v):
            for item in v:
                out.append(f"\n[[{sub}]]")
                _toml_table(item, sub, out)


def dump_scene(data: Mapping[str, Any]) -> str:
    """The scene dict ``data`` (the structure :func:`parse_scene` takes) as TOML text, for
    writing scene files from scripts: ``load_scene`` of the written file gives the scene
    of ``parse_scene(data)`` (paths relative to the file's directory).

    Writes strings, booleans, finite numbers, arrays, tables and arrays of tables (a
    table nested in an array of tables is written as a sub-table of its last element).
    Raises SceneError naming the key of a value TOML cannot hold (None, NaN, objects).
    """
    out: list[str] = []
    _toml_table(data, "", out)
    return "\n".join(out).lstrip("\n") + "\n"
