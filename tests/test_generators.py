"""Tests of dolfinx_mortar.generators: groups, separate bodies, geometry, dolfinx import.

Each rank builds its own small gmsh model and converts it on ``COMM_SELF``, so
the file also runs under mpirun.
"""

import numpy as np
import pytest

gmsh = pytest.importorskip("gmsh")
pytest.importorskip("dolfinx")

from dolfinx.io import gmshio  # noqa: E402
from mpi4py import MPI  # noqa: E402

from dolfinx_mortar import generators as G  # noqa: E402
from dolfinx_mortar.errors import SceneError  # noqa: E402

# Coarse parameters: every generator in well under a second.
COARSE = {
    "hertz2d": {"h_contact": 0.5, "h_far": 4.0},
    "hertz3d": {"h_contact": 1.0, "h_far": 5.0, "W": 12.0, "H": 8.0},
    "patch2d": {},
    "patch3d": {"n_lower": 2, "n_upper": 3, "n_y": 2},
    "cattaneo2d": {"h_contact": 0.5, "h_far": 4.0},
    "wedge2d": {"h_contact": 0.2, "h_far": 0.5},
}

# name -> (cell groups, facet groups, contact surfaces (slave, master))
GROUPS = {
    "hertz2d": (
        ["cylinder", "block"],
        ["cylinder_surface", "cylinder_top", "block_top", "block_bottom", "symmetry"],
        ("cylinder_surface", "block_top"),
    ),
    "hertz3d": (
        ["sphere", "block"],
        ["sphere_surface", "sphere_top", "block_top", "block_bottom", "symmetry_x", "symmetry_y"],
        ("sphere_surface", "block_top"),
    ),
    "patch2d": (
        ["lower", "upper"],
        [f"{b}_{s}" for b in ("lower", "upper") for s in ("top", "bottom", "left", "right")],
        ("upper_bottom", "lower_top"),
    ),
    "patch3d": (
        ["lower", "upper"],
        [
            f"{b}_{s}"
            for b in ("lower", "upper")
            for s in ("top", "bottom", "left", "right", "front", "back")
        ],
        ("upper_bottom", "lower_top"),
    ),
    "cattaneo2d": (
        ["upper", "lower"],
        ["upper_surface", "lower_surface", "upper_top", "lower_bottom"],
        ("upper_surface", "lower_surface"),
    ),
    "wedge2d": (
        ["block", "wedge"],
        [
            "block_bottom",
            "wedge_top",
            "block_top",
            "block_left",
            "block_right",
            "wedge_bottom",
            "wedge_left",
            "wedge_right",
        ],
        ("block_bottom", "wedge_top"),
    ),
}


@pytest.fixture(scope="module")
def session():
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    yield
    gmsh.finalize()


@pytest.fixture
def model(session):
    gmsh.model.add("test")
    yield gmsh.model
    gmsh.model.remove()


def group_nodes(name, meta):
    """Coordinates (n, 3) of every gmsh node of the named physical group."""
    dim, tag = meta["groups"][name]
    _, xyz = gmsh.model.mesh.getNodesForPhysicalGroup(dim, tag)
    return np.asarray(xyz).reshape(-1, 3)


def group_node_tags(name, meta):
    dim, tag = meta["groups"][name]
    tags, _ = gmsh.model.mesh.getNodesForPhysicalGroup(dim, tag)
    return set(np.asarray(tags, dtype=np.int64).tolist())


def num_elements(name, meta):
    dim, tag = meta["groups"][name]
    n = 0
    for e in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
        _, etags, _ = gmsh.model.mesh.getElements(dim, e)
        n += sum(len(t) for t in etags)
    return n


def check_model(name, meta):
    """Physical names and dimensions, non-empty groups, separate bodies."""
    cells, facets, (slave, master) = GROUPS[name]
    gdim = meta["gdim"]
    assert gdim == G.GENERATORS[name].gdim
    expected = {(gdim, c) for c in cells} | {(gdim - 1, f) for f in facets}
    found = {(d, gmsh.model.getPhysicalName(d, t)) for d, t in gmsh.model.getPhysicalGroups()}
    assert found == expected
    for n in cells + facets:
        assert num_elements(n, meta) > 0, n
    assert set(meta["bodies"]) == set(cells)
    assert (slave, master) in [tuple(c) for c in meta["contact"]]
    a, b = (group_node_tags(c, meta) for c in cells)
    assert not a & b
    assert not group_node_tags(slave, meta) & group_node_tags(master, meta)


