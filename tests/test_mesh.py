"""mesh.load_mesh: the one-line errors of meshes it cannot read (serial: rank 0 reads)."""

from __future__ import annotations

import pytest
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
