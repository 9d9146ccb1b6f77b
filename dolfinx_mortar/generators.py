"""Built-in gmsh geometries for the benchmark scenes (BENCHMARKS.md).

A scene may name a generator instead of a mesh file::

    [mesh]
    generator = "hertz2d"
    [mesh.params]
    h_contact = 0.05

:func:`build` validates the parameters, builds the geometry with the OpenCASCADE
kernel into the *current* gmsh model, meshes it and returns a metadata dict.
The caller owns gmsh: it calls ``gmsh.initialize()`` and ``gmsh.model.add(...)``
before, converts the model (``dolfinx.io.gmshio.model_to_mesh``) and finalizes
after. Only one rank (rank 0) builds; this module does not use MPI.
:func:`validate_params` checks the parameters without gmsh (for ``check``), the size
of the mesh they ask for too (at most :data:`MAX_NODES` nodes, :func:`estimate_nodes`).

Every generator tags, with NAMED physical groups, all cells of each body and
the facet groups listed below, and nothing else. The bodies are separate OCC
entities that are never fragmented together, so the two bodies of a contact
pair never share a mesh node, even where they touch. Every generator produces a
single cell type: triangles or (``quads = true``) quadrilaterals in 2D,
tetrahedra or (``quads = true``, patch3d only) hexahedra in 3D; ``order = 2``
gives the quadratic Lagrange elements (6-node triangles, 9-node quadrilaterals,
10-node tetrahedra, 27-node hexahedra) with the edge nodes on the geometry.

Mesh size: the unstructured generators take ``h_contact`` inside a box of
half-width ``c_zone`` around the initial contact point (or footprint) and let
the size grow linearly, with slope ``grading`` (dh/dx), to ``h_far`` outside it
(a gmsh ``Box`` field with a transition layer). The patch generators and
tiedcurved2d are structured (transfinite) and take element counts instead; the
ironing dies are structured with element size ``h_die``.

Generators (defaults in brackets; lengths in the scene's units)
---------------------------------------------------------------
``hertz2d``
    Plane-strain half model (x >= 0) of a cylinder on a block: the lower-right
    quarter of the disc of radius R [8] centred at (0, R + gap0) [gap0 = 0:
    touching at the origin] on the block [0, W/2] x [-H, 0] [W = H = 20].
    Size: h_contact [0.1] within |x|, |y| <= c_zone [2] (|y| up to c_zone + gap0),
    h_far [2], grading [0.2]; order [1]; quads [false].
    Cells: ``cylinder``, ``block``. Facets: ``cylinder_surface`` (the arc,
    slave), ``cylinder_top`` (y = R + gap0), ``block_top`` (y = 0, master),
    ``block_bottom`` (y = -H), ``symmetry`` (x = 0, both bodies).
    Default mesh: about 3.2k triangles (1.6k quadrilaterals with quads).
``hertz3d``
    Quarter model (x >= 0, y >= 0) of the lower hemisphere of the sphere of
    radius R [8] centred at (0, 0, R + gap0) [0] on the block
    [0, W/2]^2 x [-H, 0] [W = H = 20]. Size: h_contact [0.2] within
    c_zone [1.5] of the origin (box), h_far [3], grading [0.3]; order [1].
    Tetrahedra only (``quads = true`` is rejected). Cells: ``sphere``,
    ``block``. Facets: ``sphere_surface`` (slave), ``sphere_top``
    (z = R + gap0), ``block_top`` (z = 0, master), ``block_bottom`` (z = -H),
    ``symmetry_x`` (all facets on x = 0), ``symmetry_y`` (all facets on y = 0).
    Default mesh: about 9.5k tetrahedra.
``patch2d``
    Two stacked blocks, lower [0, L] x [-H, 0] and upper [0, L] x [gap0, gap0 + H]
    [L = 1, H = 0.5, gap0 = 0], structured with n_lower [5] and n_upper [7]
    elements along x and n_y [3] through each thickness (non-matching interface);
    quads [true]; order [1]. ``h_contact`` > 0 [0 = off] overrides the counts
    along x: n_lower = round(L/h_contact), n_upper scaled by n_upper/n_lower;
    ``h_far`` > 0 [0 = off] overrides n_y = round(H/h_far). ``margin`` [0]
    extends the lower block by that much beyond [0, L] on every side (room to
    slide: the frictional patch test).
    Cells: ``lower``, ``upper``. Facets: ``lower_top`` (master),
    ``upper_bottom`` (slave), ``lower_bottom``, ``upper_top``, ``lower_left``,
    ``upper_left`` (x = 0; x = -margin for ``lower_left``), ``lower_right``,
    ``upper_right`` (x = L; L + margin).
``patch3d``
    The same in 3D: [0, L]^2 x [-H, 0] and [0, L]^2 x [gap0, gap0 + H],
    n_lower [4], n_upper [5] elements along x and y, n_y [3] through the
    thickness; hexahedra with quads [true], structured tetrahedra otherwise.
    Facets as patch2d plus ``lower_front``, ``upper_front`` (y = 0),
    ``lower_back``, ``upper_back`` (y = L). Default mesh: 123 hexahedra.
``cattaneo2d``
    Two half-cylinders of radius R [8], full model: ``upper`` is the lower half
    of the disc centred at (0, R + gap0) (flat top y = R + gap0), ``lower`` the
    upper half of the disc centred at (0, -R) (flat bottom y = -R); they touch at
    the origin. Size as hertz2d (h_contact [0.1], c_zone [2], h_far [2],
    grading [0.2]); order [1]; quads [false]. Facets: ``upper_surface`` (slave
    arc), ``lower_surface`` (master arc), ``upper_top``, ``lower_bottom``.
    Default mesh: about 6.0k triangles (2.9k quadrilaterals with quads).
``wedge2d``
    A block on a wedge whose top rises with slope tan_alpha [0.1]. The wedge is
    the quadrilateral (0, -H), (L, -H), (L, L tan_alpha), (0, 0) [L = 4, H = 1];
    the block has vertical sides x = x0 [1.5] and x = x0 + b [b = 1], a
    horizontal top at height block_height [1] above the incline at its centre,
    and its bottom on the incline. Size: h_contact [0.05] within c_zone [0.25]
    of the footprint, h_far [0.25], grading [0.2]; order [1]; quads [false].
    Cells: ``block``, ``wedge``. Facets: ``block_bottom`` (slave),
    ``wedge_top`` (master), ``block_top``, ``block_left``, ``block_right``,
    ``wedge_bottom``, ``wedge_left``, ``wedge_right``. Default mesh: about 1.6k triangles.
``ironing2d``
    Plane-strain ironing: a die, the lower half of the ring r_in [2.8] <= r <=
    r_out [3] centred at (x_die, r_out + gap0) [x_die = 0, gap0 = 0: its lowest
    point touches the slab at (x_die, 0)], on the slab
    [x_left, x_left + L] x [-H, 0] [x_left = -2, L = 9, H = 3]. The die is
    structured with size h_die [0.1] and at least 2 elements through its
    thickness; the slab takes h_contact [0.1] within c_zone [1] of the sliding
    path (x_die - c_zone <= x <= x_die + slide + c_zone [slide = 4],
    -c_zone <= y <= c_zone + gap0), h_far [0.5], grading [0.2]; order [1];
    quads [false].
    Cells: ``die``, ``slab``. Facets: ``die_surface`` (outer arc, slave),
    ``die_top`` (the two flat ends at y = r_out + gap0, where the die is
    driven), ``die_inner`` (inner arc), ``slab_top`` (y = 0, master),
    ``slab_bottom`` (y = -H), ``slab_left`` (x = x_left), ``slab_right``
    (x = x_left + L). Default mesh: about 2.8k triangles (384 in the die;
    1.4k quadrilaterals with quads).
``ironing3d``
    The Puso-Laursen ironing problem: the slab [x_left, x_left + L] x [0, W] x
    [-H, 0] [x_left = -2, L = 9, W = 4, H = 3] and a die, the lower half of a
    cylindrical shell with axis along y, outer radius r_out [3] and thickness
    t [0.2], width w_die [5.2] centred on the slab (overhanging it on both
    sides), its lowest line at z = gap0 [0], x = x_die [0]. The die is
    structured (extruded along y) with size h_die [0.2] and at least 1 element
    through its thickness; the slab takes h_contact [0.4] within c_zone [1] of
    the sliding path (as ironing2d, slide [4], all y), h_far [1],
    grading [0.3]; order [1]. Tetrahedra only (``quads = true`` is rejected).
    Cells: ``die``, ``slab``. Facets: ``die_surface`` (outer cylindrical face,
    slave), ``die_top`` (the flat faces at z = r_out + gap0), ``die_inner``,
    ``slab_top`` (z = 0, master), ``slab_bottom`` (z = -H), ``slab_sides``
    (the four vertical faces); the die's end faces are untagged. Default mesh:
    about 11k tetrahedra (7.5k in the die).
``twist3d``
    Full (not quarter: twisting is not reflection-symmetric) lower hemisphere of
    radius R [8] centred at (0, 0, R + gap0) [0] on the block
    [-W/2, W/2]^2 x [-H, 0] [W = H = 20]. Size: h_contact [0.3] within
    c_zone [1.5] of the origin (box), h_far [4], grading [0.3]; order [1].
    Tetrahedra only (``quads = true`` is rejected). Cells: ``sphere``,
    ``block``. Facets: ``sphere_surface`` (slave), ``sphere_top``
    (z = R + gap0), ``block_top`` (z = 0, master), ``block_bottom`` (z = -H);
    the block's sides are untagged. Default mesh: about 16k tetrahedra.
``tiedcurved2d``
    Curved patch test: two annular sectors centred at the origin for
    theta0 [0] <= theta <= theta1 [pi/2] (theta1 - theta0 < pi), ``inner``
    r0 [1] <= r <= r1 [1.5] and ``outer`` r1 <= r <= r2 [2], touching along
    the arc r = r1. Structured, with n_inner [6] and n_outer [9] elements along
    the arcs (non-matching interface) and n_r [3] radially in each body;
    quads [true] (false: triangles); order [1]. ``h_contact`` > 0 [0 = off]
    overrides n_inner = round(r1 (theta1 - theta0)/h_contact), n_outer scaled
    by n_outer/n_inner; ``h_far`` > 0 [0 = off] overrides
    n_r = round(max(r1 - r0, r2 - r1)/h_far). Facets: ``inner_surface``
    (r = r1 on the inner body, master), ``outer_surface`` (r = r1 on the outer
    body, slave), ``inner_boundary`` (r = r0 and the inner body's radial
    sides), ``outer_boundary`` (r = r2 and the outer body's radial sides).
    Default mesh: 45 quadrilaterals.

Metadata returned by :func:`build`: ``generator``, ``gdim``, every parameter
value (after defaults; the structured generators add their effective element
counts, e.g. ``n_lower``, ``n_inner``, ``n_die_arc``), ``groups`` (name -> (dim, tag)), ``bodies`` (cell group
-> facet groups on it), ``contact`` (list of ``(slave, master)`` suggestions),
``cell_type`` (gmsh element name), ``num_cells``, ``num_nodes`` and
``cells_per_body``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

from dolfinx_mortar.errors import SceneError
from dolfinx_mortar.scene import C_INT_MAX, c_int, finite_float, number_text

__all__ = [
    "GENERATORS",
    "MAX_NODES",
    "Generator",
    "build",
    "describe",
    "estimate_nodes",
    "groups",
    "validate_params",
]


# ---------------------------------------------------------------------------
# Registry
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Generator:
    """A built-in geometry.

    Attributes
    ----------
    name, description:
        Registry name and one-line description.
    params:
        ``name -> (type, default, doc)``; type is ``float``, ``int`` or ``bool``.
    build:
        ``build(**params) -> dict``: builds the geometry, the physical groups and
        the mesh-size controls into the current gmsh model (no meshing) and
        returns the metadata. Call :func:`build` (the module function) instead,
        which validates, meshes and completes the metadata.
    gdim:
        Geometric (= topological) dimension of the mesh.
    checks:
        ``(key, predicate(params) -> bool, reason)`` value checks applied after
        the type checks, in order.
    counts:
        ``counts(params) -> [(key, formula, value)]``: the element counts that
        parameter ``key`` implies (``value`` a float, before rounding; e.g.
        ``("h_contact", "n_lower = round(L/h_contact)", L/h_contact)``), checked
        after ``checks`` against the rule of the given counts: at most
        ``C_INT_MAX``. None: the generator derives no counts.
    nodes:
        ``nodes(params) -> (estimate, keys)``: about how many mesh nodes the
        parameters ask for (:func:`estimate_nodes`; the order included) and the
        parameters that set it, checked last against :data:`MAX_NODES`.
    """

    name: str
    description: str
    params: dict[str, tuple[type, object, str]]
    build: Callable[..., dict]
    gdim: int = 2
    checks: tuple[tuple[str, Callable[[dict], bool], str], ...] = field(default=())
    counts: Callable[[dict], list[tuple[str, str, float]]] | None = None
    nodes: Callable[[dict], tuple[float, tuple[str, ...]]] | None = None


GENERATORS: dict[str, Generator] = {}


def _register(gen: Generator) -> Generator:
    GENERATORS[gen.name] = gen
    return gen


def validate_params(name: str, params: dict | None) -> dict:
    """Check a generator's parameters and return them completed with defaults.

    Raises :class:`SceneError` keyed ``mesh.generator`` for an unknown generator
    and ``mesh.params.<key>`` for an unknown key, a wrong type or a bad value.
    Integers are accepted for float parameters; booleans are accepted only for
    boolean parameters.
    """
    gen = GENERATORS.get(name)
    if gen is None:
        raise SceneError(
            "mesh.generator",
            f"unknown generator {name!r}; known: {', '.join(sorted(GENERATORS))}",
        )
    if params is None:
        params = {}
    if not isinstance(params, dict):
        raise SceneError("mesh.params", "must be a table of generator parameters")
    out: dict = {}
    for key, value in params.items():
        if key not in gen.params:
            raise SceneError(
                f"mesh.params.{key}",
                f"unknown parameter of generator {name!r}; known: {', '.join(gen.params)}",
            )
        typ = gen.params[key][0]
        out[key] = _coerce(f"mesh.params.{key}", value, typ)
    for key, (_typ, default, _doc) in gen.params.items():
        out.setdefault(key, default)
    for key, predicate, reason in gen.checks:
        if not predicate(out):
            raise SceneError(f"mesh.params.{key}", f"{reason} (got {out[key]!r})")
    for key, formula, value in gen.counts(out) if gen.counts is not None else ():
        if not (math.isfinite(value) and round(value) <= C_INT_MAX):  # inf: L/h overflows
            raise SceneError(
                f"mesh.params.{key}",
                f"implies {formula} = {value:.4g}, more than {C_INT_MAX} (a C int, the "
                f"rule of the given counts; got {key} = {out[key]!r})",
            )
    if gen.nodes is not None:
        nodes, keys = gen.nodes(out)
        if not nodes <= MAX_NODES:  # an inf too
            given = ", ".join(f"{k} = {out[k]!r}" for k in keys)
            about = f"about {nodes:.2g}" if math.isfinite(nodes) else "more than 1e+308"
            raise SceneError(
                "mesh.params",
                f"{given} ask {name} for {about} mesh nodes, more than it meshes "
                f"(MAX_NODES = {MAX_NODES:.0e}: rank 0 meshes the whole model in gmsh, "
                "and dolfinx reads it there with 32-bit offsets); coarsen the mesh",
            )
    return out


#: The most mesh nodes a generator is asked for (:func:`estimate_nodes`, checked by
#: :func:`validate_params` before gmsh is called: ``check`` and ``run`` alike). Within a
#: C int, a count such as patch2d's ``n_lower = 2000000000`` (about 8e9 nodes) or an
#: ``h_contact`` of 1e-6 went on to gmsh, which died of ``std::bad_alloc`` or meshed for
#: hours. The figure: dolfinx 0.5 reads the whole mesh on rank 0 into an
#: ``AdjacencyList``, whose offsets are ``std::int32_t``: at most 2**31 - 1 cell-node
#: entries, about 9.4e7 nodes of linear tetrahedra (5.7 cells, 23 entries, a node:
#: hertz3d, h_contact = 0.05); the estimate bounds gmsh's count from above (exact for
#: the structured meshes, 1.0 to 2.9 times it for the unstructured ones: session 54; it
#: was as low as 0.04 times it before, with the transition layer left out), so a mesh
#: that reaches gmsh has at most 2e7 nodes, well below that. Rank 0 alone meshes the
#: whole model, and gmsh took about 2.1 kB a node for unstructured
#: tetrahedra (hertz3d, 8 919 -> 50 526 nodes: 47 -> 130 MB) and 0.4 kB for structured
#: hexahedra (patch3d, 271 622 nodes: 106 MB): 2e7 nodes are about 40 GB. PETSc's
#: indices are 32-bit here too (3 dofs a node: 7.2e8 nodes in 3D). Real runs are far
#: below it: a few million dofs are about 1e6 nodes (BENCHMARKS.md's largest run: 63 972
#: dofs; the bench's finest levels, ``--levels 6``, are estimated at most 1.4e7: hertz3d
#: level 5).
MAX_NODES = 20_000_000


def _coerce(key: str, value: object, typ: type) -> object:
    if typ is bool:
        if not isinstance(value, bool):
            raise SceneError(key, f"must be a boolean, not {type(value).__name__}")
        return value
    if typ is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise SceneError(key, f"must be an integer, not {type(value).__name__}")
        return c_int(value, key)
    if typ is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SceneError(key, f"must be a number, not {type(value).__name__}")
        x = finite_float(value)
        if x is None:
            raise SceneError(key, f"must be a finite number, got {number_text(value)}")
        return x
    raise TypeError(f"unsupported parameter type {typ!r}")  # pragma: no cover


def describe(name: str | None = None) -> str:
    """Plain-text help (``dolfinx-mortar generators``): every generator (or one) with its
    dimension, its parameters and its physical groups (:func:`groups`): each body's cell
    group with the facet groups on it, and the suggested contact pair. Local; builds
    each generator's geometry once (:func:`groups`)."""
    names = [name] if name is not None else list(GENERATORS)
    lines = []
    for n in names:
        gen = GENERATORS[n]
        lines.append(f"{gen.name}: {gen.description}")
        for key, (typ, default, doc) in gen.params.items():
            lines.append(f"    {key} ({typ.__name__}, default {default!r}): {doc}")
        layout = groups(n)
        d = gen.gdim
        lines.append(f"  physical groups: each body's cells ({d}D), then its facets ({d - 1}D)")
        for body, facets in layout["bodies"].items():
            lines.append(f"    {body}: {', '.join(facets)}")
        pairs = "; ".join(f"slave {s}, master {m}" for s, m in layout["contact"])
        lines.append(f"  contact pair: {pairs}")
    return "\n".join(lines)


