#!/usr/bin/python3
"""Rebuild the example reference feature folders (geometry + FE shell mesh + meshing spec).

Usage:
    /usr/bin/python3 tools/make_features.py MODELS_DIR OUT_DIR
    e.g. /usr/bin/python3 tools/make_features.py build/models Resources/library

Reads MODELS_DIR/suite/rib_reference.step and MODELS_DIR/suite/boss_reference.step
(written by `build/fe_make_models build/models --suite`) and writes

    OUT_DIR/rib/  and  OUT_DIR/boss/
        geometry.step   byte copy of the reference faces
        mesh.inp        CalculiX/Abaqus shell mesh: *NODE, *ELEMENT TYPE=S4/S3, *ELSET, *NSET
        mesh.msh        the same mesh in gmsh ASCII format 4.1, physical groups named like the sets
        feature.json    the meshing specification

Node ids and element ids in mesh.inp are the node and element tags of mesh.msh.
Needs gmsh's Python API (Debian: apt-get install gmsh python3-gmsh); runs headless and is
deterministic (single thread, no user gmsh config files, fixed options).
"""

import json
import math
import os
import shutil
import sys
from collections import defaultdict, deque

import numpy as np

try:
    import gmsh
except ImportError:
    sys.exit("make_features.py: the gmsh Python module is missing "
             "(apt-get install -y --no-install-recommends gmsh python3-gmsh)")

MSH_VERSION = 4.1
IDS_PER_LINE = 16
GEO_TOL = 1e-6

# gmsh element type ids -> (Abaqus type, number of nodes)
SHELL_TYPES = {3: ("S4", 4), 2: ("S3", 3)}


# ----------------------------------------------------------------------------------------------
# gmsh helpers
# ----------------------------------------------------------------------------------------------

def gmsh_version():
    return gmsh.option.getString("General.Version")


