"""The rounded flat punch of docs/method-notes.md ("Flat-punch edge"), a session-54
probe's mesh script (/tmp/adv55/p1/mkmesh.py), tidied: a block [-5, 5] x [-5, 0] under
a punch [-1, 1] x [0, 1] whose lower corners are rounded with radius 0.1 (flat part
|x| <= 0.9), touching the block at y = 0; triangles of size h_c in the box [-1.5, 1.5]
x [-0.5, 0.3] (gmsh's Box field, growing to 0.5 over 1.5 outside it).

    /usr/bin/python3 bench/flat_punch/mesh.py [h_c = 0.05] [order = 1] [out = punch.msh]

Groups: ``block``, ``punch`` (cells); ``block_top`` (y = 0), ``block_bottom``,
``punch_bottom`` (the flat bottom and the two lower arcs), ``punch_top``. The scene is
``punch.toml`` (it reads ``punch.msh`` beside it); ``reference.py`` is the conforming
reference.
"""

import sys

import gmsh

W, H, A, HP, R = 10.0, 5.0, 1.0, 1.0, 0.1  # block width, height; punch half-width, height, corner


def main(h_c: float = 0.05, order: int = 1, out: str = "punch.msh") -> int:
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("punch")
    occ = gmsh.model.occ
    blk = occ.addRectangle(-W / 2, -H, 0, W, H)
    pun = occ.addRectangle(-A, 0, 0, 2 * A, HP, -1, R)
    occ.synchronize()

    def curves(surface):
        return [c[1] for c in gmsh.model.getBoundary([(2, surface)], oriented=False)]

    def at_y(c, y):  # the curve lies on the line y
        box = gmsh.model.getBoundingBox(1, c)
        return abs(box[1] - y) < 1e-5 and abs(box[4] - y) < 1e-5

    groups = {
        (2, "block"): [blk],
        (2, "punch"): [pun],
        (1, "block_top"): [c for c in curves(blk) if at_y(c, 0.0)],
        (1, "block_bottom"): [c for c in curves(blk) if at_y(c, -H)],
        # the flat bottom and the two lower arcs
        (1, "punch_bottom"): [
            c for c in curves(pun) if gmsh.model.getBoundingBox(1, c)[4] < HP / 2
        ],
        (1, "punch_top"): [c for c in curves(pun) if at_y(c, HP)],
    }
    for (dim, name), entities in groups.items():
        gmsh.model.setPhysicalName(dim, gmsh.model.addPhysicalGroup(dim, entities), name)
    field = gmsh.model.mesh.field
    box = field.add("Box")
    for key, value in (
        ("VIn", h_c),
        ("VOut", 0.5),
        ("XMin", -1.5),
        ("XMax", 1.5),
        ("YMin", -0.5),
        ("YMax", 0.3),
        ("Thickness", 1.5),
    ):
        field.setNumber(box, key, value)
    field.setAsBackgroundMesh(box)
    for key in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{key}", 0)
    gmsh.model.mesh.generate(2)
    gmsh.model.mesh.setOrder(order)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(out)
    nodes = len(gmsh.model.mesh.getNodes()[0])
    gmsh.finalize()
    return nodes


if __name__ == "__main__":
    args = sys.argv[1:]
    h_c = float(args[0]) if args else 0.05
    order = int(args[1]) if len(args) > 1 else 1
    print("nodes", main(h_c, order, args[2] if len(args) > 2 else "punch.msh"))
