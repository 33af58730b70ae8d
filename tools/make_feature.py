#!/usr/bin/python3
"""A reference feature folder from faces picked on a part: geometry, gmsh shell mesh, specification.

    /usr/bin/python3 tools/make_feature.py PART --faces 12,13,14 --name "mounting lug" --size 3 \\
        [--rigid-faces 13,14] OUT_DIR

PART is a STEP or BREP file; --faces are FreeCAD's FaceN numbers (gmsh numbers the faces alike: the
script checks the count). Writes OUT_DIR/geometry.brep (the picked faces, the reference to search
with), mesh.inp and mesh.msh (quad-dominant shells of the given size, turned outward from the solid:
the part's outside), and feature.json with an element-size rule, the node sets and, with
--rigid-faces, a BOLT_RIGID node set (those faces' nodes, e.g. a bolt hole) analysed as a rigid body.
gmsh runs here as a separate program, as everywhere in the project. Deterministic (one thread).
"""

import argparse
import json
import os
import sys

try:
    import gmsh
except ImportError:
    sys.exit("make_feature.py: the gmsh Python module is missing (apt-get install -y --no-install-recommends gmsh python3-gmsh)")

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_features import gmsh_version, write_inp, SHELL_TYPES  # noqa: E402


def options(size):
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads2D", 1)
    gmsh.option.setNumber("Mesh.RandomSeed", 1)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", size / 4)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 12)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay, recombined (gmsh 4.8's algorithm 8 crashes here)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.option.setNumber("Mesh.SaveAll", 0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("part")
    ap.add_argument("out")
    ap.add_argument("--faces", required=True, help="FaceN numbers, comma separated")
    ap.add_argument("--name", required=True)
    ap.add_argument("--size", type=float, required=True, help="element size (mm)")
    ap.add_argument("--rigid-faces", default="", help="faces whose nodes form BOLT_RIGID (a rigid bolt connection)")
    a = ap.parse_args()
    faces = [int(x) for x in a.faces.split(",") if x.strip()]
    rigid = [int(x) for x in a.rigid_faces.split(",") if x.strip()]
    if not set(rigid) <= set(faces):
        sys.exit(f"make_feature.py: --rigid-faces {rigid} must be among --faces")
    os.makedirs(a.out, exist_ok=True)
    gmsh.initialize(["make_feature", "-nopopup"], readConfigFiles=False)
    try:
        options(a.size)
        gmsh.model.add("part")
        gmsh.model.occ.importShapes(a.part)
        gmsh.model.occ.synchronize()
        surfaces = [t for _, t in gmsh.model.getEntities(2)]
        if any(f not in surfaces for f in faces):
            sys.exit(f"make_feature.py: {a.part} has {len(surfaces)} faces; --faces asks for {faces}")
        volumes = [t for _, t in gmsh.model.getEntities(3)]
        # mesh the picked faces only: the others leave the model (their curves stay)
        gmsh.model.removeEntities([(3, v) for v in volumes])
        gmsh.model.removeEntities([(2, s) for s in surfaces if s not in faces])
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.renumberNodes()
        gmsh.model.mesh.renumberElements()
        elems = []
        for s in faces:
            types, etags, enodes = gmsh.model.mesh.getElements(2, s)
            for ty, tags, conn in zip(types, etags, enodes):
                k = SHELL_TYPES[int(ty)][1]
                for i, et in enumerate(tags):
                    elems.append([int(et), int(ty), [int(x) for x in conn[k * i:k * i + k]], s])
        # the nodes of those elements (the curves of the faces left out are meshed too, and not wanted)
        nodes = {}
        for e in elems:
            for n in e[2]:
                if n not in nodes:
                    nodes[n] = tuple(float(c) for c in gmsh.model.mesh.getNode(n)[0])
        # outward: a point a little along the element's normal must lie outside the solid
        flips = turn_outward(a.part, nodes, elems, a.size)
        elems.sort()
        node_sets = {}
        if rigid:
            bolt = set()
            for s in rigid:
                t, _, _ = gmsh.model.mesh.getNodes(2, s, includeBoundary=True)
                bolt |= {int(x) for x in t if int(x) in nodes}
            node_sets["BOLT_RIGID"] = sorted(bolt)
        elem_sets = {set_name(a.name): [e[0] for e in elems]}
        write_inp(os.path.join(a.out, "mesh.inp"), a.name, nodes, elems, elem_sets, node_sets)
        # geometry: the picked faces as BREP
        gmsh.model.remove()
        gmsh.model.add("faces")
        gmsh.model.occ.importShapes(a.part)
        gmsh.model.occ.synchronize()
        others = [(2, s) for _, s in gmsh.model.getEntities(2) if s not in faces]
        gmsh.model.occ.remove(gmsh.model.getEntities(3))
        gmsh.model.occ.remove(others, recursive=True)
        gmsh.model.occ.synchronize()
        gmsh.write(os.path.join(a.out, "geometry.brep"))
        spec = {
            "name": a.name,
            "geometry": "geometry.brep",
            "mesh": "mesh.inp",
            "unit": "mm",
            "element": {"kind": "shell", "types": ["S4", "S3"], "size": a.size},
            "rules": [{"rule": "element_size", "size": a.size, "text": f"element size {a.size:g} mm"},
                      {"rule": "quad_dominant", "text": "mostly quadrilaterals (recombined)"}],
            "node_sets": {},
            "element_sets": {set_name(a.name): "all elements of the feature"},
            "source": {"part": os.path.basename(a.part), "faces": faces, "rigid_faces": rigid},
            "counts": {"nodes": len(nodes), "elements": len(elems),
                       "S4": sum(1 for e in elems if e[1] == 3), "S3": sum(1 for e in elems if e[1] == 2)},
            "made_by": "tools/make_feature.py with gmsh %s" % gmsh_version(),
        }
        if rigid:
            spec["node_sets"]["BOLT_RIGID"] = f"nodes of faces {rigid}: rigid bolt connection (RBE2)"
            spec["analysis"] = [{"kind": "rigid_body", "node_set": "BOLT_RIGID",
                                 "text": "bolt connection: the nodes move as one rigid body about their centroid, "
                                         "where the bolt load goes"}]
        with open(os.path.join(a.out, "feature.json"), "w", newline="\n") as f:
            json.dump(spec, f, indent=2)
            f.write("\n")
        print(f"make_feature: {a.name}: {len(nodes)} nodes, {len(elems)} elements, {len(flips)} faces turned outward -> {a.out}")
    finally:
        gmsh.finalize()