@functools.cache
def groups(name: str) -> dict:
    """The physical groups that generator ``name`` makes, read from its own build (local;
    rank 0 or any rank: no MPI): ``{"cells": [...], "facets": [...], "bodies": {cell
    group: [facet groups on that body]}, "contact": [(slave, master)]}``, names in the
    build's order. A facet group on two bodies (hertz2d's ``symmetry``) is listed under
    both. The names do not depend on the parameters: this builds the geometry only (no
    mesh; about 0.01 s) with the defaults, in a gmsh model of its own
    (:func:`dolfinx_mortar.gmsh_session.gmsh_model`: a caller's gmsh session is kept),
    once per process; no dolfinx, PETSc nor MPI. ``dolfinx-mortar generators`` (:func:`describe`) and docs/scenes.md's table
    of groups (tests/test_generators.py checks it) print them."""
    from .gmsh_session import gmsh_model, import_gmsh

    gen = GENERATORS[name]
    gmsh = import_gmsh()
    with gmsh_model(gmsh):
        meta = gen.build(**validate_params(name, {}))
    dims = {key: dim for key, (dim, _tag) in meta["groups"].items()}
    return {
        "cells": [k for k, d in dims.items() if d == gen.gdim],
        "facets": [k for k, d in dims.items() if d == gen.gdim - 1],
        "bodies": {body: list(facets) for body, facets in meta["bodies"].items()},
        "contact": [tuple(pair) for pair in meta["contact"]],
    }


def build(name: str, params: dict | None = None) -> dict:
    """Build generator ``name`` into the current gmsh model, mesh it, return metadata.

    The caller has called ``gmsh.initialize()`` and ``gmsh.model.add(...)``.
    Parameters are validated first (:func:`validate_params`), so a bad scene
    raises :class:`SceneError` before gmsh is touched. The mesh is generated in
    the generator's dimension and raised to ``order``; sets global gmsh options
    (terminal output off, size from the background field only).
    """
    p = validate_params(name, params)
    gen = GENERATORS[name]
    gmsh = _gmsh()
    _baseline_options(gmsh)
    try:
        meta = gen.build(**p)
        dim = gen.gdim
        gmsh.model.mesh.generate(dim)
        if p.get("quads") and dim == 2 and _has_mixed_2d(gmsh, meta):
            # Blossom recombination left triangles: redo with the full-quad variant,
            # which subdivides to guarantee quadrilaterals only.
            gmsh.model.mesh.clear()
            gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 3)
            gmsh.model.mesh.generate(1)
            _check_even_boundaries(gmsh, meta, name)
            gmsh.model.mesh.generate(dim)
        gmsh.model.mesh.setOrder(p["order"])
    except SceneError:
        raise
    except Exception as exc:  # gmsh and OpenCASCADE raise bare Exceptions
        raise SceneError("mesh", f"generator {name!r} failed: {exc}{_tiny_hint(p)}") from exc
    out = {"generator": name, "gdim": dim, **p}
    out.update(meta)  # e.g. the effective element counts of the patch generators
    out.update(_mesh_stats(gmsh, meta, dim))
    return out