def set_common_options():
    gmsh.option.setNumber("General.Terminal", 1)
    gmsh.option.setNumber("General.Verbosity", 2)          # errors and warnings only
    gmsh.option.setNumber("General.NumThreads", 1)         # determinism
    gmsh.option.setNumber("Mesh.MaxNumThreads1D", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads2D", 1)
    gmsh.option.setNumber("Geometry.OCCSewFaces", 1)       # one conforming shell, not loose faces
    gmsh.option.setNumber("Mesh.MshFileVersion", MSH_VERSION)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.option.setNumber("Mesh.SaveAll", 0)               # only physical groups
    gmsh.option.setNumber("Mesh.SaveParametric", 0)


def import_faces(step_path):
    """Import the STEP faces as one sewn, healed open shell."""
    gmsh.model.add(os.path.basename(step_path))
    ents = gmsh.model.occ.importShapes(step_path)
    # healShapes also sews; without it gmsh 4.8.4 fails on one corner sphere patch of the rib
    # ("The 1D mesh seems not to be forming a closed loop").
    gmsh.model.occ.healShapes([], tolerance=1e-8, fixDegenerated=True, fixSmallEdges=True,
                              fixSmallFaces=True, sewFaces=True, makeSolids=False)
    gmsh.model.occ.synchronize()
    return [t for d, t in gmsh.model.getEntities(2)]


def curve_points(tag, n=129):
    lo, hi = gmsh.model.getParametrizationBounds(1, tag)
    u = np.linspace(lo[0], hi[0], n)
    return np.array(gmsh.model.getValue(1, tag, u)).reshape(-1, 3)


def curve_length(tag):
    p = curve_points(tag)
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def bbox(dim, tag):
    return gmsh.model.getBoundingBox(dim, tag)


def mesh_and_collect(name):
    """Renumber, then collect nodes and 2D shell elements of the current model."""
    gmsh.model.mesh.renumberNodes()
    gmsh.model.mesh.renumberElements()
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    nodes = {int(t): tuple(float(c) for c in coords[3 * i:3 * i + 3]) for i, t in enumerate(ntags)}
    elems = []   # (tag, gmsh type, [node tags], surface tag)
    for _, s in gmsh.model.getEntities(2):
        types, etags, enodes = gmsh.model.mesh.getElements(2, s)
        for ty, tags, conn in zip(types, etags, enodes):
            ty = int(ty)
            if ty not in SHELL_TYPES:
                raise RuntimeError("%s: unexpected element type %d on surface %d" % (name, ty, s))
            k = SHELL_TYPES[ty][1]
            for i, et in enumerate(tags):
                elems.append((int(et), ty, [int(x) for x in conn[k * i:k * i + k]], s))
    elems.sort()
    return nodes, elems


def surface_flips(nodes, elems):
    """Which surfaces must be reversed so that all shell normals are consistent across shared
    edges, with the normal of the highest element pointing to +z (away from the material for
    a rib / boss standing on a plate)."""
    edge_users = defaultdict(list)
    for idx, (_, _, conn, _) in enumerate(elems):
        for a, b in zip(conn, conn[1:] + conn[:1]):
            edge_users[frozenset((a, b))].append((idx, a, b))
    flip = [None] * len(elems)
    for start in range(len(elems)):
        if flip[start] is not None:
            continue
        flip[start] = False
        queue = deque([start])
        while queue:
            i = queue.popleft()
            conn = elems[i][2]
            for a, b in zip(conn, conn[1:] + conn[:1]):
                if flip[i]:
                    a, b = b, a
                for j, c, d in edge_users[frozenset((a, b))]:
                    if j == i:
                        continue
                    want = (c, d) == (a, b)   # same direction -> must be flipped
                    if flip[j] is None:
                        flip[j] = want
                        queue.append(j)
                    elif flip[j] != want:
                        raise RuntimeError("shell mesh is not orientable")
    # global sign from the highest element
    def normal(i):
        p = [np.array(nodes[n]) for n in elems[i][2]]
        nv = np.cross(p[1] - p[0], p[2] - p[0])
        return -nv if flip[i] else nv
    top = max(range(len(elems)), key=lambda i: (np.mean([nodes[n][2] for n in elems[i][2]]), -i))
    if normal(top)[2] < 0:
        flip = [not f for f in flip]
    per_surface = {}
    for (_, _, _, s), f in zip(elems, flip):
        if per_surface.setdefault(s, f) != f:
            raise RuntimeError("surface %d has mixed element orientations" % s)
    return sorted(s for s, f in per_surface.items() if f)


def generate(name, surfaces):
    """Mesh; if needed, reverse surfaces for consistent normals and mesh again."""
    gmsh.model.mesh.generate(2)
    nodes, elems = mesh_and_collect(name)
    flips = surface_flips(nodes, elems)
    if flips:
        gmsh.model.mesh.clear()
        for s in flips:
            gmsh.model.mesh.setReverse(2, s)
        gmsh.model.mesh.generate(2)
        nodes, elems = mesh_and_collect(name)
        if surface_flips(nodes, elems):
            raise RuntimeError("%s: could not make shell normals consistent" % name)
    return nodes, elems, flips


# ----------------------------------------------------------------------------------------------
# features
# ----------------------------------------------------------------------------------------------

def build_rib(step):
    size = 1.5
    surfaces = import_faces(step)
    gmsh.option.setNumber("Mesh.MeshSizeMin", size)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
    gmsh.option.setNumber("Mesh.Algorithm", 6)             # Frontal-Delaunay (8 segfaults here)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)  # blossom
    gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 0)

    zmax = bbox(-1, -1)[5]
    top_surfaces = [s for s in surfaces if bbox(2, s)[2] >= 10.5 - 1e-6]
    root_curves = [t for _, t in gmsh.model.getEntities(1) if bbox(1, t)[5] <= 0.01]
    groups = [(2, surfaces, "RIB"), (2, top_surfaces, "RIB_TOP"), (1, root_curves, "RIB_ROOT")]
    for dim, tags, gname in groups:
        pg = gmsh.model.addPhysicalGroup(dim, tags)
        gmsh.model.setPhysicalName(dim, pg, gname)

    nodes, elems, flips = generate("rib", surfaces)
    node_sets = {
        "RIB_TOP": sorted(n for n, p in nodes.items() if p[2] >= 10.5),
        "RIB_ROOT": sorted(n for n, p in nodes.items() if p[2] <= 0.01),
    }
    entity_sets = {
        "RIB_TOP": entity_nodes(2, top_surfaces),
        "RIB_ROOT": entity_nodes(1, root_curves),
    }
    spec = {
        "name": "rib",
        "class": "rib",
        "description": "a straight stiffening rib with root fillets on a plate",
        "search": {"scale_min": 0.8, "scale_max": 2.6, "params": {}},
        "thumbnail": "thumbnail.png",
        "geometry": "geometry.step", "mesh": "mesh.inp", "mesh_msh": "mesh.msh",
        "mesh_msh_format": "gmsh ASCII %.1f" % MSH_VERSION,
        "unit": "mm",
        "element": {"kind": "shell", "types": ["S4", "S3"], "size": size},
        "rules": [
            {"rule": "element_size", "size": size, "text": "element size 1.5 mm"},
            {"rule": "quad_dominant", "text": "mostly quadrilaterals (recombined), triangles only where needed"},
        ],
        "node_sets": {
            "RIB_TOP": "nodes on the top flat face and the top fillets (z >= 10.5)",
            "RIB_ROOT": "nodes on the bottom edge of the root fillets, where the rib meets the plate (z <= 0.01)",
        },
        "element_sets": {"RIB": "all rib elements"},
    }
    return nodes, elems, {"RIB": [e[0] for e in elems]}, node_sets, entity_sets, spec, {
        "zmax": zmax, "flipped_surfaces": flips}


