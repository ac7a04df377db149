"""Write the Gmsh meshes of seed 001's healthy artery (config/fem/seed-001-healthy-artery.ron)
that the `gmsh_mesh` test reads: MSH 4.1 ASCII, all quadrilaterals, with the
physical groups docs/fem.md names ("tissue", "wall", "lumen", "top", "bottom").

Sizes follow the built-in mesher at refine 0: 0.4 mm around the artery's outer circle, 1.6 mm
far from it, 0.4 mm in the 1 mm wall.

    pip install gmsh==4.15.2
    python3 seed001_healthy_artery.py      # in this directory
"""

import gmsh

W, H = 0.08, 0.03  # block, m
CX, CY = 0.04, 0.03 - 0.015  # artery centre (depth 15 mm)
R_IN, R_OUT = 0.004, 0.005  # lumen radius, outer wall radius
NEAR, FAR = 0.0004, 0.0016
WALL_SIZE = 0.0004  # inside the 1 mm wall


def build():
    gmsh.model.add("seed-001-healthy-artery")
    occ = gmsh.model.occ
    block = occ.addRectangle(0, 0, 0, W, H)
    outer = occ.addDisk(CX, CY, 0, R_OUT, R_OUT)
    inner = occ.addDisk(CX, CY, 0, R_IN, R_IN)
    tissue = occ.cut([(2, block)], [(2, outer)], removeObject=True, removeTool=False)[0]
    wall = occ.cut([(2, outer)], [(2, inner)], removeObject=True, removeTool=True)[0]
    # Fragment so that tissue and wall share the outer circle's nodes.
    out, out_map = occ.fragment(tissue, wall)
    occ.synchronize()
    tissue_s = [t for _, t in out_map[0]]
    wall_s = [t for _, t in out_map[1]]
    curves = gmsh.model.getEntities(1)
    lumen, top, bottom, outer_c = [], [], [], []
    for _, c in curves:
        xmin, ymin, _, xmax, ymax, _ = gmsh.model.getBoundingBox(1, c)
        if abs(ymin - H) < 1e-6 and abs(ymax - H) < 1e-6:
            top.append(c)
        elif abs(ymin) < 1e-6 and abs(ymax) < 1e-6:
            bottom.append(c)
        elif abs((xmax - xmin) - 2 * R_IN) < 1e-6:
            lumen.append(c)
        elif abs((xmax - xmin) - 2 * R_OUT) < 1e-6:
            outer_c.append(c)
    gmsh.model.addPhysicalGroup(2, tissue_s, name="tissue")
    gmsh.model.addPhysicalGroup(2, wall_s, name="wall")
    gmsh.model.addPhysicalGroup(1, lumen, name="lumen")
    gmsh.model.addPhysicalGroup(1, top, name="top")
    gmsh.model.addPhysicalGroup(1, bottom, name="bottom")
    # Sizes: NEAR on the circles growing to FAR; WALL_SIZE throughout the wall.
    dist = gmsh.model.mesh.field.add("Distance")
    gmsh.model.mesh.field.setNumbers(dist, "CurvesList", outer_c + lumen)
    grow = gmsh.model.mesh.field.add("Threshold")
    gmsh.model.mesh.field.setNumber(grow, "InField", dist)
    gmsh.model.mesh.field.setNumber(grow, "SizeMin", NEAR)
    gmsh.model.mesh.field.setNumber(grow, "SizeMax", FAR)
    gmsh.model.mesh.field.setNumber(grow, "DistMin", 0.0)
    gmsh.model.mesh.field.setNumber(grow, "DistMax", 0.012)
    ring = gmsh.model.mesh.field.add("Restrict")
    const = gmsh.model.mesh.field.add("MathEval")
    gmsh.model.mesh.field.setString(const, "F", str(WALL_SIZE))
    gmsh.model.mesh.field.setNumber(ring, "InField", const)
    gmsh.model.mesh.field.setNumbers(ring, "SurfacesList", wall_s)
    both = gmsh.model.mesh.field.add("Min")
    gmsh.model.mesh.field.setNumbers(both, "FieldsList", [grow, ring])
    gmsh.model.mesh.field.setAsBackgroundMesh(both)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    # All quadrilaterals: Frontal-Delaunay for quads, then Blossom full-quad recombination.
    gmsh.option.setNumber("Mesh.Algorithm", 8)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 3)
    gmsh.model.mesh.generate(2)


def main():
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    build()
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.write("seed-001-healthy-artery.msh")
    types, tags, _ = gmsh.model.mesh.getElements(2)
    print({int(t): len(g) for t, g in zip(types, tags)})
    gmsh.finalize()


if __name__ == "__main__":
    main()