# ---------------------------------------------------------------------------
# gmsh helpers
# ---------------------------------------------------------------------------


def _gmsh():
    import gmsh

    return gmsh


def _baseline_options(gmsh) -> None:
    opts = {
        "General.Terminal": 0,
        "General.Verbosity": 2,
        "Mesh.MeshSizeFromPoints": 0,
        "Mesh.MeshSizeExtendFromBoundary": 0,
        "Mesh.MeshSizeFromCurvature": 0,
        "Mesh.MeshSizeMin": 0.0,
        "Mesh.MeshSizeMax": 1e22,
        "Mesh.MeshSizeFactor": 1.0,
        "Mesh.Algorithm": 6,  # Frontal-Delaunay (8 crashes in gmsh 4.8 with fields)
        "Mesh.Algorithm3D": 1,
        "Mesh.RecombineAll": 0,
        "Mesh.Recombine3DAll": 0,
        "Mesh.RecombinationAlgorithm": 1,
        "Mesh.SubdivisionAlgorithm": 0,
        "Mesh.ElementOrder": 1,
        "Mesh.SecondOrderLinear": 0,
        "Mesh.SecondOrderIncomplete": 0,
    }
    for key, value in opts.items():
        gmsh.option.setNumber(key, value)


class _Groups:
    """Physical groups with names and unique tags (cells 1, 2, ...; facets after)."""

    def __init__(self, gmsh):
        self.gmsh = gmsh
        self.groups: dict[str, tuple[int, int]] = {}
        self._next = 1

    def add(self, dim: int, entities: list[int], name: str) -> None:
        if not entities:
            raise RuntimeError(f"generator bug: physical group {name!r} is empty")
        tag = self._next
        self._next += 1
        self.gmsh.model.addPhysicalGroup(dim, sorted(entities), tag)
        self.gmsh.model.setPhysicalName(dim, tag, name)
        self.groups[name] = (dim, tag)


def _polygon(occ, pts: list[tuple[float, float]]) -> tuple[int, list[int]]:
    """Plane surface bounded by the closed polygon ``pts``; returns (surface, lines)."""
    ptags = [occ.addPoint(x, y, 0.0) for x, y in pts]
    lines = [occ.addLine(ptags[i], ptags[(i + 1) % len(ptags)]) for i in range(len(ptags))]
    surf = occ.addPlaneSurface([occ.addCurveLoop(lines)])
    return surf, lines


def _box_field(gmsh, h_in, h_out, lo, hi, grading) -> None:
    """Background size: ``h_in`` inside the box [lo, hi], linear growth to ``h_out``."""
    mf = gmsh.model.mesh.field
    f = mf.add("Box")
    values = {"VIn": h_in, "VOut": h_out, "Thickness": max(h_out - h_in, 0.0) / grading}
    for axis, a, b in zip("XYZ", lo, hi, strict=False):
        values[f"{axis}Min"] = a
        values[f"{axis}Max"] = b
    if len(lo) == 2:
        values["ZMin"], values["ZMax"] = -1.0, 1.0
    for key, value in values.items():
        mf.setNumber(f, key, value)
    mf.setAsBackgroundMesh(f)


def _faces_of(gmsh, vol: int) -> list[int]:
    return [t for _, t in gmsh.model.getBoundary([(3, vol)], combined=False, oriented=False)]


#: OpenCASCADE pads every bounding box by its own absolute tolerance, 1e-7 in any units
#: (Precision::Confusion): a face flat at z = 0 has the box z ∈ [−1e-7, 1e-7].
OCC_BOX_PAD = 1e-7


def _flat_tol(*lengths: float) -> float:
    """The tolerance of :func:`_classify` for a geometry of these characteristic lengths:
    1e-6 of the largest, but no less than 3 × OCC_BOX_PAD. With 1e-6 × size alone every
    3D generator failed for lengths in millimetres given in metres (R = 0.008: the
    tolerance 2e-8 lay below the pad, no face was flat, and the run stopped on
    "mesh: KeyError: 'sphere_top'")."""
    return max(1e-6 * max(lengths), 3.0 * OCC_BOX_PAD)


#: The generators' parameters that size geometric features (not mesh sizes, positions or
#: ratios): OpenCASCADE cannot model them much below its absolute tolerance.
_FEATURE_LENGTHS = frozenset(
    {"R", "H", "L", "W", "b", "block_height", "gap0", "margin", "t", "w_die", "slide"}
    | {"r0", "r1", "r2", "r_in", "r_out"}
)


def _tiny_hint(params: dict) -> str:
    """A clause for a failed build whose smallest feature length is within 100 ×
    OCC_BOX_PAD (all generators fail at lengths of 1e-7 × the demos'); "" otherwise."""
    small = [abs(v) for k, v in params.items() if k in _FEATURE_LENGTHS and v != 0.0]
    if not small or min(small) >= 100.0 * OCC_BOX_PAD:
        return ""
    return (
        f"; its smallest length, {min(small):g}, is near OpenCASCADE's absolute tolerance "
        f"{OCC_BOX_PAD:g} (the same in any units): give the lengths in smaller units"
    )


def _classify(gmsh, dim: int, tags: list[int], rules, tol: float) -> dict[str, list[int]]:
    """Sort entities by bounding box: ``rules`` is a list of ``(name, axis, value)``
    (the entity is flat in ``axis`` at ``value``) and a final ``(name, None, None)``
    catch-all (``name`` None: leave untagged)."""
    out: dict[str, list[int]] = {}
    for t in tags:
        bb = gmsh.model.getBoundingBox(dim, t)
        for name, axis, value in rules:
            if axis is None or (abs(bb[axis] - value) < tol and abs(bb[axis + 3] - value) < tol):
                if name is not None:
                    out.setdefault(name, []).append(t)
                break
    return out


def _element_types(gmsh, dim: int, entities) -> set[int]:
    types: set[int] = set()
    for t in entities:
        etypes, _, _ = gmsh.model.mesh.getElements(dim, t)
        types.update(int(e) for e in etypes)
    return types


def _group_entities(gmsh, dim: int, tag: int) -> list[int]:
    return [int(e) for e in gmsh.model.getEntitiesForPhysicalGroup(dim, tag)]


def _has_mixed_2d(gmsh, meta: dict) -> bool:
    ents = []
    for body in meta["bodies"]:
        ents += _group_entities(gmsh, *meta["groups"][body])
    return len(_element_types(gmsh, 2, ents)) > 1


def _check_even_boundaries(gmsh, meta: dict, name: str) -> None:
    """Raise SceneError where a body's surface has an odd number of boundary edges in the
    current 1D mesh. gmsh's all-quadrilateral recombination (RecombinationAlgorithm 3)
    needs an even number on every surface; with an odd one gmsh 4.8 throws a C++
    string that no API layer catches ("1D mesh cannot be divided by 2"): the process
    aborts (SIGABRT, a C backtrace on every rank). It happens where h_far is larger than
    a body (hertz2d with quads = true and h_far > H: a side of one edge)."""
    odd = []
    for body in meta["bodies"]:
        d, tag = meta["groups"][body]
        for surface in _group_entities(gmsh, d, tag):
            curves = gmsh.model.getBoundary([(d, surface)], combined=False, oriented=False)
            edges = 0
            for _, curve in curves:
                _, etags, _ = gmsh.model.mesh.getElements(1, abs(curve))
                edges += sum(len(x) for x in etags)
            if edges % 2:
                odd.append(f"{body!r} has {edges}")
    if odd:
        raise SceneError(
            "mesh",
            f"generator {name!r} with quads = true: Blossom recombination left triangles, "
            f"and its all-quadrilateral variant needs an even number of boundary edges on "
            f"every body, and {', '.join(odd)}: give smaller element sizes where a body is "
            f"thinner than them (h_far, say), or quads = false",
        )


def _mesh_stats(gmsh, meta: dict, dim: int) -> dict:
    """Count cells per body; check one cell type, one facet type, no shared nodes."""
    import numpy as np

    cell_types: set[int] = set()
    per_body: dict[str, int] = {}
    nodes: dict[str, set[int]] = {}
    for body in meta["bodies"]:
        d, tag = meta["groups"][body]
        ents = _group_entities(gmsh, d, tag)
        cell_types |= _element_types(gmsh, d, ents)
        n = 0
        for e in ents:
            _, etags, _ = gmsh.model.mesh.getElements(d, e)
            n += sum(len(x) for x in etags)
        per_body[body] = n
        ntags, _ = gmsh.model.mesh.getNodesForPhysicalGroup(d, tag)
        nodes[body] = set(np.asarray(ntags, dtype=np.int64).tolist())
    facet_types: set[int] = set()
    for d, tag in meta["groups"].values():
        if d == dim - 1:
            facet_types |= _element_types(gmsh, d, _group_entities(gmsh, d, tag))
    if len(cell_types) != 1 or len(facet_types) != 1:
        raise RuntimeError(
            f"gmsh produced mixed element types (cells {sorted(cell_types)}, "
            f"facets {sorted(facet_types)}); dolfinx needs one cell type"
        )
    bodies = list(nodes)
    for i, a in enumerate(bodies):
        for b in bodies[i + 1 :]:
            if nodes[a] & nodes[b]:
                raise RuntimeError(f"generator bug: bodies {a!r} and {b!r} share mesh nodes")
    ntags, _, _ = gmsh.model.mesh.getNodes()
    (cell_type,) = cell_types
    return {
        "cell_type": gmsh.model.mesh.getElementProperties(cell_type)[0],
        "num_cells": sum(per_body.values()),
        "cells_per_body": per_body,
        "num_nodes": len(ntags),
    }


def _meta(groups: _Groups, bodies: dict[str, list[str]], contact: list[tuple[str, str]]):
    return {"groups": dict(groups.groups), "bodies": bodies, "contact": contact}


# Common parameter definitions -----------------------------------------------

_ORDER = (int, 1, "polynomial order of the geometry: 1 or 2")
_GRADING = (float, 0.2, "slope dh/dx of the linear size growth outside the refined zone")


def _positive(*keys):
    return tuple((k, (lambda p, k=k: p[k] > 0.0), "must be positive") for k in keys)