def build_boss(step):
    size = 1.0
    angle_step = 30.0
    surfaces = import_faces(step)
    xmin, ymin, zmin, xmax, ymax, zmax = bbox(-1, -1)
    cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)     # vertical axis through the bbox centre
    reach = max(xmax - xmin, ymax - ymin) + 10.0
    occ = gmsh.model.occ

    # Cut the revolved (periodic) faces along 4 meridian half planes (0, 90, 180, 270 deg):
    # gmsh 4.8.4 cannot mesh a periodic face with a seam as a transfinite surface, the quarter
    # patches are 4-sided and get structured 30-degree node rings.
    tools = []
    for k in range(4):
        r = occ.addRectangle(cx, zmin - 1.0, 0.0, reach, (zmax - zmin) + 2.0)  # xy: x->radius, y->z
        occ.rotate([(2, r)], cx, 0, 0, 1, 0, 0, math.pi / 2)                  # y -> z
        occ.translate([(2, r)], 0, cy, 0)
        occ.rotate([(2, r)], cx, cy, 0, 0, 0, 1, k * math.pi / 2)
        tools.append((2, r))
    objs = [(2, s) for s in surfaces]
    _, omap = occ.fragment(objs, tools)
    keep = sorted({t for m in omap[:len(objs)] for t in m})
    drop = sorted({t for m in omap[len(objs):] for t in m} - set(keep))
    occ.remove(drop, recursive=True)
    occ.synchronize()
    surfaces = [t for d, t in gmsh.model.getEntities(2)]

    circles = {}   # curve tag -> (radius, z, number of divisions)
    for _, t in gmsh.model.getEntities(1):
        p = curve_points(t)
        rad = np.hypot(p[:, 0] - cx, p[:, 1] - cy)
        if np.ptp(p[:, 2]) < GEO_TOL and np.ptp(rad) < GEO_TOL and rad.mean() > 1e-3:
            ang = np.unwrap(np.arctan2(p[:, 1] - cy, p[:, 0] - cx))
            span = math.degrees(abs(ang[-1] - ang[0])) or 360.0
            ndiv = int(round(span / angle_step))
            if abs(ndiv * angle_step - span) > 1e-6:
                raise RuntimeError("boss: arc %d spans %.6f deg, not a multiple of %g" % (t, span, angle_step))
            circles[t] = (float(rad.mean()), float(p[0, 2]), ndiv)
        else:
            ndiv = max(1, int(round(curve_length(t) / size)))
        gmsh.model.mesh.setTransfiniteCurve(t, ndiv + 1)

    revolved = [s for s in surfaces if gmsh.model.getType(2, s) != "Plane"]
    disk = [s for s in surfaces if gmsh.model.getType(2, s) == "Plane" and bbox(2, s)[2] >= zmax - 1e-6]
    for s in revolved:
        if len(gmsh.model.getBoundary([(2, s)], False, False)) != 4:
            raise RuntimeError("boss: revolved patch %d is not 4-sided" % s)
        gmsh.model.mesh.setTransfiniteSurface(s)
    # The top disk quarters are 3-sided: transfinite with the centre as the collapsed corner,
    # i.e. a polar grid (node rings every 1 mm, rays every 30 deg, a triangle fan at the centre).
    # Unstructured quarters have an odd boundary (3 + 2 x 5 segments) so blossom leaves many tris.
    e = 1e-6
    centre = gmsh.model.getEntitiesInBoundingBox(cx - e, cy - e, zmax - e, cx + e, cy + e, zmax + e, 0)
    if len(centre) != 1:
        raise RuntimeError("boss: no single vertex at the centre of the top disk")
    for s in disk:
        corners = sorted({t for _, t in gmsh.model.getBoundary([(2, s)], False, False, True)})
        if len(corners) != 3 or centre[0][1] not in corners:
            raise RuntimeError("boss: top disk quarter %d is not a 3-sided sector" % s)
        corners.remove(centre[0][1])
        gmsh.model.mesh.setTransfiniteSurface(s, "Left", [centre[0][1]] + corners)
    gmsh.option.setNumber("Mesh.MeshSizeMin", size)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
    gmsh.option.setNumber("Mesh.Algorithm", 6)             # not used: every boss patch is transfinite
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
    gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 0)

    root_curves = [t for _, t in gmsh.model.getEntities(1) if bbox(1, t)[5] <= 0.01]
    for dim, tags, gname in [(2, surfaces, "BOSS"), (2, disk, "BOLT_RIGID"), (1, root_curves, "BOSS_ROOT")]:
        pg = gmsh.model.addPhysicalGroup(dim, tags)
        gmsh.model.setPhysicalName(dim, pg, gname)

    nodes, elems, flips = generate("boss", surfaces)
    bolt = entity_nodes(2, disk)
    node_sets = {
        "BOLT_RIGID": bolt,
        "BOSS_ROOT": sorted(n for n, p in nodes.items() if p[2] <= 0.01),
    }
    entity_sets = {"BOLT_RIGID": bolt, "BOSS_ROOT": entity_nodes(1, root_curves)}
    axis_point = [round(cx, 6) + 0.0, round(cy, 6) + 0.0, round(zmin, 6) + 0.0]
    spec = {
        "name": "screw boss",
        "class": "boss",
        "description": "a cylindrical screw boss with a root fillet and a flat top for the bolt",
        "search": {"scale_min": 0.8, "scale_max": 2.6, "params": {}},
        "thumbnail": "thumbnail.png",
        "geometry": "geometry.step", "mesh": "mesh.inp", "mesh_msh": "mesh.msh",
        "mesh_msh_format": "gmsh ASCII %.1f" % MSH_VERSION,
        "unit": "mm",
        "element": {"kind": "shell", "types": ["S4", "S3"], "size": size},
        "axis": {"point": axis_point, "direction": [0, 0, 1]},
        "rules": [
            {"rule": "nodes_on_circles", "about": "axis", "angle_step_deg": angle_step,
             "start_angle_deg": 0.0,
             "text": "nodes on circles around the boss axis every 30 degrees"},
            {"rule": "element_size", "size": size,
             "text": "element size 1.0 mm (along the boss; around it the 30 degree rule governs)"},
            {"rule": "quad_dominant", "text": "mostly quadrilaterals (recombined)"},
        ],
        "node_sets": {
            "BOLT_RIGID": "nodes of the top flat disk: rigid bolt connection (RBE2) at the top face",
            "BOSS_ROOT": "nodes at the boss root, where the root fillet meets the plate (z <= 0.01)",
        },
        "element_sets": {"BOSS": "all boss elements"},
        "analysis": [
            {"kind": "rigid_body", "node_set": "BOLT_RIGID",
             "text": "bolt connection: the top disk's nodes move as one rigid body (CalculiX *RIGID BODY, "
                     "Nastran RBE2) about a reference node at their centroid, where the bolt load goes"},
        ],
    }
    info = {"circles": circles, "axis": (cx, cy), "flipped_surfaces": flips, "zmax": zmax}
    return nodes, elems, {"BOSS": [e[0] for e in elems]}, node_sets, entity_sets, spec, info


