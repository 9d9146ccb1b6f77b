"""mesh.load_mesh: the one-line errors of meshes it cannot read (serial: rank 0 reads)."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import numpy as np
import pytest
import ufl
from mpi4py import MPI

from dolfinx_mortar.errors import SceneError
from dolfinx_mortar.mesh import load_mesh


def _msh(nodes: list[tuple[float, float]], elements: list[tuple[int, list[int]]]) -> str:
    """A gmsh 2.2 ASCII mesh of 2D ``elements`` (gmsh type, 1-based nodes), all in the
    physical group "body"."""
    lines = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat"]
    lines += ["$PhysicalNames", "1", '2 1 "body"', "$EndPhysicalNames"]
    lines += ["$Nodes", str(len(nodes))]
    lines += [f"{i} {x} {y} 0" for i, (x, y) in enumerate(nodes, 1)]
    lines += ["$EndNodes", "$Elements", str(len(elements))]
    lines += [f"{i} {t} 2 1 1 {' '.join(map(str, ns))}" for i, (t, ns) in enumerate(elements, 1)]
    lines += ["$EndElements"]
    return "\n".join(lines) + "\n"


# a 10-node (P3) triangle: its corners, two nodes per edge, one inside
P3 = _msh(
    [(0, 0), (3, 0), (0, 3), (1, 0), (2, 0), (2, 1), (1, 2), (0, 2), (0, 1), (1, 1)],
    [(21, list(range(1, 11)))],
)
# a quadrilateral and a triangle next to it
MIXED = _msh([(0, 0), (1, 0), (1, 1), (0, 1), (2, 0)], [(3, [1, 2, 3, 4]), (2, [2, 5, 3])])


@pytest.mark.parametrize(
    ("name", "text", "key", "reason"),
    [
        (
            "p3.msh",
            P3,
            "mesh",
            "unsupported cells: 10-node triangle (order 3) (gmsh element type 21); "
            "supported: triangle P1, triangle P2, quadrilateral Q1",
        ),
        (
            "mixed.msh",
            MIXED,
            "mesh",
            "mixed cell types (triangle P1, quadrilateral Q1) are not supported",
        ),
        ("fields.xdmf", '<?xml version="1.0"?>\n<Xdmf/>\n', "mesh.file", "only gmsh .msh"),
        ("a_dir", None, "mesh.file", "is a directory, not a mesh file"),
    ],
    ids=["p3", "mixed", "xdmf", "directory"],
)
def test_meshes_that_cannot_be_read(tmp_path, name, text, key, reason):
    """Each is one error naming the cells by name (they said "unsupported gmsh element
    type 21", "mixed cell types [2, 3]"), the directory as a directory (it said "file not
    found"), and a file of another format as not a gmsh .msh file (it said "line 1:
    syntax error (<)")."""
    path = tmp_path / name
    if text is None:
        path.mkdir()
    else:
        path.write_text(text)
    with pytest.raises(SceneError) as info:
        load_mesh(MPI.COMM_SELF, file=path)
    assert info.value.key == key and reason in info.value.reason, str(info.value)


@pytest.mark.parametrize(
    ("kind", "reason"),
    [
        ("fifo", "is not a regular file (a FIFO), not a mesh file"),
        ("devnull", "/dev/null is not a regular file (a character device), not a mesh file"),
        ("loop", "is a link that loops (too many levels of symbolic links)"),
        ("dangling", "is a link to nothing (dangling)"),
        ("missing", "file not found: "),
    ],
    ids=["fifo", "devnull", "loop", "dangling", "missing"],
)
def test_mesh_file_that_is_not_a_regular_file(tmp_path, kind, reason):
    """A mesh.file that exists but is not a regular file, or a link that leads nowhere, is
    one error saying what it is (session 52: "file not found" for a FIFO, /dev/null and a
    link that loops); nothing opens it (a FIFO would block the read)."""
    import os

    path = tmp_path / "m.msh"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "devnull":
        path = Path("/dev/null")
    elif kind == "loop":
        path.symlink_to(tmp_path / "n.msh")
        (tmp_path / "n.msh").symlink_to(path)
    elif kind == "dangling":
        path.symlink_to(tmp_path / "nowhere.msh")
    with pytest.raises(SceneError) as info:
        load_mesh(MPI.COMM_SELF, file=path)
    assert info.value.key == "mesh.file" and reason in info.value.reason, str(info.value)
    assert str(path) in info.value.reason


# two triangles of the unit square, the second's nodes in clockwise order
SQUARE = [(0, 0), (1, 0), (1, 1), (0, 1)]
TRIS = [(2, [1, 2, 3]), (2, [1, 4, 3])]


@pytest.mark.parametrize(
    ("nodes", "elements", "reason"),
    [
        (
            [(0, 0), (1, "nan"), (1, 1), (0, 1)],
            TRIS,
            "1 node(s) with a non-finite coordinate, e.g. node 2 (1, nan, 0)",
        ),
        ([(0, 0), (1, 0), (1, "inf"), (0, 1)], TRIS, "non-finite coordinate, e.g. node 3"),
        (
            [(0, 0), (1, 0), (2, 0), (3, 0)],  # every y = 0
            TRIS,
            "2 cell(s) of group 'body' with zero area (nodes collinear or coincident), "
            "e.g. element 1",
        ),
        (SQUARE + [(0.5, 0.5)], TRIS + [(2, [1, 3, 5])], "1 cell(s) of group 'body'"),
        (SQUARE + [(1, 1)], [(2, [1, 2, 3]), (2, [1, 3, 4]), (2, [3, 5, 2])], "e.g. element 3"),
        ([(0, 0), (1, 0), (1, 1e-20), (0, 1e-20)], [(3, [1, 2, 3, 4])], "zero area"),  # a quad
    ],
    ids=["nan", "inf", "flat", "collinear", "coincident", "quad"],
)
def test_non_finite_or_degenerate_geometry(tmp_path, nodes, elements, reason):
    """A node with a non-finite coordinate, or a cell of zero area, is one error naming
    mesh.file at load: both passed `check`, and the run failed with a traceback
    (LinAlgError) or a hint that blamed the loads."""
    path = tmp_path / "bad.msh"
    path.write_text(_msh(nodes, elements))
    with pytest.raises(SceneError) as info:
        load_mesh(MPI.COMM_SELF, file=path)
    assert info.value.key == "mesh.file" and reason in info.value.reason, str(info.value)


def test_thin_or_clockwise_cells_are_not_degenerate(tmp_path):
    """Cells in either orientation, and a thin one (aspect ratio 1e-6), load."""
    path = tmp_path / "ok.msh"
    nodes = SQUARE + [(2, 0), (2, 1e-6)]
    path.write_text(_msh(nodes, TRIS + [(2, [2, 5, 6])]))
    data = load_mesh(MPI.COMM_SELF, file=path)
    assert data.mesh.topology.index_map(2).size_local == 3


@pytest.mark.parametrize("last_tag", [7, 10**10])
def test_node_tags_with_gaps_are_renumbered(tmp_path, last_tag):
    """A .msh file whose node tags have gaps (another mesher, a file edited by hand)
    loads: dolfinx's model_to_mesh asserts tags 1 … N, and such a mesh stopped the run
    with an AssertionError traceback."""
    from dolfinx import fem

    tags = [1, 2, 3, last_tag]
    lines = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat"]
    lines += ["$PhysicalNames", "1", '2 1 "body"', "$EndPhysicalNames", "$Nodes", "4"]
    lines += [f"{t} {x} {y} 0" for t, (x, y) in zip(tags, SQUARE, strict=True)]
    lines += ["$EndNodes", "$Elements", "2", "1 2 2 1 1 1 2 3", f"2 2 2 1 1 1 {last_tag} 3"]
    lines += ["$EndElements"]
    path = tmp_path / "gaps.msh"
    path.write_text("\n".join(lines) + "\n")
    data = load_mesh(MPI.COMM_SELF, file=path)
    x = data.mesh.geometry.x[:, :2]
    np.testing.assert_allclose(sorted(map(tuple, x)), sorted(SQUARE))
    area = fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=data.mesh)))
    assert abs(area - 1.0) < 1e-14