_ORDER_CHECK = (("order", lambda p: p["order"] in (1, 2), "must be 1 or 2"),)


# Mesh size estimates (Generator.nodes) ----------------------------------------

#: Mesh nodes per unit area (2D) or volume (3D) at element size h, times h**d, of gmsh's
#: unstructured meshes: 2/sqrt(3) for equilateral triangles of side h; in 3D, tetrahedra
#: of edge h (h**3/(6 sqrt 2) each) at 5.7 a node (hertz3d). Checked against gmsh:
#: tests/test_generators.py::test_node_estimates_bound_gmsh.
_NODE_DENSITY = {2: 2.0 / math.sqrt(3.0), 3: 6.0 * math.sqrt(2.0) / 5.7}

#: gmsh meshes a little denser than :data:`_NODE_DENSITY` at a size field's sizes (its
#: edges come out shorter than h, and the boundaries' node counts round up): the layer
#: formula of :func:`_graded_nodes` was 1.00 to 1.25 times low on the 2D generators
#: (wedge2d with grading 1.0 the most), so the estimate is raised by this factor to bound
#: gmsh's count from above (tests/test_generators.py::test_node_estimates_bound_gmsh).
_NODE_MARGIN = 1.3


def estimate_nodes(name: str, params: dict) -> float:
    """About how many mesh nodes generator ``name`` makes with ``params`` (completed by
    :func:`validate_params`), its order included: a float (inf where it overflows);
    local, without gmsh; never below gmsh's count where measured. Exact for the
    structured meshes (patch2d, patch3d, tiedcurved2d, the ironing dies: (order n + 1)
    nodes along an edge of n elements). For the unstructured ones an upper estimate
    (:func:`_graded_nodes`): the bodies' measure in the refined box at ``h_contact``, the
    rest filling the transition layer around the box nearest first at the size the field
    asks there, ``h_contact + grading * s``, and what is left at ``h_far``, times
    :data:`_NODE_DENSITY`, order**d (order-2 triangles and tetrahedra have a little fewer
    nodes: 3.9 and 6.9 times, not 4 and 8) and :data:`_NODE_MARGIN`. Measured against
    gmsh's ``num_nodes`` (``generators.build``, session 54) on the 7 unstructured
    generators, each at its defaults and 8 to 10 variants (h_contact × 2, / 2, / 4 in 2D;
    grading 0.05, 0.1, 1.0; c_zone × 2; h_far / 2; order 2; quads in 2D): 1.00 (ironing3d,
    h_contact 0.8) to 2.90 (twist3d, grading 0.05) times the count, 1.04 to 1.42 in 2D.
    Session 53's estimate left the layer out and was 0.04 to 1.04 times it over the same
    meshes (twist3d with grading 0.05: 955 estimated, 26 432 meshed)."""
    return GENERATORS[name].nodes(params)[0]


def _per_size(measure: float, h: float, d: int) -> float:
    """``measure / h**d`` (inf where it overflows; h > 0)."""
    if measure <= 0.0:
        return 0.0
    try:
        return measure * (1.0 / h) ** d
    except (OverflowError, ZeroDivisionError):
        return math.inf


def _overlap(lo_a, hi_a, lo_b, hi_b) -> float:
    """Measure of the intersection of two axis-aligned boxes."""
    out = 1.0
    for a0, a1, b0, b1 in zip(lo_a, hi_a, lo_b, hi_b, strict=True):
        out *= max(0.0, min(a1, b1) - max(a0, b0))
    return out


def _shell_measures(d: int, lo, hi, share: float = 1.0):
    """Steiner's formula for the axis-aligned box [lo, hi]: ``(M, A)`` with ``M(s)`` the
    measure of the points within (Euclidean) distance s > 0 of the box but outside it, and
    ``A(s) = M'(s)`` the measure of those at distance s (a length in 2D, an area in 3D),
    both times ``share``."""
    sides = [max(0.0, b - a) for a, b in zip(lo, hi, strict=True)]
    if d == 2:
        q = (2.0 * sum(sides), math.pi, 0.0)  # M(s) = q0 s + q1 s**2 + q2 s**3
    else:
        a, b, c = sides
        q = (2.0 * (a * b + b * c + c * a), math.pi * (a + b + c), 4.0 * math.pi / 3.0)
    q = [share * x for x in q]
    return (
        lambda s: s * (q[0] + s * (q[1] + s * q[2])),
        lambda s: q[0] + s * (2.0 * q[1] + s * 3.0 * q[2]),
    )


#: Simpson intervals of :func:`_graded_nodes`'s layer integral (in log h; 1e-4 relative).
_LAYER_INTERVALS = 128


def _graded_nodes(
    d: int, order: int, total: float, zone: float, lo, hi, p: dict, share: float = 1.0
) -> float:
    """Nodes of an unstructured mesh, at most about ``total`` measure of bodies of which at
    least ``zone`` lies in the refined box [lo, hi], sized as :func:`_box_field` asks:
    h_contact in the box, ``h(s) = h_contact + grading * s`` at distance s from it up to
    h_far (the transition layer, ``s <= T = (h_far - h_contact) / grading``), h_far
    beyond. Cells (element measure h**d units) are ``zone / h_contact**d`` plus the rest
    of the bodies' measure placed nearest first: the shells around the box at distance
    s filled whole (:func:`_shell_measures`) from s = 0 until the rest is used up or s = T,
    ``integral A(s) / h(s)**d ds`` (as if the bodies filled the space around the box:
    since h grows with s, no placement of the same measure has more cells), then what is
    left at h_far; times :data:`_NODE_DENSITY`, order**d and :data:`_NODE_MARGIN`
    (tests/test_generators.py::test_node_estimates_bound_gmsh). An upper estimate where
    ``zone`` is the box's whole share of the bodies, the generators' ``zone`` being a
    lower bound of it (the share of the curved bodies under a parabola); ``share``: the
    part of each shell a symmetric half or quarter model can hold. Inf where it
    overflows."""
    h_in, h_out, grading = p["h_contact"], p["h_far"], p["grading"]
    try:
        zone = min(zone, total)
        rest = max(0.0, total - zone)
        cells = _per_size(zone, h_in, d)
        thick = max(h_out - h_in, 0.0) / grading
        measure, shell = _shell_measures(d, lo, hi, share)
        if rest > 0.0 and thick > 0.0 and not math.isfinite(shell(0.0)):  # a vast box
            cells, rest = cells + _per_size(rest, h_in, d), 0.0
        elif rest > 0.0 and thick > 0.0:
            # the rest is used up within s* <= rest / A(0) (M(s) >= A(0) s) and within
            # (rest / (share * unit ball))**(1/d) (M(s) >= that ball's measure): bisect
            ball = share * (math.pi if d == 2 else 4.0 * math.pi / 3.0)
            a, b = 0.0, min(thick, (rest / ball) ** (1.0 / d))
            if shell(0.0) > 0.0:
                b = min(b, rest / shell(0.0))
            s1 = b
            if measure(b) > rest:
                for _ in range(200):
                    s1 = 0.5 * (a + b)
                    if s1 in (a, b):
                        break
                    a, b = (s1, b) if measure(s1) < rest else (a, s1)
            # integral_0^s1 A(s) h(s)**-d ds in v = log(h / h_contact), Simpson:
            # h = h_contact e**v, s = h_contact expm1(v) / grading, ds = h dv / grading
            top = math.log1p(grading * s1 / h_in)
            if top < 1e-6:  # h about h_contact over the layer used (a tiny grading)
                cells += _per_size(measure(s1), h_in, d)
            else:
                n = _LAYER_INTERVALS
                dv = top / n
                layer = 0.0
                for k in range(n + 1):
                    w = 1.0 if k in (0, n) else (4.0 if k % 2 else 2.0)
                    s = h_in * math.expm1(k * dv) / grading
                    layer += w * shell(s) * math.exp((1 - d) * k * dv)
                cells += layer * dv / (3.0 * grading) * h_in ** (1 - d)
            rest = max(0.0, rest - measure(s1))
        cells += _per_size(rest, h_out, d)
        return _NODE_MARGIN * _NODE_DENSITY[d] * order**d * cells
    except (OverflowError, ZeroDivisionError):
        return math.inf


def _structured(order: int, *counts: float) -> float:
    """Nodes of a structured block of ``counts`` elements per direction."""
    return math.prod(order * n + 1 for n in counts)


_ZONE_KEYS = ("h_contact", "h_far", "c_zone", "order")


def _hertz2d_nodes(p: dict) -> tuple[float, tuple[str, ...]]:
    c, R, W, H, g = p["c_zone"], p["R"], p["W"], p["H"], p["gap0"]
    total = 0.25 * math.pi * R**2 + 0.5 * W * H
    lo, hi = (-c, -c), (c, c + g)
    zone = _overlap((0.0, -H), (0.5 * W, 0.0), lo, hi)  # the block's part
    # the cylinder's: above its tip y = gap0 its arc lies below gap0 + x**2/R, so it
    # holds the area between that parabola and min(c, R) over 0 <= x <= min(c, R)
    m = min(c, R)
    zone += (m * m - m**3 / (3.0 * R)) if g >= -c else 0.0
    # the half model x >= 0 holds at most half of each shell around the box (symmetric in x)
    return _graded_nodes(2, p["order"], total, zone, lo, hi, p, share=0.5), _ZONE_KEYS


def _hemisphere_nodes(quarter: bool):
    def nodes(p: dict) -> tuple[float, tuple[str, ...]]:
        c, R, W, H, g = p["c_zone"], p["R"], p["W"], p["H"], p["gap0"]
        x0 = 0.0 if quarter else -0.5 * W
        lo, hi = (x0, x0, -H), (0.5 * W, 0.5 * W, 0.0)
        ball = (1.0 / 6.0 if quarter else 2.0 / 3.0) * math.pi * R**3
        total = ball + _overlap(lo, hi, lo, hi)
        box_lo, box_hi = (-c, -c, -c), (c, c, c + g)
        zone = _overlap(lo, hi, box_lo, box_hi)  # the block's part
        # the sphere's: above its tip z = gap0 it lies below gap0 + r**2/R, so it holds
        # the volume between that paraboloid and min(c, R) over r <= min(c, R)
        m = min(c, R)
        cap = math.pi * m**3 * (1.0 - m / (2.0 * R)) if g >= -c else 0.0
        zone += 0.25 * cap if quarter else cap
        # the quarter model x, y >= 0 holds at most a quarter of each shell around the box
        share = 0.25 if quarter else 1.0
        nodes = _graded_nodes(3, p["order"], total, zone, box_lo, box_hi, p, share)
        return nodes, _ZONE_KEYS

    return nodes


