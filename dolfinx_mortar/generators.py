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
:func:`validate_params` checks the parameters without gmsh (for ``check``).

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
(a gmsh ``Box`` field with a transition layer). The patch generators are
structured (transfinite) and take element counts instead.

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
    ``h_far`` > 0 [0 = off] overrides n_y = round(H/h_far).
    Cells: ``lower``, ``upper``. Facets: ``lower_top`` (master),
    ``upper_bottom`` (slave), ``lower_bottom``, ``upper_top``, ``lower_left``,
    ``upper_left`` (x = 0), ``lower_right``, ``upper_right`` (x = L).
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

Metadata returned by :func:`build`: ``generator``, ``gdim``, every parameter
value (after defaults), ``groups`` (name -> (dim, tag)), ``bodies`` (cell group
-> facet groups on it), ``contact`` (list of ``(slave, master)`` suggestions),
``cell_type`` (gmsh element name), ``num_cells``, ``num_nodes`` and
``cells_per_body``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from dolfinx_mortar.errors import SceneError

__all__ = ["GENERATORS", "Generator", "build", "describe", "validate_params"]


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
    """

    name: str
    description: str
    params: dict[str, tuple[type, object, str]]
    build: Callable[..., dict]
    gdim: int = 2
    checks: tuple[tuple[str, Callable[[dict], bool], str], ...] = field(default=())


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
    return out


def _coerce(key: str, value: object, typ: type) -> object:
    if typ is bool:
        if not isinstance(value, bool):
            raise SceneError(key, f"must be a boolean, not {type(value).__name__}")
        return value
    if typ is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise SceneError(key, f"must be an integer, not {type(value).__name__}")
        return value
    if typ is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SceneError(key, f"must be a number, not {type(value).__name__}")
        if not math.isfinite(value):
            raise SceneError(key, "must be finite")
        return float(value)
    raise TypeError(f"unsupported parameter type {typ!r}")  # pragma: no cover


def describe(name: str | None = None) -> str:
    """Plain-text help: every generator (or one) with its parameters."""
    names = [name] if name is not None else sorted(GENERATORS)
    lines = []
    for n in names:
        gen = GENERATORS[n]
        lines.append(f"{gen.name} ({gen.gdim}D): {gen.description}")
        for key, (typ, default, doc) in gen.params.items():
            lines.append(f"    {key} ({typ.__name__}, default {default!r}): {doc}")
    return "\n".join(lines)


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
    meta = gen.build(**p)
    dim = gen.gdim
    gmsh.model.mesh.generate(dim)
    if p.get("quads") and dim == 2 and _has_mixed_2d(gmsh, meta):
        # Blossom recombination left triangles: redo with the full-quad variant,
        # which subdivides to guarantee quadrilaterals only.
        gmsh.model.mesh.clear()
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 3)
        gmsh.model.mesh.generate(dim)
    gmsh.model.mesh.setOrder(p["order"])
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
    )
)


# ---------------------------------------------------------------------------
# hertz3d
# ---------------------------------------------------------------------------


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

    tol = 1e-6 * max(R, W, H)
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
        params={
            "R": (float, 8.0, "sphere radius"),
            "gap0": (float, 0.0, "initial gap between sphere and block"),
            "W": (float, 20.0, "block width (the quarter model is W/2 x W/2)"),
            "H": (float, 20.0, "block height"),
            **_zone_params(c_zone=1.5, h_contact=0.2, h_far=3.0),
            "grading": (float, 0.3, _GRADING[2]),
            "order": _ORDER,
            "quads": (bool, False, "hexahedra: not available for hertz3d (must be false)"),
        },
        build=_build_hertz3d,
        gdim=3,
        checks=_positive("R", "W", "H", "c_zone", "h_contact", "h_far", "grading")
        + (("gap0", lambda p: -p["R"] < p["gap0"] < p["R"], "must lie in (-R, R)"),)
        + _ORDER_CHECK
        + (("quads", lambda p: not p["quads"], "hexahedra are not available for hertz3d"),),
    )
)


# ---------------------------------------------------------------------------
# patch2d / patch3d
# ---------------------------------------------------------------------------


def _patch_counts(L, H, n_lower, n_upper, n_y, h_contact, h_far):
    if h_contact > 0.0:
        nl = max(1, round(L / h_contact))
        n_upper = max(1, round(nl * n_upper / n_lower))
        n_lower = nl
    if h_far > 0.0:
        n_y = max(1, round(H / h_far))
    return n_lower, n_upper, n_y


def _build_patch2d(L, H, gap0, n_lower, n_upper, n_y, h_contact, h_far, order, quads):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    n_lower, n_upper, n_y = _patch_counts(L, H, n_lower, n_upper, n_y, h_contact, h_far)
    low, (lb, lr, lt, ll) = _polygon(occ, [(0, -H), (L, -H), (L, 0), (0, 0)])
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


def _build_patch3d(L, H, gap0, n_lower, n_upper, n_y, h_contact, h_far, order, quads):
    gmsh = _gmsh()
    occ = gmsh.model.occ
    n_lower, n_upper, n_y = _patch_counts(L, H, n_lower, n_upper, n_y, h_contact, h_far)
    low = occ.addBox(0.0, 0.0, -H, L, L, H)
    up = occ.addBox(0.0, 0.0, gap0, L, L, H)
    occ.synchronize()

    tol = 1e-6 * max(L, H)
    mesh = gmsh.model.mesh
    g = _Groups(gmsh)
    g.add(3, [low], "lower")
    g.add(3, [up], "upper")
    bodies = {}
    for body, vol, n, z0, z1 in (
        ("lower", low, n_lower, -H, 0.0),
        ("upper", up, n_upper, gap0, gap0 + H),
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
                ("left", 0, 0.0),
                ("right", 0, L),
                ("front", 1, 0.0),
                ("back", 1, L),
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
        "order": _ORDER,
        "quads": (bool, True, "quadrilaterals/hexahedra (else triangles/tetrahedra)"),
    }


_PATCH_CHECKS = (
    _positive("L", "H")
    + tuple(
        (k, (lambda p, k=k: p[k] >= 1), "must be at least 1") for k in ("n_lower", "n_upper", "n_y")
    )
    + tuple((k, (lambda p, k=k: p[k] >= 0.0), "must be >= 0") for k in ("h_contact", "h_far"))
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
    )
)
