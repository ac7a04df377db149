"""Write the small Gmsh meshes the `gmsh_*` tests read besides the seed-001 artery
(seed001_healthy_artery.py): all MSH 4.1, made with gmsh 4.15.2.

- small-artery.msh, small-artery-binary.msh: seed 001's healthy artery, coarse (the same
  mesh in both encodings: the test checks they read alike).
- triangles.msh: a plain block of triangles (refused: quadrilaterals only).
- box-3d.msh: a 3-D box of tetrahedra (refused: 2-D only).
- unglued.msh: a block made of two rectangles meshed apart, not fragmented (refused: the
  halves share no nodes).

    pip install gmsh==4.15.2
    python3 small_meshes.py      # in this directory
"""

import gmsh

import seed001_healthy_artery as seed

W, H = seed.W, seed.H


def edges(top, bottom):
    """Tag the curves lying on y = H and y = 0."""
    for _, c in gmsh.model.getEntities(1):
        _, ymin, _, _, ymax, _ = gmsh.model.getBoundingBox(1, c)
        if abs(ymin - H) < 1e-6 and abs(ymax - H) < 1e-6:
            top.append(c)
        elif abs(ymin) < 1e-6 and abs(ymax) < 1e-6:
            bottom.append(c)


def write(name, binary=False):
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 1 if binary else 0)
    gmsh.write(name)


def small_artery():
    seed.NEAR, seed.FAR, seed.WALL_SIZE = 0.0015, 0.006, 0.0005
    seed.build()
    write("small-artery.msh")
    write("small-artery-binary.msh", binary=True)
    gmsh.model.remove()
    gmsh.option.setNumber("Mesh.RecombineAll", 0)


def plain_block(name, halves):
    gmsh.model.add(name)
    occ = gmsh.model.occ
    if halves:
        surfaces = [occ.addRectangle(0, 0, 0, W / 2, H), occ.addRectangle(W / 2, 0, 0, W / 2, H)]
    else:
        surfaces = [occ.addRectangle(0, 0, 0, W, H)]
    occ.synchronize()
    top, bottom = [], []
    edges(top, bottom)
    gmsh.model.addPhysicalGroup(2, surfaces, name="tissue")
    gmsh.model.addPhysicalGroup(1, top, name="top")
    gmsh.model.addPhysicalGroup(1, bottom, name="bottom")
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.01)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.01)
    gmsh.option.setNumber("Mesh.RecombineAll", 1 if halves else 0)
    gmsh.model.mesh.generate(2)
    write(name)
    gmsh.model.remove()


def box_3d():
    gmsh.model.add("box-3d")
    box = gmsh.model.occ.addBox(0, 0, 0, W, H, 0.01)
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [box], name="tissue")
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.02)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.02)
    gmsh.option.setNumber("Mesh.RecombineAll", 0)
    gmsh.model.mesh.generate(3)
    write("box-3d.msh")
    gmsh.model.remove()


def main():
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    small_artery()
    plain_block("triangles.msh", halves=False)
    plain_block("unglued.msh", halves=True)
    box_3d()
    gmsh.finalize()


if __name__ == "__main__":
    main()