def _cattaneo2d_nodes(p: dict) -> tuple[float, tuple[str, ...]]:
    c, R, g = p["c_zone"], p["R"], p["gap0"]
    m = min(c, R)
    # in the box [-c, c] x [-c, c + gap0]: the lower half-disc (tip at the origin) lies
    # above y = -x**2/R, so holds the area between that parabola and y = -min(c, R) over
    # |x| <= min(c, R); the upper one (tip at y = gap0) its mirror image
    half = 2.0 * (m * m - m**3 / (3.0 * R))
    zone = half + (half if g >= -c else 0.0)
    lo, hi = (-c, -c), (c, c + g)
    return _graded_nodes(2, p["order"], math.pi * R**2, zone, lo, hi, p), _ZONE_KEYS


def _wedge2d_nodes(p: dict) -> tuple[float, tuple[str, ...]]:
    t, L, H, b, c, x0 = p["tan_alpha"], p["L"], p["H"], p["b"], p["c_zone"], p["x0"]
    total = L * H + 0.5 * L**2 * t + b * p["block_height"]
    x1 = x0 + b
    lo, hi = (x0 - c, min(x0 * t, x1 * t) - c), (x1 + c, max(x0 * t, x1 * t) + c)
    # the wedge in the box: under its incline (above the box's bottom there) and over -H
    xa, xb = max(0.0, lo[0]), min(L, hi[0])
    zone = max(0.0, xb - xa) * max(0.0, 0.5 * (xa + xb) * t - max(-H, lo[1]))
    # the block's: over x0 <= x <= x1, from the incline to its top or the box's
    ytop = (x0 + 0.5 * b) * t + p["block_height"]
    zone += b * max(0.0, min(hi[1], ytop) - max(x0 * t, x1 * t))
    return _graded_nodes(2, p["order"], total, zone, lo, hi, p), _ZONE_KEYS


def _ironing_nodes(d: int):
    def nodes(p: dict) -> tuple[float, tuple[str, ...]]:
        c, H, L, x_left, x_die = p["c_zone"], p["H"], p["L"], p["x_left"], p["x_die"]
        r_out, order, h_die = p["r_out"], p["order"], p["h_die"]
        thickness = p["t"] if d == 3 else r_out - p["r_in"]
        n_arc = max(2.0, 0.5 * math.pi * r_out / h_die)  # as _ring_counts, not rounded
        n_thick = max(1.0 if d == 3 else 2.0, thickness / h_die)
        die = [2.0 * n_arc, n_thick] + ([max(1.0, p["w_die"] / h_die)] if d == 3 else [])
        width = [p["W"]] if d == 3 else []
        lo, hi = [x_left, -H], [x_left + L, 0.0]
        box_lo = [x_die - c, -c]
        box_hi = [x_die + p["slide"] + c, c + max(p["gap0"], 0.0)]
        if d == 3:
            lo.insert(1, 0.0)
            hi.insert(1, width[0])
            box_lo.insert(1, -c)
            box_hi.insert(1, width[0] + c)
        zone = _overlap(lo, hi, box_lo, box_hi)
        slab = _graded_nodes(d, order, _overlap(lo, hi, lo, hi), zone, box_lo, box_hi, p)
        return slab + _structured(order, *die), (*_ZONE_KEYS[:3], "h_die", "order")

    return nodes


def _patch_nodes(d: int):
    def nodes(p: dict) -> tuple[float, tuple[str, ...]]:
        n_lower, n_upper, n_y = _patch_counts(
            p["L"], p["H"], p["n_lower"], p["n_upper"], p["n_y"], p["h_contact"], p["h_far"]
        )
        bodies = sum(_structured(p["order"], *[n] * (d - 1), n_y) for n in (n_lower, n_upper))
        keys = ("h_contact" if p["h_contact"] > 0.0 else "n_lower", "n_upper")
        return bodies, (*keys, "h_far" if p["h_far"] > 0.0 else "n_y", "order")

    return nodes


def _tiedcurved2d_nodes(p: dict) -> tuple[float, tuple[str, ...]]:
    n_inner, n_outer, n_r = p["n_inner"], p["n_outer"], p["n_r"]
    if p["h_contact"] > 0.0:  # as _build_tiedcurved2d, not rounded
        ni = p["r1"] * (p["theta1"] - p["theta0"]) / p["h_contact"]
        n_inner, n_outer = ni, ni * n_outer / n_inner
    if p["h_far"] > 0.0:
        n_r = max(p["r1"] - p["r0"], p["r2"] - p["r1"]) / p["h_far"]
    bodies = _structured(p["order"], n_inner, n_r) + _structured(p["order"], n_outer, n_r)
    keys = ("h_contact" if p["h_contact"] > 0.0 else "n_inner", "n_outer")
    return bodies, (*keys, "h_far" if p["h_far"] > 0.0 else "n_r", "order")


# ---------------------------------------------------------------------------
# hertz2d
# ---------------------------------------------------------------------------


def _build_hertz2d(R, gap0, W, H, c_zone, h_contact, h_far, grading, order, quads):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    yc = R + gap0
    c = occ.addPoint(0.0, yc, 0.0)
    b = occ.addPoint(0.0, gap0, 0.0)
    e = occ.addPoint(R, yc, 0.0)
    arc = occ.addCircleArc(b, c, e)
    top = occ.addLine(e, c)
    sym_c = occ.addLine(c, b)
    cyl = occ.addPlaneSurface([occ.addCurveLoop([arc, top, sym_c])])
    blk, (bot, _right, btop, sym_b) = _polygon(occ, [(0, -H), (W / 2, -H), (W / 2, 0), (0, 0)])
    occ.synchronize()

    g = _Groups(gmsh)
    g.add(2, [cyl], "cylinder")
    g.add(2, [blk], "block")
    g.add(1, [arc], "cylinder_surface")
    g.add(1, [top], "cylinder_top")
    g.add(1, [btop], "block_top")
    g.add(1, [bot], "block_bottom")
    g.add(1, [sym_c, sym_b], "symmetry")

    _box_field(gmsh, h_contact, h_far, (-c_zone, -c_zone), (c_zone, c_zone + gap0), grading)
    if quads:
        for s in (cyl, blk):
            gmsh.model.mesh.setRecombine(2, s)
    bodies = {
        "cylinder": ["cylinder_surface", "cylinder_top", "symmetry"],
        "block": ["block_top", "block_bottom", "symmetry"],
    }
    return _meta(g, bodies, [("cylinder_surface", "block_top")])


def _zone_params(c_zone: float, h_contact: float, h_far: float) -> dict:
    """The refined-zone parameters shared by the Hertz-type generators, with their defaults."""
    return {
        "c_zone": (float, c_zone, "half-width of the refined box around the origin"),
        "h_contact": (float, h_contact, "element size in the contact zone"),
        "h_far": (float, h_far, "element size far from the contact"),
    }


_register(
    Generator(
        name="hertz2d",
        description="plane-strain quarter cylinder on a block (half model, x >= 0)",
        params={
            "R": (float, 8.0, "cylinder radius"),
            "gap0": (float, 0.0, "initial gap between cylinder and block"),
            "W": (float, 20.0, "block width (the half model is W/2 wide)"),
            "H": (float, 20.0, "block height"),
            **_zone_params(c_zone=2.0, h_contact=0.1, h_far=2.0),
            "grading": _GRADING,
            "order": _ORDER,
            "quads": (bool, False, "recombine into quadrilaterals"),
        },
        build=_build_hertz2d,
        gdim=2,
        checks=_positive("R", "W", "H", "c_zone", "h_contact", "h_far", "grading")
        + (("gap0", lambda p: -p["R"] < p["gap0"] < p["R"], "must lie in (-R, R)"),)
        + _ORDER_CHECK,
        nodes=_hertz2d_nodes,
    )
)


# ---------------------------------------------------------------------------
# hertz3d
# ---------------------------------------------------------------------------


def _hemisphere_params(w_doc: str, h_contact: float, h_far: float, name: str) -> dict:
    """Parameters shared by the hemisphere-on-a-block generators (hertz3d, twist3d)."""
    return {
        "R": (float, 8.0, "sphere radius"),
        "gap0": (float, 0.0, "initial gap between sphere and block"),
        "W": (float, 20.0, w_doc),
        "H": (float, 20.0, "block height"),
        **_zone_params(c_zone=1.5, h_contact=h_contact, h_far=h_far),
        "grading": (float, 0.3, _GRADING[2]),
        "order": _ORDER,
        "quads": (bool, False, f"hexahedra: not available for {name} (must be false)"),
    }


def _hemisphere_checks(name: str) -> tuple:
    return (
        _positive("R", "W", "H", "c_zone", "h_contact", "h_far", "grading")
        + (("gap0", lambda p: -p["R"] < p["gap0"] < p["R"], "must lie in (-R, R)"),)
        + _ORDER_CHECK
        + (("quads", lambda p: not p["quads"], f"hexahedra are not available for {name}"),)
    )


def _build_hertz3d(R, gap0, W, H, c_zone, h_contact, h_far, grading, order, quads):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    zc = R + gap0
    ball = occ.addSphere(0.0, 0.0, zc, R)
    cut = occ.addBox(0.0, 0.0, gap0, R, R, R)
    out, _ = occ.intersect([(3, ball)], [(3, cut)])
    sph = out[0][1]
    blk = occ.addBox(0.0, 0.0, -H, W / 2, W / 2, H)
    occ.synchronize()

    tol = _flat_tol(R, W, H)
    fs = _classify(
        gmsh,
        2,
        _faces_of(gmsh, sph),
        [("symmetry_x", 0, 0.0), ("symmetry_y", 1, 0.0), ("sphere_top", 2, zc)]
        + [("sphere_surface", None, None)],
        tol,
    )
    fb = _classify(
        gmsh,
        2,
        _faces_of(gmsh, blk),
        [("symmetry_x", 0, 0.0), ("symmetry_y", 1, 0.0), ("block_top", 2, 0.0)]
        + [("block_bottom", 2, -H), (None, None, None)],
        tol,
    )
    g = _Groups(gmsh)
    g.add(3, [sph], "sphere")
    g.add(3, [blk], "block")
    g.add(2, fs["sphere_surface"], "sphere_surface")
    g.add(2, fs["sphere_top"], "sphere_top")
    g.add(2, fb["block_top"], "block_top")
    g.add(2, fb["block_bottom"], "block_bottom")
    g.add(2, fs["symmetry_x"] + fb["symmetry_x"], "symmetry_x")
    g.add(2, fs["symmetry_y"] + fb["symmetry_y"], "symmetry_y")

    lo = (-c_zone, -c_zone, -c_zone)
    hi = (c_zone, c_zone, c_zone + gap0)
    _box_field(gmsh, h_contact, h_far, lo, hi, grading)
    bodies = {
        "sphere": ["sphere_surface", "sphere_top", "symmetry_x", "symmetry_y"],
        "block": ["block_top", "block_bottom", "symmetry_x", "symmetry_y"],
    }
    return _meta(g, bodies, [("sphere_surface", "block_top")])