def _descriptors_on(path: Path) -> list[int]:
    """This process's open file descriptors whose /proc/self/fd link names ``path``."""
    target = str(path.resolve())
    fds = []
    for name in os.listdir("/proc/self/fd"):
        with contextlib.suppress(OSError):  # the listing's own descriptor, closed since
            if os.readlink(f"/proc/self/fd/{name}") == target:
                fds.append(int(name))
    return sorted(fds)


def test_a_mesh_gmsh_cannot_parse_leaves_no_file_open(tmp_path):
    """A .msh file that gmsh cannot parse is one error, and no descriptor on it stays
    open: gmsh 4.8 left one per failed load (three loads, three descriptors; a sweep
    over many files ran out). A host's own handle on that file, open before, stays open
    and reads on; a mesh that gmsh reads leaves nothing open either. The descriptors are
    listed in /proc/self/fd (Linux, the platform of the stack: Debian bookworm)."""
    assert os.path.isdir("/proc/self/fd")
    path = tmp_path / "garbage.msh"  # a .msh header, then what gmsh's reader fails on
    path.write_bytes(b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n" + bytes(range(256)))
    good = tmp_path / "good.msh"
    good.write_text(_msh(SQUARE, TRIS))
    with open(path, "rb") as host:
        assert host.read(4) == b"$Mes"
        for _ in range(3):
            with pytest.raises(SceneError) as info:
                load_mesh(MPI.COMM_SELF, file=path)
            assert info.value.key == "mesh.file", str(info.value)
            assert info.value.reason.startswith(f"cannot read {path}: "), str(info.value)
            assert "\n" not in info.value.reason, str(info.value)  # gmsh's words vary
            assert _descriptors_on(path) == [host.fileno()]
        assert host.read(4) == b"hFor"
        load_mesh(MPI.COMM_SELF, file=good)
        assert _descriptors_on(good) == []
        assert _descriptors_on(path) == [host.fileno()]
    assert _descriptors_on(path) == []


def test_a_script_named_msh_is_refused_unrun(tmp_path):
    """A file that does not begin as a .msh file does (``$MeshFormat``) is refused before
    gmsh sees it: gmsh ran any other file as a .geo script, whatever its name, so a
    ``SystemCall`` in a "mesh" ran a shell command (and its option assignments outlived
    the run in a host's gmsh session). The refusal names the file's first line."""
    marker = tmp_path / "ran"
    path = tmp_path / "mesh.msh"
    path.write_text(f'SystemCall "touch {marker}";\nPoint(1) = {{0, 0, 0}};\n')
    with pytest.raises(SceneError) as info:
        load_mesh(MPI.COMM_SELF, file=path)
    assert info.value.key == "mesh.file", str(info.value)
    assert info.value.reason.startswith(
        f"cannot read {path}: not a gmsh .msh file: it begins 'SystemCall"
    ), str(info.value)
    assert "$MeshFormat" in info.value.reason
    assert not marker.exists()
    # white space before $MeshFormat: gmsh read that as a script too ("syntax error ($)")
    path.write_text("\n" + _msh(SQUARE, TRIS))
    with pytest.raises(SceneError, match="not a gmsh .msh file: it begins ''"):
        load_mesh(MPI.COMM_SELF, file=path)
    # binary bytes are shown escaped (they were decoded with replacement characters and
    # echoed raw to the terminal; QA, session 65), an escape sequence too
    path.write_bytes(b"\xda\xaa\x1b[2Jl\x8bc\x00\xff|v,\n" + bytes(range(256)))
    with pytest.raises(SceneError) as info:
        load_mesh(MPI.COMM_SELF, file=path)
    assert "it begins with bytes b'\\xda\\xaa\\x1b[2Jl\\x8bc\\x00\\xff|v,'" in str(info.value)
    assert str(info.value).isascii() and "\x1b" not in str(info.value)


def test_an_options_file_beside_the_mesh_is_not_read(tmp_path):
    """gmsh's ``open`` merges ``<mesh>.opt`` beside the mesh (.geo syntax: options,
    ``SystemCall``); ``load_mesh`` reads the mesh through a link in a directory of its
    own, where there is none: the mesh loads and the options file is not run."""
    marker = tmp_path / "ran"
    path = tmp_path / "square.msh"
    path.write_text(_msh(SQUARE, TRIS))
    (tmp_path / "square.msh.opt").write_text(f'SystemCall "touch {marker}";\n')
    data = load_mesh(MPI.COMM_SELF, file=path)
    assert data.mesh.topology.index_map(2).size_global == 2
    assert not marker.exists()