def entity_nodes(dim, tags):
    out = set()
    for t in tags:
        nt, _, _ = gmsh.model.mesh.getNodes(dim, t, includeBoundary=True)
        out.update(int(x) for x in nt)
    return sorted(out)


# ----------------------------------------------------------------------------------------------
# output
# ----------------------------------------------------------------------------------------------

def fmt(x):
    s = "%.10g" % x
    return "0" if s == "-0" else s


def id_lines(ids):
    return [", ".join(str(i) for i in ids[k:k + IDS_PER_LINE]) for k in range(0, len(ids), IDS_PER_LINE)]


def write_inp(path, title, nodes, elems, elem_sets, node_sets):
    lines = ["** FeatureExtract reference feature: %s" % title,
             "** shell mesh made by tools/make_features.py with gmsh %s, units mm" % gmsh_version(),
             "** node and element ids are the node and element tags of mesh.msh",
             "*NODE"]
    for n in sorted(nodes):
        x, y, z = nodes[n]
        lines.append("%d, %s, %s, %s" % (n, fmt(x), fmt(y), fmt(z)))
    for ty in (3, 2):
        block = [e for e in elems if e[1] == ty]
        if not block:
            continue
        lines.append("*ELEMENT, TYPE=%s" % SHELL_TYPES[ty][0])
        for et, _, conn, _ in block:
            lines.append("%d, %s" % (et, ", ".join(str(c) for c in conn)))
    for name, ids in elem_sets.items():
        lines.append("*ELSET, ELSET=%s" % name)
        lines.extend(id_lines(sorted(ids)))
    for name, ids in node_sets.items():
        lines.append("*NSET, NSET=%s" % name)
        lines.extend(id_lines(sorted(ids)))
    with open(path, "w", newline="\n") as f:
        f.write("\n".join(lines) + "\n")