def convert(name, meta):
    """Convert with dolfinx; check cells, tags and that the bodies share no vertex."""
    cells, facets, _ = GROUPS[name]
    mesh, ct, ft = gmshio.model_to_mesh(gmsh.model, MPI.COMM_SELF, 0, gdim=meta["gdim"])
    tdim = mesh.topology.dim
    assert tdim == meta["gdim"]
    assert mesh.topology.index_map(tdim).size_local == meta["num_cells"] > 0
    for n in facets:
        tag = meta["groups"][n][1]
        assert np.count_nonzero(ft.values == tag) == num_elements(n, meta), n
    mesh.topology.create_connectivity(tdim, 0)
    c2v = mesh.topology.connectivity(tdim, 0)
    verts = []
    for c in cells:
        ids = ct.indices[ct.values == meta["groups"][c][1]]
        assert len(ids) == meta["cells_per_body"][c]
        verts.append(set(np.concatenate([c2v.links(i) for i in ids]).tolist()))
    assert not verts[0] & verts[1]
    return mesh, ct, ft


@pytest.mark.parametrize("name", sorted(COARSE))
def test_generator_groups_and_conversion(model, name):
    meta = G.build(name, COARSE[name])
    assert meta["generator"] == name
    check_model(name, meta)
    convert(name, meta)


@pytest.mark.parametrize("name", ["hertz2d", "cattaneo2d", "wedge2d", "patch2d", "patch3d"])
def test_quads(model, name):
    meta = G.build(name, dict(COARSE[name], quads=True))
    assert meta["cell_type"].startswith("Quadrilateral" if meta["gdim"] == 2 else "Hexahedron")
    check_model(name, meta)
    convert(name, meta)


def test_quad_fallback(model, monkeypatch):
    """If blossom leaves triangles, build() remeshes with the full-quad algorithm."""
    calls = []

    def mixed(gmsh_module, meta):
        calls.append(meta)
        return True

    monkeypatch.setattr(G, "_has_mixed_2d", mixed)
    meta = G.build("hertz2d", dict(COARSE["hertz2d"], quads=True))
    assert calls and meta["cell_type"].startswith("Quadrilateral")
    s = group_nodes("cylinder_surface", meta)
    assert np.allclose(np.hypot(s[:, 0], s[:, 1] - 8.0), 8.0, rtol=0, atol=1e-9)
    check_model("hertz2d", meta)
    convert("hertz2d", meta)


@pytest.mark.parametrize("name", ["hertz2d", "hertz3d", "patch2d", "patch3d", "cattaneo2d"])
def test_second_order(model, name):
    meta = G.build(name, dict(COARSE[name], order=2))
    assert meta["cell_type"].split()[-1] in ("6", "9", "10", "27")
    check_model(name, meta)
    mesh, _, _ = convert(name, meta)
    assert mesh.geometry.cmap.degree == 2


def test_patch3d_tets(model):
    meta = G.build("patch3d", dict(COARSE["patch3d"], quads=False))
    assert meta["cell_type"].startswith("Tetrahedron")
    check_model("patch3d", meta)
    convert("patch3d", meta)


@pytest.mark.parametrize("gap0, order", [(0.0, 1), (0.25, 2)])
def test_hertz2d_geometry(model, gap0, order):
    R, W, H = 8.0, 20.0, 20.0
    meta = G.build("hertz2d", dict(COARSE["hertz2d"], gap0=gap0, order=order))
    assert meta["R"] == R and meta["gdim"] == 2
    x = group_nodes("block_top", meta)
    assert np.all(x[:, 1] == 0.0) and np.isclose(x[:, 0].min(), 0.0)
    assert np.isclose(x[:, 0].max(), W / 2)
    assert np.allclose(group_nodes("block_bottom", meta)[:, 1], -H)
    assert np.allclose(group_nodes("cylinder_top", meta)[:, 1], R + gap0)
    assert np.allclose(group_nodes("symmetry", meta)[:, 0], 0.0, atol=1e-14)
    s = group_nodes("cylinder_surface", meta)
    r = np.hypot(s[:, 0], s[:, 1] - (R + gap0))
    assert np.allclose(r, R, rtol=0, atol=1e-9 * R)
    low = s[np.argmin(s[:, 1])]
    assert np.allclose(low[:2], [0.0, gap0], rtol=0, atol=1e-12 * R)
    assert s[:, 0].min() >= -1e-12 * R and s[:, 1].max() <= R + gap0 + 1e-12 * R
    # refined near the origin: the arc's nodes near the tip are about h_contact apart
    near = s[np.hypot(s[:, 0], s[:, 1] - gap0) < 1.0]
    assert len(near) >= (1.0 / COARSE["hertz2d"]["h_contact"]) * order


