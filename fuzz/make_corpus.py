#!/usr/bin/python3
"""Seed corpora for the fuzz targets (issue 10), generated, never downloaded:
    /usr/bin/python3 fuzz/make_corpus.py OUT_DIR
writes OUT_DIR/<kind>/ for kind in stl obj ply step iges brep inp msh feature params: small valid
inputs of each kind (B-rep ones made with FreeCAD's OpenCASCADE), so that mutations start from
files a user could have."""
import json
import math
import os
import struct
import sys

sys.path.append("/usr/lib/freecad-python3/lib")
import FreeCAD as App  # noqa: E402
import Part  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def mesh():
    """A small closed mesh: an octagonal prism (vertices, triangles)."""
    v, t = [], []
    n = 8
    for z in (0.0, 3.0):
        for k in range(n):
            a = 2 * math.pi * k / n
            v.append((5 * math.cos(a), 5 * math.sin(a), z))
    v += [(0, 0, 0), (0, 0, 3)]
    for k in range(n):
        j = (k + 1) % n
        t += [(k, j, n + j), (k, n + j, n + k), (2 * n, j, k), (2 * n + 1, n + k, n + j)]
    return v, t


def write(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def main(out):
    v, t = mesh()
    # STL ascii and binary
    a = "solid p\n" + "".join("facet normal 0 0 0\nouter loop\n" + "".join(f"vertex {v[i][0]} {v[i][1]} {v[i][2]}\n" for i in tri) +
                              "endloop\nendfacet\n" for tri in t) + "endsolid p\n"
    write(f"{out}/stl/ascii.stl", a)
    b = b"\0" * 80 + struct.pack("<I", len(t)) + b"".join(struct.pack("<12fH", 0, 0, 0, *[c for i in tri for c in v[i]], 0) for tri in t)
    write(f"{out}/stl/binary.stl", b)
    # OBJ: triangles, a quad and a planar polygon, negative indices
    o = "".join(f"v {x} {y} {z}\n" for x, y, z in v) + "".join(f"f {i + 1} {j + 1} {k + 1}\n" for i, j, k in t[:-8])
    o += "f -1 -2 -3\nf 1/1/1 2/2/2 10/3/3 9/4/4\nf " + " ".join(str(k + 1) for k in range(8)) + "\n"
    write(f"{out}/obj/prism.obj", "# prism\n" + o)
    # PLY ascii, binary little and big endian
    head = lambda fmt: (f"ply\nformat {fmt} 1.0\nelement vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
                        f"element face {len(t)}\nproperty list uchar int vertex_indices\nend_header\n")
    write(f"{out}/ply/ascii.ply", head("ascii") + "".join(f"{x} {y} {z}\n" for x, y, z in v) + "".join(f"3 {i} {j} {k}\n" for i, j, k in t))
    for fmt, e in (("binary_little_endian", "<"), ("binary_big_endian", ">")):
        body = b"".join(struct.pack(e + "3f", *p) for p in v) + b"".join(struct.pack(e + "B3i", 3, *tri) for tri in t)
        write(f"{out}/ply/{fmt}.ply", head(fmt).encode() + body)
    # B-rep: a filleted block with a hole, and a single face (an open shell)
    s = Part.makeBox(20, 12, 6)
    s = s.cut(Part.makeCylinder(2.5, 6, App.Vector(10, 6, 0)))
    s = s.makeFillet(1.0, [e for e in s.Edges if abs(e.BoundBox.ZMax - 6) < 1e-6 and e.BoundBox.ZLength < 1e-6][:4])
    os.makedirs(f"{out}/step", exist_ok=True)
    os.makedirs(f"{out}/iges", exist_ok=True)
    os.makedirs(f"{out}/brep", exist_ok=True)
    s.exportStep(f"{out}/step/block.step")
    Part.Compound([s.Faces[0]]).exportStep(f"{out}/step/face.step")
    s.exportIges(f"{out}/iges/block.iges")
    s.exportBrep(f"{out}/brep/block.brep")
    Part.Compound([s.Faces[0]]).exportBrep(f"{out}/brep/face.brep")
    # extract: a plate with two ribs (one 1.3x), and one rib picked as faces; each is the seed of its
    # role (fuzz_extract.cpp: an even first byte makes the input the target, an odd one the reference)
    # and the fixed partner of the other role (extract_fixed/)
    plate = Part.makeBox(60, 30, 3)
    rib1 = Part.makeBox(20, 3, 6, App.Vector(8, 6, 3))
    rib2 = Part.makeBox(26, 3.9, 7.8, App.Vector(30, 18, 3))
    part = plate.fuse([rib1, rib2]).removeSplitter()
    part = part.makeFillet(0.8, [e for e in part.Edges if e.BoundBox.ZMin > 8.9 and e.BoundBox.ZLength < 1e-6])
    picked = [f for f in part.Faces if f.BoundBox.XMax < 29 and f.BoundBox.ZMin > 2.9 and f.BoundBox.ZLength + f.BoundBox.XLength > 1e-6
              and not (f.BoundBox.ZLength < 1e-6 and f.BoundBox.ZMax < 3.1)]

    def binary_stl(shape, header):
        p, tris = shape.tessellate(0.05)
        return header.ljust(80, b" ")[:80] + struct.pack("<I", len(tris)) + b"".join(
            struct.pack("<12fH", 0, 0, 0, *[c for i in tri for c in (p[i].x, p[i].y, p[i].z)], 0) for tri in tris)
    target = binary_stl(part, b"T plate with two ribs (even first byte: the input is the target)")
    reference = binary_stl(Part.Compound(picked), b"S rib picked as faces (odd first byte: the input is the reference)")
    write(f"{out}/extract/target.stl", target)
    write(f"{out}/extract/reference.stl", reference)
    write(f"{out}/extract_fixed/target.stl", target)
    write(f"{out}/extract_fixed/reference.stl", reference)
    # FE meshes: tiny hand-made ones of every element type, and the shipped rib feature's
    write(f"{out}/inp/tiny.inp", "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 1, 1, 0\n4, 0, 1, 0\n5, 0, 0, 1\n"
                                 "*ELEMENT, TYPE=S4, ELSET=A\n1, 1, 2, 3, 4\n*ELEMENT, TYPE=S3, ELSET=B\n2, 1, 2, 3\n"
                                 "*ELEMENT, TYPE=C3D4, ELSET=C\n3, 1, 2, 4, 5\n*NSET, NSET=TOP\n3, 4\n*ELSET, ELSET=ALL\nA, B\n")
    write(f"{out}/msh/tiny.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4\n2 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
                                 "$EndNodes\n$Elements\n1 2 1 2\n2 1 2 2\n1 1 2 3\n2 1 3 4\n$EndElements\n")
    feat = os.path.join(ROOT, "Resources", "library")
    for name in sorted(os.listdir(feat)):
        d = os.path.join(feat, name)
        for f in os.listdir(d):
            if f.endswith(".inp") or f.endswith(".msh"):
                write(f"{out}/{f.rsplit('.', 1)[1]}/{name}_{f}", open(os.path.join(d, f), "rb").read())
            if f == "feature.json":
                write(f"{out}/feature/{name}.json", open(os.path.join(d, f), "rb").read())
    # parameters
    write(f"{out}/params/empty.json", "{}")
    write(f"{out}/params/some.json", json.dumps({"seed": 7, "scale_max": 2.0, "mirror": False, "shot_radii": 3, "time_limit": 10}))
    write(f"{out}/params/all.json", json.dumps({"dense_spacing": 0.014, "sparse_spacing": 0.035, "max_dense_points": 100000,
                                                "accept_error": 0.05, "refine_iterations": 0}))
    print(f"make_corpus: {sum(len(fs) for _, _, fs in os.walk(out))} seed files in {out}")


if __name__ == "__main__":
    main(sys.argv[1])