def check_mesh(name, nodes, elems, node_sets, entity_sets):
    missing = sorted({c for e in elems for c in e[2] if c not in nodes})
    if missing:
        raise RuntimeError("%s: elements reference %d missing nodes, e.g. %s" % (name, len(missing), missing[:5]))
    used = {c for e in elems for c in e[2]}
    if used != set(nodes):
        raise RuntimeError("%s: %d nodes not used by any shell element" % (name, len(set(nodes) - used)))
    for e in elems:
        if len(set(e[2])) != len(e[2]):
            raise RuntimeError("%s: degenerate element %d" % (name, e[0]))
    for s, ids in node_sets.items():
        if not ids:
            raise RuntimeError("%s: node set %s is empty" % (name, s))
        if s in entity_sets and sorted(entity_sets[s]) != sorted(ids):
            raise RuntimeError("%s: node set %s (%d nodes) differs from its physical group's nodes (%d)"
                               % (name, s, len(ids), len(entity_sets[s])))
    # free (boundary) edges of the shell: the mesh must be conforming, free edges only at the root
    count = defaultdict(int)
    for e in elems:
        c = e[2]
        for a, b in zip(c, c[1:] + c[:1]):
            count[(min(a, b), max(a, b))] += 1
    free = [k for k, v in count.items() if v == 1]
    over = [k for k, v in count.items() if v > 2]
    free_z = max((max(nodes[a][2], nodes[b][2]) for a, b in free), default=0.0)
    if over:
        raise RuntimeError("%s: %d non-manifold edges" % (name, len(over)))
    if free_z > 0.01:
        raise RuntimeError("%s: free mesh edges above the root (z up to %.3f): mesh not conforming" % (name, free_z))
    return len(free)


def quality(nodes, elems):
    """Smallest and largest corner angle (degrees) and worst warp (out of plane angle of a
    quad's two triangles, degrees) over all elements."""
    amin, amax, warp = 180.0, 0.0, 0.0
    for _, _, c, _ in elems:
        p = [np.array(nodes[n]) for n in c]
        k = len(p)
        for i in range(k):
            u = p[(i + 1) % k] - p[i]
            v = p[i - 1] - p[i]
            a = math.degrees(math.acos(max(-1.0, min(1.0, u.dot(v) / (np.linalg.norm(u) * np.linalg.norm(v))))))
            amin, amax = min(amin, a), max(amax, a)
        if k == 4:
            n1 = np.cross(p[1] - p[0], p[2] - p[0])
            n2 = np.cross(p[2] - p[0], p[3] - p[0])
            cw = n1.dot(n2) / (np.linalg.norm(n1) * np.linalg.norm(n2))
            warp = max(warp, math.degrees(math.acos(max(-1.0, min(1.0, cw)))))
    return amin, amax, warp


def max_quad_aspect(nodes, elems):
    worst = 1.0
    for _, ty, c, _ in elems:
        p = [np.array(nodes[n]) for n in c]
        L = [np.linalg.norm(p[(i + 1) % len(p)] - p[i]) for i in range(len(p))]
        worst = max(worst, max(L) / min(L))
    return worst