def set_name(text):
    out = "".join(c.upper() if c.isalnum() else "_" for c in text)
    while "__" in out:
        out = out.replace("__", "_")
    return out.strip("_") or "FEATURE"


def turn_outward(part, nodes, elems, size):
    """Reverses, face by face, the elements whose normal points into the solid (majority vote over the
    face's elements, tested with a second model of the whole part). Returns the faces turned."""
    import math
    current = gmsh.model.getCurrent()
    gmsh.model.add("solid")
    gmsh.model.occ.importShapes(part)
    gmsh.model.occ.synchronize()
    vols = [t for _, t in gmsh.model.getEntities(3)]
    by_face = {}
    for e in elems:
        by_face.setdefault(e[3], []).append(e)
    turned = []
    for s, es in by_face.items():
        votes = 0
        for e in es[:: max(1, len(es) // 25)]:
            p = [nodes[n] for n in e[2]]
            c = [sum(q[k] for q in p) / len(p) for k in range(3)]
            u = [p[1][k] - p[0][k] for k in range(3)]
            v = [p[2][k] - p[0][k] for k in range(3)]
            n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
            ln = math.sqrt(sum(x * x for x in n)) or 1.0
            q = [c[k] + 0.05 * size * n[k] / ln for k in range(3)]
            inside = any(gmsh.model.isInside(3, vol, q) for vol in vols) if vols else False
            votes += 1 if inside else -1
        if votes > 0:
            turned.append(s)
            for e in es:
                e[2] = [e[2][0]] + e[2][1:][::-1]
    gmsh.model.remove()
    gmsh.model.setCurrent(current)
    return turned


if __name__ == "__main__":
    main()