def test_hertz3d_geometry(model):
    R, W, H = 8.0, COARSE["hertz3d"]["W"], COARSE["hertz3d"]["H"]
    meta = G.build("hertz3d", COARSE["hertz3d"])
    assert np.allclose(group_nodes("block_top", meta)[:, 2], 0.0, atol=1e-14)
    assert np.allclose(group_nodes("block_bottom", meta)[:, 2], -H)
    assert np.allclose(group_nodes("sphere_top", meta)[:, 2], R)
    assert np.allclose(group_nodes("symmetry_x", meta)[:, 0], 0.0, atol=1e-12)
    assert np.allclose(group_nodes("symmetry_y", meta)[:, 1], 0.0, atol=1e-12)
    bt = group_nodes("block_top", meta)
    assert np.isclose(bt[:, 0].max(), W / 2) and np.isclose(bt[:, 1].max(), W / 2)
    s = group_nodes("sphere_surface", meta)
    r = np.linalg.norm(s - [0.0, 0.0, R], axis=1)
    assert np.allclose(r, R, rtol=0, atol=1e-9 * R)
    low = s[np.argmin(s[:, 2])]
    assert np.allclose(low, 0.0, rtol=0, atol=1e-12 * R)
    assert s[:, :2].min() >= -1e-12 * R and s[:, 2].max() <= R + 1e-12 * R


def test_patch_geometry(model):
    meta = G.build("patch2d", {"gap0": 0.0})
    nl, nu, ny = meta["n_lower"], meta["n_upper"], meta["n_y"]
    assert (nl, nu, ny) == (5, 7, 3)
    lt, ub = group_nodes("lower_top", meta), group_nodes("upper_bottom", meta)
    assert np.all(lt[:, 1] == 0.0) and np.all(ub[:, 1] == 0.0)
    assert len(lt) == nl + 1 and len(ub) == nu + 1
    assert np.allclose(np.sort(lt[:, 0]), np.linspace(0.0, 1.0, nl + 1))
    assert np.allclose(group_nodes("lower_bottom", meta)[:, 1], -0.5)
    assert np.allclose(group_nodes("upper_top", meta)[:, 1], 0.5)
    for side, x in (("left", 0.0), ("right", 1.0)):
        for body in ("lower", "upper"):
            pts = group_nodes(f"{body}_{side}", meta)
            assert np.allclose(pts[:, 0], x) and len(pts) == ny + 1
    assert meta["cells_per_body"] == {"lower": nl * ny, "upper": nu * ny}


def test_patch_h_overrides(model):
    meta = G.build("patch2d", {"h_contact": 0.1, "h_far": 0.25})
    assert (meta["n_lower"], meta["n_upper"], meta["n_y"]) == (10, 14, 2)


def test_patch3d_geometry(model):
    meta = G.build("patch3d", {"gap0": 0.1})
    nl, nu, ny = meta["n_lower"], meta["n_upper"], meta["n_y"]
    assert meta["cells_per_body"] == {"lower": nl * nl * ny, "upper": nu * nu * ny}
    assert len(group_nodes("lower_top", meta)) == (nl + 1) ** 2
    assert len(group_nodes("upper_bottom", meta)) == (nu + 1) ** 2
    axes = {"top": 2, "bottom": 2, "left": 0, "right": 0, "front": 1, "back": 1}
    values = {
        ("lower", "top"): 0.0,
        ("lower", "bottom"): -0.5,
        ("upper", "bottom"): 0.1,
        ("upper", "top"): 0.6,
    }
    for body in ("lower", "upper"):
        for side, axis in axes.items():
            v = values.get((body, side), 0.0 if side in ("left", "front") else 1.0)
            assert np.allclose(group_nodes(f"{body}_{side}", meta)[:, axis], v), (body, side)