_register(
    Generator(
        name="hertz3d",
        description="quarter hemisphere on a block (x >= 0, y >= 0), tetrahedra",
        params=_hemisphere_params(
            "block width (the quarter model is W/2 x W/2)", 0.2, 3.0, "hertz3d"
        ),
        build=_build_hertz3d,
        gdim=3,
        checks=_hemisphere_checks("hertz3d"),
        nodes=_hemisphere_nodes(quarter=True),
    )
)


# ---------------------------------------------------------------------------
# patch2d / patch3d
# ---------------------------------------------------------------------------


def _patch_derived(p: dict) -> list[tuple[str, str, float]]:
    """The counts that h_contact / h_far imply (``Generator.counts``), as floats
    before rounding: n_lower = L/h_contact, n_upper = that × n_upper/n_lower,
    n_y = H/h_far."""
    out = []
    if p["h_contact"] > 0.0:
        nl = p["L"] / p["h_contact"]
        out.append(("h_contact", "n_lower = round(L/h_contact)", nl))
        out.append(
            (
                "h_contact",
                "n_upper = round(n_lower n_upper/n_lower)",
                nl * p["n_upper"] / p["n_lower"],
            )
        )
    if p["h_far"] > 0.0:
        out.append(("h_far", "n_y = round(H/h_far)", p["H"] / p["h_far"]))
    return out


def _patch_counts(L, H, n_lower, n_upper, n_y, h_contact, h_far):
    if h_contact > 0.0:
        nl = max(1, round(L / h_contact))
        n_upper = max(1, round(nl * n_upper / n_lower))
        n_lower = nl
    if h_far > 0.0:
        n_y = max(1, round(H / h_far))
    return n_lower, n_upper, n_y


def _build_patch2d(L, H, gap0, n_lower, n_upper, n_y, h_contact, h_far, margin, order, quads):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    n_lower, n_upper, n_y = _patch_counts(L, H, n_lower, n_upper, n_y, h_contact, h_far)
    m = margin
    low, (lb, lr, lt, ll) = _polygon(occ, [(-m, -H), (L + m, -H), (L + m, 0), (-m, 0)])
    y0, y1 = gap0, gap0 + H
    up, (ub, ur, ut, ul) = _polygon(occ, [(0, y0), (L, y0), (L, y1), (0, y1)])
    occ.synchronize()

    mesh = gmsh.model.mesh
    for n, surf, horizontal, vertical in (
        (n_lower, low, (lb, lt), (lr, ll)),
        (n_upper, up, (ub, ut), (ur, ul)),
    ):
        for c in horizontal:
            mesh.setTransfiniteCurve(c, n + 1)
        for c in vertical:
            mesh.setTransfiniteCurve(c, n_y + 1)
        mesh.setTransfiniteSurface(surf)
        if quads:
            mesh.setRecombine(2, surf)

    g = _Groups(gmsh)
    g.add(2, [low], "lower")
    g.add(2, [up], "upper")
    names = {}
    for body, curves in (("lower", (lb, lt, ll, lr)), ("upper", (ub, ut, ul, ur))):
        names[body] = []
        for side, c in zip(("bottom", "top", "left", "right"), curves, strict=True):
            g.add(1, [c], f"{body}_{side}")
            names[body].append(f"{body}_{side}")
    meta = _meta(g, names, [("upper_bottom", "lower_top")])
    meta.update(n_lower=n_lower, n_upper=n_upper, n_y=n_y)
    return meta


def _build_patch3d(L, H, gap0, n_lower, n_upper, n_y, h_contact, h_far, margin, order, quads):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    n_lower, n_upper, n_y = _patch_counts(L, H, n_lower, n_upper, n_y, h_contact, h_far)
    low = occ.addBox(-margin, -margin, -H, L + 2 * margin, L + 2 * margin, H)
    up = occ.addBox(0.0, 0.0, gap0, L, L, H)
    occ.synchronize()

    tol = _flat_tol(L, H)
    mesh = gmsh.model.mesh
    g = _Groups(gmsh)
    g.add(3, [low], "lower")
    g.add(3, [up], "upper")
    bodies = {}
    for body, vol, n, z0, z1, lo, hi in (
        ("lower", low, n_lower, -H, 0.0, -margin, L + margin),
        ("upper", up, n_upper, gap0, gap0 + H, 0.0, L),
    ):
        faces = _faces_of(gmsh, vol)
        curves = {
            int(c)
            for _, c in gmsh.model.getBoundary(
                [(2, f) for f in faces], combined=False, oriented=False
            )
        }
        for c in sorted(curves):
            bb = gmsh.model.getBoundingBox(1, c)
            vertical = bb[5] - bb[2] > tol
            mesh.setTransfiniteCurve(c, (n_y if vertical else n) + 1)
        for f in faces:
            mesh.setTransfiniteSurface(f)
            if quads:
                mesh.setRecombine(2, f)
        mesh.setTransfiniteVolume(vol)
        if quads:
            mesh.setRecombine(3, vol)
        sides = _classify(
            gmsh,
            2,
            faces,
            [
                ("bottom", 2, z0),
                ("top", 2, z1),
                ("left", 0, lo),
                ("right", 0, hi),
                ("front", 1, lo),
                ("back", 1, hi),
            ],
            tol,
        )
        bodies[body] = []
        for side in ("bottom", "top", "left", "right", "front", "back"):
            g.add(2, sides[side], f"{body}_{side}")
            bodies[body].append(f"{body}_{side}")
    meta = _meta(g, bodies, [("upper_bottom", "lower_top")])
    meta.update(n_lower=n_lower, n_upper=n_upper, n_y=n_y)
    return meta


def _patch_params(n_lower: int, n_upper: int) -> dict:
    return {
        "L": (float, 1.0, "block length (x; and y in 3D)"),
        "H": (float, 0.5, "thickness of each block"),
        "gap0": (float, 0.0, "initial gap between the blocks"),
        "n_lower": (int, n_lower, "elements of the lower block along x (and y)"),
        "n_upper": (int, n_upper, "elements of the upper block along x (and y)"),
        "n_y": (int, 3, "elements through each block's thickness"),
        "h_contact": (
            float,
            0.0,
            "if > 0: interface size of the lower block, n_lower = round(L/h_contact), "
            "n_upper scaled by n_upper/n_lower",
        ),
        "h_far": (float, 0.0, "if > 0: size through the thickness, n_y = round(H/h_far)"),
        "margin": (
            float,
            0.0,
            "the lower block overhangs the upper one by this much on every side "
            "(n_lower elements over its whole length)",
        ),
        "order": _ORDER,
        "quads": (bool, True, "quadrilaterals/hexahedra (else triangles/tetrahedra)"),
    }


_PATCH_CHECKS = (
    _positive("L", "H")
    + tuple(
        (k, (lambda p, k=k: p[k] >= 1), "must be at least 1") for k in ("n_lower", "n_upper", "n_y")
    )
    + tuple(
        (k, (lambda p, k=k: p[k] >= 0.0), "must be >= 0") for k in ("h_contact", "h_far", "margin")
    )
    + (("gap0", lambda p: -p["H"] < p["gap0"] < p["H"], "must lie in (-H, H)"),)
    + _ORDER_CHECK
)

_register(
    Generator(
        name="patch2d",
        description="two stacked structured blocks with a non-matching interface (2D)",
        params=_patch_params(5, 7),
        build=_build_patch2d,
        gdim=2,
        checks=_PATCH_CHECKS,
        counts=_patch_derived,
        nodes=_patch_nodes(2),
    )
)

_register(
    Generator(
        name="patch3d",
        description="two stacked structured blocks with a non-matching interface (3D)",
        params=_patch_params(4, 5),
        build=_build_patch3d,
        gdim=3,
        checks=_PATCH_CHECKS,
        counts=_patch_derived,
        nodes=_patch_nodes(3),
    )
)


# ---------------------------------------------------------------------------
# cattaneo2d
# ---------------------------------------------------------------------------


def _build_cattaneo2d(R, gap0, c_zone, h_contact, h_far, grading, order, quads):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    surfs = {}
    for body, yc, ytip in (("upper", R + gap0, gap0), ("lower", -R, 0.0)):
        c = occ.addPoint(0.0, yc, 0.0)
        left = occ.addPoint(-R, yc, 0.0)
        tip = occ.addPoint(0.0, ytip, 0.0)
        right = occ.addPoint(R, yc, 0.0)
        a1 = occ.addCircleArc(left, c, tip)
        a2 = occ.addCircleArc(tip, c, right)
        flat = occ.addLine(right, left)
        surf = occ.addPlaneSurface([occ.addCurveLoop([a1, a2, flat])])
        surfs[body] = (surf, [a1, a2], flat)
    occ.synchronize()

    g = _Groups(gmsh)
    g.add(2, [surfs["upper"][0]], "upper")
    g.add(2, [surfs["lower"][0]], "lower")
    g.add(1, surfs["upper"][1], "upper_surface")
    g.add(1, surfs["lower"][1], "lower_surface")
    g.add(1, [surfs["upper"][2]], "upper_top")
    g.add(1, [surfs["lower"][2]], "lower_bottom")

    _box_field(gmsh, h_contact, h_far, (-c_zone, -c_zone), (c_zone, c_zone + gap0), grading)
    if quads:
        for s, _, _ in surfs.values():
            gmsh.model.mesh.setRecombine(2, s)
    bodies = {"upper": ["upper_surface", "upper_top"], "lower": ["lower_surface", "lower_bottom"]}
    return _meta(g, bodies, [("upper_surface", "lower_surface")])


_register(
    Generator(
        name="cattaneo2d",
        description="two half-cylinders touching at the origin (full 2D model)",
        params={
            "R": (float, 8.0, "radius of both half-cylinders"),
            "gap0": (float, 0.0, "initial gap (the upper body is lifted by gap0)"),
            **_zone_params(c_zone=2.0, h_contact=0.1, h_far=2.0),
            "grading": _GRADING,
            "order": _ORDER,
            "quads": (bool, False, "recombine into quadrilaterals"),
        },
        build=_build_cattaneo2d,
        gdim=2,
        checks=_positive("R", "c_zone", "h_contact", "h_far", "grading")
        + (("gap0", lambda p: -p["R"] < p["gap0"] < p["R"], "must lie in (-R, R)"),)
        + _ORDER_CHECK,
        nodes=_cattaneo2d_nodes,
    )
)


# ---------------------------------------------------------------------------
# wedge2d
# ---------------------------------------------------------------------------