def build(name, builder, step, out_dir):
    gmsh.clear()
    nodes, elems, elem_sets, node_sets, entity_sets, spec, info = builder(step)
    nfree = check_mesh(name, nodes, elems, node_sets, entity_sets)
    amin, amax, warp = quality(nodes, elems)

    d = os.path.join(out_dir, name)
    os.makedirs(d, exist_ok=True)
    shutil.copyfile(step, os.path.join(d, "geometry.step"))
    gmsh.write(os.path.join(d, "mesh.msh"))
    write_inp(os.path.join(d, "mesh.inp"), spec["name"], nodes, elems, elem_sets, node_sets)
    nq = sum(1 for e in elems if e[1] == 3)
    nt = sum(1 for e in elems if e[1] == 2)
    spec["counts"] = {"nodes": len(nodes), "elements": len(elems), "S4": nq, "S3": nt,
                      "node_sets": {k: len(v) for k, v in node_sets.items()},
                      "element_sets": {k: len(v) for k, v in elem_sets.items()}}
    spec["made_by"] = "tools/make_features.py with gmsh %s" % gmsh_version()
    with open(os.path.join(d, "feature.json"), "w", newline="\n") as f:
        json.dump(spec, f, indent=2)
        f.write("\n")

    print("%s -> %s" % (name, d))
    print("  nodes %d, elements %d (quads %d, tris %d), free edges %d (all at z<=0.01)"
          % (len(nodes), len(elems), nq, nt, nfree))
    print("  quality: corner angles %.1f..%.1f deg, max quad warp %.1f deg, max edge-length ratio %.2f"
          % (amin, amax, warp, max_quad_aspect(nodes, elems)))
    if info.get("flipped_surfaces"):
        print("  reversed surfaces for consistent normals (+z at the top): %s" % info["flipped_surfaces"])
    for k, v in elem_sets.items():
        print("  element set %-10s %d" % (k, len(v)))
    for k, v in node_sets.items():
        print("  node set    %-10s %d" % (k, len(v)))
    if "circles" in info:
        report_circles(nodes, info)


def report_circles(nodes, info):
    """Check that every circular edge around the axis has exactly 12 nodes at 30 degree steps."""
    cx, cy = info["axis"]
    rings = {}
    for t, (rad, z, _) in info["circles"].items():
        rings.setdefault((round(rad, 6), round(z, 6)), []).append(t)
    for (rad, z) in sorted(rings, key=lambda k: (k[1], k[0])):
        ids = set()
        for t in rings[(rad, z)]:
            nt, _, _ = gmsh.model.mesh.getNodes(1, t, includeBoundary=True)
            ids.update(int(x) for x in nt)
        ang = sorted(round(math.degrees(math.atan2(nodes[n][1] - cy, nodes[n][0] - cx)) % 360.0, 6) % 360.0
                     for n in ids)
        steps = np.diff(ang + [ang[0] + 360.0])
        ok = len(ang) == 12 and np.allclose(steps, 30.0, atol=1e-6)
        print("  circle r=%g z=%g: %d nodes, angles %s deg %s"
              % (rad, z, len(ang), " ".join("%g" % a for a in ang), "OK" if ok else "NOT 30-degree steps"))
        if not ok:
            raise RuntimeError("boss: circle r=%g z=%g does not have 12 nodes at 30 degree steps" % (rad, z))
    # every node (but the disk centre) lies on a 30-degree meridian (polar grid everywhere)
    off = 0
    for n, (x, y, z) in nodes.items():
        r = math.hypot(x - cx, y - cy)
        if r > 1e-6:
            a = math.degrees(math.atan2(y - cy, x - cx)) % 30.0
            if min(a, 30.0 - a) > 1e-6:
                off += 1
    print("  nodes not on a 30-degree meridian (centre excluded): %d" % off)
    if off:
        raise RuntimeError("boss: %d nodes off the 30-degree meridians" % off)


def main(argv):
    if len(argv) != 3:
        sys.exit(__doc__)
    models_dir, out_dir = argv[1], argv[2]
    suite = os.path.join(models_dir, "suite")
    steps = {"rib": os.path.join(suite, "rib_reference.step"),
             "boss": os.path.join(suite, "boss_reference.step")}
    for p in steps.values():
        if not os.path.isfile(p):
            sys.exit("make_features.py: %s is missing (run build/fe_make_models %s --suite)" % (p, models_dir))
    gmsh.initialize([], readConfigFiles=False)
    try:
        set_common_options()
        print("gmsh %s, writing msh %.1f ASCII" % (gmsh_version(), MSH_VERSION))
        build("rib", build_rib, steps["rib"], out_dir)
        build("boss", build_boss, steps["boss"], out_dir)
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main(sys.argv)