def test_cattaneo2d_geometry(model):
    R = 8.0
    meta = G.build("cattaneo2d", COARSE["cattaneo2d"])
    up, lo = group_nodes("upper_surface", meta), group_nodes("lower_surface", meta)
    assert np.allclose(np.hypot(up[:, 0], up[:, 1] - R), R, rtol=0, atol=1e-9 * R)
    assert np.allclose(np.hypot(lo[:, 0], lo[:, 1] + R), R, rtol=0, atol=1e-9 * R)
    assert np.allclose(up[np.argmin(up[:, 1])][:2], 0.0, atol=1e-12 * R)
    assert np.allclose(lo[np.argmax(lo[:, 1])][:2], 0.0, atol=1e-12 * R)
    assert np.isclose(up[:, 0].min(), -R) and np.isclose(up[:, 0].max(), R)
    assert np.allclose(group_nodes("upper_top", meta)[:, 1], R)
    assert np.allclose(group_nodes("lower_bottom", meta)[:, 1], -R)


def test_wedge2d_geometry(model):
    meta = G.build("wedge2d", dict(COARSE["wedge2d"], tan_alpha=0.2))
    t, x0, b = 0.2, meta["x0"], meta["b"]
    for n in ("block_bottom", "wedge_top"):
        p = group_nodes(n, meta)
        assert np.allclose(p[:, 1], t * p[:, 0], atol=1e-12)
    bb = group_nodes("block_bottom", meta)
    assert np.isclose(bb[:, 0].min(), x0) and np.isclose(bb[:, 0].max(), x0 + b)
    top = group_nodes("block_top", meta)
    assert np.allclose(top[:, 1], (x0 + b / 2) * t + meta["block_height"])
    assert np.allclose(group_nodes("block_left", meta)[:, 0], x0)
    assert np.allclose(group_nodes("wedge_bottom", meta)[:, 1], -meta["H"])


def test_default_sizes_documented():
    for name, gen in G.GENERATORS.items():
        assert gen.description
        for key in ("h_contact", "h_far", "order"):
            assert key in gen.params, (name, key)
        for key, (typ, default, doc) in gen.params.items():
            assert isinstance(default, typ) and doc, (name, key)
    assert "hertz2d" in G.describe() and "h_contact" in G.describe("hertz3d")


def test_validation_defaults():
    p = G.validate_params("hertz2d", None)
    assert p["R"] == 8.0 and p["gap0"] == 0.0 and p["h_contact"] == 0.1 and p["order"] == 1
    p = G.validate_params("hertz2d", {"R": 4})  # an int for a float
    assert p["R"] == 4.0 and isinstance(p["R"], float)


@pytest.mark.parametrize(
    "name, params, key",
    [
        ("hertz2d", {"foo": 1.0}, "mesh.params.foo"),
        ("hertz2d", {"h_contact": "fine"}, "mesh.params.h_contact"),
        ("hertz2d", {"h_contact": -0.1}, "mesh.params.h_contact"),
        ("hertz2d", {"h_far": float("nan")}, "mesh.params.h_far"),
        ("hertz2d", {"R": True}, "mesh.params.R"),
        ("hertz2d", {"order": 3}, "mesh.params.order"),
        ("hertz2d", {"order": 2.0}, "mesh.params.order"),
        ("hertz2d", {"quads": 1}, "mesh.params.quads"),
        ("hertz2d", {"gap0": 9.0}, "mesh.params.gap0"),
        ("hertz3d", {"quads": True}, "mesh.params.quads"),
        ("patch2d", {"n_lower": 0}, "mesh.params.n_lower"),
        ("patch3d", {"n_y": 2.5}, "mesh.params.n_y"),
        ("wedge2d", {"x0": 3.5}, "mesh.params.x0"),
        ("nope", {}, "mesh.generator"),
    ],
)
def test_validation_errors(name, params, key):
    with pytest.raises(SceneError) as err:
        G.build(name, params)  # raises before gmsh is touched
    assert err.value.key == key
    assert str(err.value).startswith(key + ": ")


def test_params_must_be_table():
    with pytest.raises(SceneError) as err:
        G.validate_params("hertz2d", [("R", 1.0)])
    assert err.value.key == "mesh.params"