def _build_wedge2d(
    tan_alpha, L, H, b, block_height, x0, c_zone, h_contact, h_far, grading, order, quads
):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    t = tan_alpha
    wedge, (wb, wr, wt, wl) = _polygon(occ, [(0, -H), (L, -H), (L, L * t), (0, 0)])
    x1 = x0 + b
    ytop = (x0 + 0.5 * b) * t + block_height
    block, (bb, br, bt, bl) = _polygon(occ, [(x0, x0 * t), (x1, x1 * t), (x1, ytop), (x0, ytop)])
    occ.synchronize()

    g = _Groups(gmsh)
    g.add(2, [block], "block")
    g.add(2, [wedge], "wedge")
    for name, c in (
        ("block_bottom", bb),
        ("wedge_top", wt),
        ("block_top", bt),
        ("block_left", bl),
        ("block_right", br),
        ("wedge_bottom", wb),
        ("wedge_left", wl),
        ("wedge_right", wr),
    ):
        g.add(1, [c], name)

    ys = (x0 * t, x1 * t)
    lo = (x0 - c_zone, min(ys) - c_zone)
    hi = (x1 + c_zone, max(ys) + c_zone)
    _box_field(gmsh, h_contact, h_far, lo, hi, grading)
    if quads:
        for s in (block, wedge):
            gmsh.model.mesh.setRecombine(2, s)
    bodies = {
        "block": ["block_bottom", "block_top", "block_left", "block_right"],
        "wedge": ["wedge_top", "wedge_bottom", "wedge_left", "wedge_right"],
    }
    return _meta(g, bodies, [("block_bottom", "wedge_top")])


_register(
    Generator(
        name="wedge2d",
        description="a block on an inclined wedge (slope tan_alpha), 2D",
        params={
            "tan_alpha": (float, 0.1, "slope of the wedge's top (rising in +x)"),
            "L": (float, 4.0, "wedge length"),
            "H": (float, 1.0, "wedge depth below the incline's start (0, 0)"),
            "b": (float, 1.0, "block width"),
            "block_height": (float, 1.0, "block height above the incline at its centre"),
            "x0": (float, 1.5, "x of the block's left side"),
            "c_zone": (float, 0.25, "margin of the refined box around the footprint"),
            "h_contact": (float, 0.05, "element size near the interface"),
            "h_far": (float, 0.25, "element size far from the interface"),
            "grading": _GRADING,
            "order": _ORDER,
            "quads": (bool, False, "recombine into quadrilaterals"),
        },
        build=_build_wedge2d,
        gdim=2,
        checks=_positive("L", "H", "b", "block_height", "c_zone", "h_contact", "h_far", "grading")
        + (
            ("tan_alpha", lambda p: abs(p["tan_alpha"]) < 1.0, "must lie in (-1, 1)"),
            ("H", lambda p: p["H"] + min(0.0, p["L"] * p["tan_alpha"]) > 0.0, "wedge too thin"),
            ("x0", lambda p: 0.0 <= p["x0"] and p["x0"] + p["b"] <= p["L"], "block off the wedge"),
            (
                "block_height",
                lambda p: p["block_height"] > 0.5 * p["b"] * abs(p["tan_alpha"]),
                "must exceed b |tan_alpha| / 2",
            ),
        )
        + _ORDER_CHECK,
        nodes=_wedge2d_nodes,
    )
)


# ---------------------------------------------------------------------------
# ironing2d / ironing3d
# ---------------------------------------------------------------------------


def _half_ring(occ, point, r_in, r_out):
    """Lower half of the ring ``r_in <= r <= r_out`` around the origin of a (u, v) plane.

    ``point(u, v)`` adds an OCC point and returns its tag. Returns the surface,
    the outer arcs, the flat ends (v = 0), the inner arcs and the corners
    (outer left, outer right, inner right, inner left) for a transfinite mesh.
    """
    c = point(0.0, 0.0)
    ol, ob, o_r = point(-r_out, 0.0), point(0.0, -r_out), point(r_out, 0.0)
    il, ib, i_r = point(-r_in, 0.0), point(0.0, -r_in), point(r_in, 0.0)
    outer = [occ.addCircleArc(ol, c, ob), occ.addCircleArc(ob, c, o_r)]
    right = occ.addLine(o_r, i_r)
    inner = [occ.addCircleArc(i_r, c, ib), occ.addCircleArc(ib, c, il)]
    left = occ.addLine(il, ol)
    surf = occ.addPlaneSurface([occ.addCurveLoop([*outer, right, *inner, left])])
    occ.remove([(0, c)])  # the centre is no part of the ring
    return surf, outer, [right, left], inner, [ol, o_r, i_r, il]


def _ring_counts(r_out: float, thickness: float, h_die: float, n_thick_min: int):
    """Elements per quarter arc and through the thickness of a ring of size ``h_die``."""
    n_arc = max(2, math.ceil(0.5 * math.pi * r_out / h_die - 1e-9))
    n_thick = max(n_thick_min, math.ceil(thickness / h_die - 1e-9))
    return n_arc, n_thick


def _structured_ring(gmsh, surf, outer, ends, inner, corners, n_arc, n_thick) -> None:
    mesh = gmsh.model.mesh
    for c in outer + inner:
        mesh.setTransfiniteCurve(c, n_arc + 1)
    for c in ends:
        mesh.setTransfiniteCurve(c, n_thick + 1)
    mesh.setTransfiniteSurface(surf, "Left", corners)


def _build_ironing2d(
    r_in,
    r_out,
    x_die,
    gap0,
    L,
    H,
    x_left,
    slide,
    c_zone,
    h_contact,
    h_far,
    h_die,
    grading,
    order,
    quads,
):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    yc = r_out + gap0
    die, outer, ends, inner, corners = _half_ring(
        occ, lambda u, v: occ.addPoint(x_die + u, yc + v, 0.0), r_in, r_out
    )
    x_right = x_left + L
    slab, (bot, right, top, left) = _polygon(
        occ, [(x_left, -H), (x_right, -H), (x_right, 0.0), (x_left, 0.0)]
    )
    occ.synchronize()

    g = _Groups(gmsh)
    g.add(2, [die], "die")
    g.add(2, [slab], "slab")
    g.add(1, outer, "die_surface")
    g.add(1, ends, "die_top")
    g.add(1, inner, "die_inner")
    g.add(1, [top], "slab_top")
    g.add(1, [bot], "slab_bottom")
    g.add(1, [left], "slab_left")
    g.add(1, [right], "slab_right")

    n_arc, n_thick = _ring_counts(r_out, r_out - r_in, h_die, 2)
    _structured_ring(gmsh, die, outer, ends, inner, corners, n_arc, n_thick)
    lo = (x_die - c_zone, -c_zone)
    hi = (x_die + slide + c_zone, c_zone + max(gap0, 0.0))
    _box_field(gmsh, h_contact, h_far, lo, hi, grading)
    if quads:
        for s in (die, slab):
            gmsh.model.mesh.setRecombine(2, s)
    bodies = {
        "die": ["die_surface", "die_top", "die_inner"],
        "slab": ["slab_top", "slab_bottom", "slab_left", "slab_right"],
    }
    meta = _meta(g, bodies, [("die_surface", "slab_top")])
    meta.update(n_die_arc=2 * n_arc, n_die_thickness=n_thick)
    return meta


def _build_ironing3d(
    r_out,
    t,
    w_die,
    x_die,
    gap0,
    L,
    W,
    H,
    x_left,
    slide,
    c_zone,
    h_contact,
    h_far,
    h_die,
    grading,
    order,
    quads,
):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    zc = r_out + gap0
    r_in = r_out - t
    y0 = 0.5 * (W - w_die)
    ring, outer, ends, inner, corners = _half_ring(
        occ, lambda u, v: occ.addPoint(x_die + u, y0, zc + v), r_in, r_out
    )
    n_arc, n_thick = _ring_counts(r_out, t, h_die, 1)
    n_w = max(1, math.ceil(w_die / h_die - 1e-9))
    out = occ.extrude([(2, ring)], 0.0, w_die, 0.0, numElements=[n_w], recombine=False)
    die = next(tag for dim, tag in out if dim == 3)
    slab = occ.addBox(x_left, 0.0, -H, L, W, H)
    occ.synchronize()
    _structured_ring(gmsh, ring, outer, ends, inner, corners, n_arc, n_thick)

    tol = _flat_tol(r_out, L, W, H)
    fd = _classify(
        gmsh,
        2,
        _faces_of(gmsh, die),
        [("die_top", 2, zc), (None, 1, y0), (None, 1, y0 + w_die), ("curved", None, None)],
        tol,
    )
    for f in fd.pop("curved"):
        lo, hi = gmsh.model.getParametrizationBounds(2, f)
        x, _, z = gmsh.model.getValue(2, f, [0.5 * (a + b) for a, b in zip(lo, hi, strict=True)])
        r = math.hypot(x - x_die, z - zc)  # the mid-point's distance to the axis
        name = "die_surface" if abs(r - r_out) < abs(r - r_in) else "die_inner"
        fd.setdefault(name, []).append(f)
    fs = _classify(
        gmsh,
        2,
        _faces_of(gmsh, slab),
        [("slab_top", 2, 0.0), ("slab_bottom", 2, -H), ("slab_sides", None, None)],
        tol,
    )
    g = _Groups(gmsh)
    g.add(3, [die], "die")
    g.add(3, [slab], "slab")
    for name in ("die_surface", "die_top", "die_inner"):
        g.add(2, fd[name], name)
    for name in ("slab_top", "slab_bottom", "slab_sides"):
        g.add(2, fs[name], name)

    lo = (x_die - c_zone, -c_zone, -c_zone)
    hi = (x_die + slide + c_zone, W + c_zone, c_zone + max(gap0, 0.0))
    _box_field(gmsh, h_contact, h_far, lo, hi, grading)
    bodies = {
        "die": ["die_surface", "die_top", "die_inner"],
        "slab": ["slab_top", "slab_bottom", "slab_sides"],
    }
    meta = _meta(g, bodies, [("die_surface", "slab_top")])
    meta.update(n_die_arc=2 * n_arc, n_die_thickness=n_thick, n_die_width=n_w)
    return meta


def _ironing_common(gdim: int, h_contact: float, h_far: float, h_die: float) -> dict:
    """The parameters shared by the ironing generators, with their defaults."""
    width = {"W": (float, 4.0, "slab width (y)")} if gdim == 3 else {}
    return {
        "x_die": (float, 0.0, "x of the die's centre (and lowest point)"),
        "gap0": (float, 0.0, "initial gap between the die's lowest point and the slab"),
        "L": (float, 9.0, "slab length (x)"),
        **width,
        "H": (float, 3.0, "slab height"),
        "x_left": (float, -2.0, "x of the slab's left end"),
        "slide": (float, 4.0, "length of the sliding path (+x) inside the refined zone"),
        "c_zone": (float, 1.0, "margin of the refined box around the sliding path"),
        "h_contact": (float, h_contact, "element size of the slab along the sliding path"),
        "h_far": (float, h_far, "element size far from the sliding path"),
        "h_die": (float, h_die, "element size of the die (structured)"),
    }


_IRONING_CHECKS = (
    ("x_die", lambda p: p["x_left"] <= p["x_die"] <= p["x_left"] + p["L"], "die off the slab"),
    (
        "slide",
        lambda p: p["slide"] >= 0.0 and p["x_die"] + p["slide"] <= p["x_left"] + p["L"],
        "sliding path off the slab",
    ),
)

_register(
    Generator(
        name="ironing2d",
        description="a half-ring die sliding on a slab (plane strain)",
        params={
            "r_in": (float, 2.8, "inner radius of the die"),
            "r_out": (float, 3.0, "outer radius of the die"),
            **_ironing_common(2, h_contact=0.1, h_far=0.5, h_die=0.1),
            "grading": _GRADING,
            "order": _ORDER,
            "quads": (bool, False, "recombine into quadrilaterals"),
        },
        build=_build_ironing2d,
        gdim=2,
        checks=_positive("r_in", "r_out", "L", "H", "c_zone", "h_contact", "h_far", "h_die")
        + _positive("grading")
        + (
            ("r_in", lambda p: p["r_in"] < p["r_out"], "must be less than r_out"),
            (
                "gap0",
                lambda p: p["r_in"] - p["r_out"] < p["gap0"] < p["H"],
                "must lie in (r_in - r_out, H)",
            ),
        )
        + _IRONING_CHECKS
        + _ORDER_CHECK,
        nodes=_ironing_nodes(2),
    )
)

_register(
    Generator(
        name="ironing3d",
        description="a cylindrical-shell die sliding on a slab (Puso-Laursen), tetrahedra",
        params={
            "r_out": (float, 3.0, "outer radius of the die"),
            "t": (float, 0.2, "wall thickness of the die (inner radius r_out - t)"),
            "w_die": (float, 5.2, "die width along y, centred on the slab"),
            **_ironing_common(3, h_contact=0.4, h_far=1.0, h_die=0.2),
            "grading": (float, 0.3, _GRADING[2]),
            "order": _ORDER,
            "quads": (bool, False, "hexahedra: not available for ironing3d (must be false)"),
        },
        build=_build_ironing3d,
        gdim=3,
        checks=_positive("r_out", "t", "w_die", "L", "W", "H", "c_zone", "h_contact", "h_far")
        + _positive("h_die", "grading")
        + (
            ("t", lambda p: p["t"] < p["r_out"], "must be less than r_out"),
            ("gap0", lambda p: -p["t"] < p["gap0"] < p["H"], "must lie in (-t, H)"),
        )
        + _IRONING_CHECKS
        + _ORDER_CHECK
        + (("quads", lambda p: not p["quads"], "hexahedra are not available for ironing3d"),),
        nodes=_ironing_nodes(3),
    )
)


# ---------------------------------------------------------------------------
# twist3d
# ---------------------------------------------------------------------------


def _build_twist3d(R, gap0, W, H, c_zone, h_contact, h_far, grading, order, quads):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    zc = R + gap0
    ball = occ.addSphere(0.0, 0.0, zc, R)
    cut = occ.addBox(-2.0 * R, -2.0 * R, zc - 2.0 * R, 4.0 * R, 4.0 * R, 2.0 * R)
    out, _ = occ.intersect([(3, ball)], [(3, cut)])
    sph = out[0][1]
    blk = occ.addBox(-W / 2, -W / 2, -H, W, W, H)
    occ.synchronize()

    tol = _flat_tol(R, W, H)
    fs = _classify(
        gmsh, 2, _faces_of(gmsh, sph), [("sphere_top", 2, zc), ("sphere_surface", None, None)], tol
    )
    fb = _classify(
        gmsh,
        2,
        _faces_of(gmsh, blk),
        [("block_top", 2, 0.0), ("block_bottom", 2, -H), (None, None, None)],
        tol,
    )
    g = _Groups(gmsh)
    g.add(3, [sph], "sphere")
    g.add(3, [blk], "block")
    g.add(2, fs["sphere_surface"], "sphere_surface")
    g.add(2, fs["sphere_top"], "sphere_top")
    g.add(2, fb["block_top"], "block_top")
    g.add(2, fb["block_bottom"], "block_bottom")

    lo = (-c_zone, -c_zone, -c_zone)
    hi = (c_zone, c_zone, c_zone + gap0)
    _box_field(gmsh, h_contact, h_far, lo, hi, grading)
    bodies = {
        "sphere": ["sphere_surface", "sphere_top"],
        "block": ["block_top", "block_bottom"],
    }
    return _meta(g, bodies, [("sphere_surface", "block_top")])


_register(
    Generator(
        name="twist3d",
        description="full lower hemisphere on a block (for twisting), tetrahedra",
        params=_hemisphere_params("block width (x and y)", 0.3, 4.0, "twist3d"),
        build=_build_twist3d,
        gdim=3,
        checks=_hemisphere_checks("twist3d"),
        nodes=_hemisphere_nodes(quarter=False),
    )
)


# ---------------------------------------------------------------------------
# tiedcurved2d
# ---------------------------------------------------------------------------


def _tiedcurved_derived(p: dict) -> list[tuple[str, str, float]]:
    """The counts that h_contact / h_far imply (``Generator.counts``), as floats
    before rounding."""
    out = []
    if p["h_contact"] > 0.0:
        ni = p["r1"] * (p["theta1"] - p["theta0"]) / p["h_contact"]
        out.append(("h_contact", "n_inner = round(r1 (theta1 - theta0)/h_contact)", ni))
        out.append(
            (
                "h_contact",
                "n_outer = round(n_inner n_outer/n_inner)",
                ni * p["n_outer"] / p["n_inner"],
            )
        )
    if p["h_far"] > 0.0:
        nr = max(p["r1"] - p["r0"], p["r2"] - p["r1"]) / p["h_far"]
        out.append(("h_far", "n_r = round(max(r1 - r0, r2 - r1)/h_far)", nr))
    return out


def _build_tiedcurved2d(
    r0, r1, r2, theta0, theta1, n_inner, n_outer, n_r, h_contact, h_far, order, quads
):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    if h_contact > 0.0:
        ni = max(1, round(r1 * (theta1 - theta0) / h_contact))
        n_outer = max(1, round(ni * n_outer / n_inner))
        n_inner = ni
    if h_far > 0.0:
        n_r = max(1, round(max(r1 - r0, r2 - r1) / h_far))

    def point(r, theta):
        return occ.addPoint(r * math.cos(theta), r * math.sin(theta), 0.0)

    c = occ.addPoint(0.0, 0.0, 0.0)
    sectors = {}
    for body, ra, rb in (("inner", r0, r1), ("outer", r1, r2)):
        a0, b0, b1, a1 = point(ra, theta0), point(rb, theta0), point(rb, theta1), point(ra, theta1)
        side0 = occ.addLine(a0, b0)
        arc_b = occ.addCircleArc(b0, c, b1)
        side1 = occ.addLine(b1, a1)
        arc_a = occ.addCircleArc(a1, c, a0)
        surf = occ.addPlaneSurface([occ.addCurveLoop([side0, arc_b, side1, arc_a])])
        sectors[body] = (surf, arc_a, arc_b, [side0, side1])
    occ.remove([(0, c)])
    occ.synchronize()

    mesh = gmsh.model.mesh
    g = _Groups(gmsh)
    for body, n in (("inner", n_inner), ("outer", n_outer)):
        surf, arc_a, arc_b, sides = sectors[body]
        for arc in (arc_a, arc_b):
            mesh.setTransfiniteCurve(arc, n + 1)
        for side in sides:
            mesh.setTransfiniteCurve(side, n_r + 1)
        mesh.setTransfiniteSurface(surf)
        if quads:
            mesh.setRecombine(2, surf)
        g.add(2, [surf], body)
    (s_in, a_in, b_in, sides_in), (s_out, a_out, b_out, sides_out) = sectors.values()
    g.add(1, [b_in], "inner_surface")
    g.add(1, [a_out], "outer_surface")
    g.add(1, [a_in, *sides_in], "inner_boundary")
    g.add(1, [b_out, *sides_out], "outer_boundary")
    bodies = {
        "inner": ["inner_surface", "inner_boundary"],
        "outer": ["outer_surface", "outer_boundary"],
    }
    meta = _meta(g, bodies, [("outer_surface", "inner_surface")])
    meta.update(n_inner=n_inner, n_outer=n_outer, n_r=n_r)
    return meta


_register(
    Generator(
        name="tiedcurved2d",
        description="two annular sectors with a non-matching circular-arc interface (2D)",
        params={
            "r0": (float, 1.0, "inner radius of the inner body"),
            "r1": (float, 1.5, "radius of the interface"),
            "r2": (float, 2.0, "outer radius of the outer body"),
            "theta0": (float, 0.0, "start angle of both sectors (radians)"),
            "theta1": (float, 0.5 * math.pi, "end angle of both sectors (radians)"),
            "n_inner": (int, 6, "elements of the inner body along its arcs"),
            "n_outer": (int, 9, "elements of the outer body along its arcs"),
            "n_r": (int, 3, "elements through each body's radial thickness"),
            "h_contact": (
                float,
                0.0,
                "if > 0: interface size of the inner body, "
                "n_inner = round(r1 (theta1 - theta0)/h_contact), n_outer scaled",
            ),
            "h_far": (
                float,
                0.0,
                "if > 0: radial size, n_r = round(max(r1 - r0, r2 - r1)/h_far)",
            ),
            "order": _ORDER,
            "quads": (bool, True, "quadrilaterals (else triangles)"),
        },
        build=_build_tiedcurved2d,
        gdim=2,
        checks=_positive("r0")
        + (
            ("r1", lambda p: p["r0"] < p["r1"] < p["r2"], "must lie in (r0, r2)"),
            (
                "theta1",
                lambda p: 0.0 < p["theta1"] - p["theta0"] < math.pi,
                "theta1 - theta0 must lie in (0, pi)",
            ),
        )
        + tuple(
            (k, (lambda p, k=k: p[k] >= 1), "must be at least 1")
            for k in ("n_inner", "n_outer", "n_r")
        )
        + tuple((k, (lambda p, k=k: p[k] >= 0.0), "must be >= 0") for k in ("h_contact", "h_far"))
        + _ORDER_CHECK,
        counts=_tiedcurved_derived,
        nodes=_tiedcurved2d_nodes,
    )
)
