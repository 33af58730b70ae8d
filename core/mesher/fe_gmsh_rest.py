#!/usr/bin/python3
"""Meshes the faces of a part that no feature instance covers, joined to the instances' patches (issue 12).

Run by `featureextract mesh-part` as a separate program (gmsh is GPL, the core LGPL-2.1: the core never
links gmsh, as FreeCAD's FEM workbench runs gmsh as a program of its own):

    /usr/bin/python3 fe_gmsh_rest.py JOB.json OUT.json

JOB.json (written by the core):
    {"part": "part.step", "faces": 139, "size": 2.0, "patches": [
        {"faces": [2, 3, ...],            # 1-based FaceN the patch covers (FreeCAD / TopExp order)
         "tolerance": 0.6,                # a node this close to a B-rep vertex / edge / face is put on it
         "nodes": [[key, x, y, z], ...],  # every patch node (key: the core's index)
         "border": [key, ...],            # the patch's border nodes (on its free edges)
         "border_edges": [[key, key], ...],  # its free edges (optional: the border's chain)
         "transition": {"width": W, "size": s}}]}  # optional: the rest's size grows from s to "size"
                                                   # over W around the patch (its border edges)

OUT.json:
    {"nodes": [[tag, x, y, z], ...],      # nodes of the rest (gmsh tags), border nodes excluded
     "triangles": [[face, t1, t2, t3], ...],
     "joined": [[tag, key], ...]          # a rest node that is a patch node
     "moved": [[key, x, y, z], ...],      # patch nodes put onto the B-rep (vertex, edge or face)
     "fixed_face": N, "fixed_nodes": [tag, ...], "fixed_keys": [key, ...],  # suggested support
     "report": {...}}

Two other jobs, for `mesh-part --solid`: {"fill": true, ...} fills the surface with tetrahedra
(fill() below) and {"project": true, ...} puts the quadratic tetrahedra's surface middle nodes onto
their B-rep faces (project() below).

The border curves (B-rep edges between a covered and an uncovered face) take the patches' border
nodes as their 1D mesh, so the surface mesher builds the rest's triangles on exactly those nodes: the
whole mesh is conforming without merging by distance. Deterministic: one thread, fixed options.
Errors: one line on stderr, exit 1 (bad job) or 2 (gmsh failed).
"""

import json
import math
import os
import sys
import time


def fail(code, text):
    sys.stderr.write("fe_gmsh_rest: " + " ".join(str(text).split()) + "\n")
    sys.exit(code)


try:
    import gmsh
except ImportError:
    fail(2, "the gmsh Python module is missing (apt-get install -y --no-install-recommends gmsh python3-gmsh)")


def start_gmsh():
    """gmsh, headless and deterministic: one thread everywhere, a fixed seed, no user config files."""
    gmsh.initialize(["fe_gmsh_rest", "-nopopup"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.NumThreads", 1)
    for d in ("1D", "2D", "3D"):
        gmsh.option.setNumber("Mesh.MaxNumThreads" + d, 1)
    gmsh.option.setNumber("Mesh.RandomSeed", 1)


def bbox_distance(box, p):
    """Distance from p to an axis-aligned box (x0, y0, z0, x1, y1, z1); 0 inside."""
    d2 = 0.0
    for k in range(3):
        lo, hi = box[k], box[k + 3]
        if p[k] < lo:
            d2 += (lo - p[k]) ** 2
        elif p[k] > hi:
            d2 += (p[k] - hi) ** 2
    return math.sqrt(d2)


def log(text):
    if VERBOSE:
        sys.stderr.write(f"fe_gmsh_rest: {text}\n")
        sys.stderr.flush()


VERBOSE = False


def dist(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


def face_boundary(s):
    """The curves bounding face s (unsigned tags)."""
    return [abs(c) for _, c in gmsh.model.getBoundary([(2, s)], combined=False, oriented=False)]


def closest_on_face(s, q, curves, curve_boxes):
    """(point, distance): the closest point of face s to q, or None where gmsh has none. The closest
    point of a face is inside it or on its boundary curves; gmsh 4.8 can return a wrong local point on
    a trimmed surface (a boss's root fillet: 1.6 mm round the root circle, so the root nodes failed
    their ring angles), while a curve's closest point is exact: a boundary point nearer than gmsh's
    answer replaces it. `curves`: the face's boundary curves, `curve_boxes`: their bounding boxes."""
    try:
        cp, _ = gmsh.model.getClosestPoint(2, s, list(q))
    except Exception:
        return None
    d = dist(cp, q)
    for c in curves:
        if bbox_distance(curve_boxes[c], q) >= d:
            continue
        try:
            cc, _ = gmsh.model.getClosestPoint(1, c, list(q))
        except Exception:  # a degenerate edge (a cone's apex) has no curve
            continue
        if dist(cc, q) < d:
            cp, d = cc, dist(cc, q)
    return cp, d


def project(job):
    """Points onto B-rep faces: {"project": true, "part": PATH, "points": [[x, y, z, face], ...]} ->
    {"points": [[x, y, z] or null, ...]}: each point's closest point on its face (FaceN, the core's
    numbering), null where the face is not read or has no closest point."""
    t0 = time.time()
    try:
        part = job["part"]
        pts = [(float(p[0]), float(p[1]), float(p[2]), int(p[3])) for p in job["points"]]
    except (KeyError, TypeError, ValueError, IndexError) as e:
        fail(1, f"{sys.argv[1]}: not a projection job: {e}")
    start_gmsh()
    try:
        try:
            gmsh.model.occ.importShapes(part)
            gmsh.model.occ.synchronize()
        except Exception as e:
            fail(2, f"{part}: gmsh cannot read it: {e}")
        surfaces = {t for _, t in gmsh.model.getEntities(2)}
        curves, curve_boxes, out = {}, {}, []
        for x, y, z, f in pts:
            if f not in surfaces:
                out.append(None)
                continue
            if f not in curves:
                curves[f] = face_boundary(f)
                for c in curves[f]:
                    if c not in curve_boxes:
                        curve_boxes[c] = gmsh.model.getBoundingBox(1, c)
            found = closest_on_face(f, (x, y, z), curves[f], curve_boxes)
            out.append(None if found is None else [float(v) for v in found[0]])
        with open(sys.argv[2], "w") as fo:
            json.dump({"points": out, "report": {"points": len(out), "placed": sum(p is not None for p in out),
                                                 "seconds": round(time.time() - t0, 3)}}, fo)
    finally:
        gmsh.finalize()


def main():
    global VERBOSE
    VERBOSE = bool(os.environ.get("FE_DEBUG"))
    if len(sys.argv) != 3:
        fail(1, "usage: fe_gmsh_rest.py JOB.json OUT.json")
    try:
        with open(sys.argv[1]) as f:
            job = json.load(f)
        if isinstance(job, dict) and job.get("fill"):
            return fill(job)
        if isinstance(job, dict) and job.get("project"):
            return project(job)
        part, size = job["part"], float(job["size"])
        patches = job["patches"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        fail(1, f"{sys.argv[1]}: not a mesh job: {e}")
    if not (size > 0 and math.isfinite(size)):
        fail(1, f"{sys.argv[1]}: size must be > 0, got {size}")
    t0 = time.time()
    start_gmsh()
    try:
        try:
            gmsh.model.occ.importShapes(part)
            gmsh.model.occ.synchronize()
        except Exception as e:  # gmsh raises a bare Exception with its last error
            fail(2, f"{part}: gmsh cannot read it: {e}")
        surfaces = [t for _, t in gmsh.model.getEntities(2)]
        # gmsh numbers the faces as FreeCAD and the core do (TopExp order), but may read fewer (NIST
        # CTC-02: 663 of 664, the last one): check face by face, where the core sent centroids
        extent = gmsh.model.getBoundingBox(-1, -1)
        diag = math.sqrt(sum((extent[k + 3] - extent[k]) ** 2 for k in range(3)))
        centroids = job.get("face_centroids") or []
        for f, c in enumerate(centroids[:len(surfaces)], 1):
            if c is None:
                continue
            g = gmsh.model.occ.getCenterOfMass(2, f)
            if dist(g, c) > 0.01 * diag:
                fail(2, f"{part}: gmsh's face {f} is not the core's (centroids {dist(g, c):.3g} apart): face numbers do not agree")
        missing = max(0, int(job.get("faces") or 0) - len(surfaces))
        # every patch node onto the nearest of its instance's faces (exact B-rep projection)
        moved = {}     # patch key -> exact position
        not_on_a_face = 0
        on_inner_edges = 0
        for i, p in enumerate(patches):
            tol = float(p["tolerance"])
            snap = 0.1 * tol / 1.5  # a tenth of the patch's median edge
            mine_faces = set(p["faces"])
            face_curves = {s: face_boundary(s)
                           for s in mine_faces if s in surfaces}
            users = {}
            for s, cs in face_curves.items():
                for c in cs:
                    users[c] = users.get(c, 0) + 1
            curve_boxes = {c: gmsh.model.getBoundingBox(1, c) for c in users}

            def inner_curves(s, face_curves=face_curves, users=users):
                return [c for c in face_curves.get(s, []) if users[c] >= 2]
            boxes = {s: gmsh.model.getBoundingBox(2, s) for s in p["faces"] if s in surfaces}
            for n in p["nodes"]:
                key, q = int(n[0]), (float(n[1]), float(n[2]), float(n[3]))
                best = None
                for s, b in boxes.items():
                    if bbox_distance(b, q) > tol:
                        continue
                    found = closest_on_face(s, q, face_curves.get(s, []), curve_boxes)
                    if found is None:
                        continue
                    cp, d = found
                    if best is None or d < best[0]:
                        best = (d, cp, s)
                if best is not None and best[0] <= tol:
                    moved[key] = tuple(best[1])
                    # a node at an edge between two of the patch's faces goes onto that edge (the
                    # feature mesh has nodes on its edges; a node left a hair off the edge is on
                    # neither face, and FreeCAD finds a face's nodes by distance)
                    for c in inner_curves(best[2]):
                        if bbox_distance(curve_boxes[c], best[1]) > snap:
                            continue
                        try:
                            cp, _ = gmsh.model.getClosestPoint(1, c, list(best[1]))
                        except Exception:
                            continue
                        if dist(cp, best[1]) <= snap:
                            moved[key] = tuple(cp)
                            on_inner_edges += 1
                            break
                else:
                    not_on_a_face += 1
        owner = {s: -1 for s in surfaces}  # -1: the rest; i: patch i
        for i, p in enumerate(patches):
            for f in p["faces"]:
                if f not in owner:
                    fail(2, f"{part}: an instance covers face {f}, which gmsh does not read (it reads {len(surfaces)} faces)")
                owner[f] = i
        # plain: the whole part meshed by gmsh, no patch placed (the comparison mesh); the patches still
        # say where the features are (support choice, rigid sets)
        plain = bool(job.get("plain", False))
        feature_owner = dict(owner)
        if plain:
            owner = {s: -1 for s in surfaces}
            for p in patches:
                p["border"] = []
        rest = [s for s in surfaces if owner[s] < 0]

        # curves and who is on each side
        curve_faces = {}
        for s in surfaces:
            for c in face_boundary(s):
                curve_faces.setdefault(c, set()).add(s)
        border = {}  # curve -> patch index (a curve between the rest and a patch)
        for c, fs in curve_faces.items():
            owners = {owner[s] for s in fs}
            if -1 in owners and len(owners) > 1:
                border[c] = max(owners)
        curve_box = {c: gmsh.model.getBoundingBox(1, c) for c in border}
        curve_ends = {}
        for c in border:
            ends = [abs(v) for _, v in gmsh.model.getBoundary([(1, c)], combined=False, oriented=True)]
            curve_ends[c] = ends
        border_vertices = sorted({v for c in border for v in curve_ends[c]})
        vertex_xyz = {v: gmsh.model.getValue(0, v, []) for v in border_vertices}

        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.MeshSizeMin", size / 4)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 12)
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay
        gmsh.option.setNumber("Mesh.MeshOnlyEmpty", 1)
        joined = {}    # gmsh node tag -> patch key
        report = {"border_curves": len(border), "border_vertices": len(border_vertices),
                  "faces_gmsh_does_not_read": missing,
                  "curves_without_patch_nodes": [], "vertices_without_patch_node": [],
                  "border_nodes_not_on_an_edge": 0, "border_nodes_spread": 0, "short_curves_one_segment": 0,
                  "patch_nodes_not_on_a_face": not_on_a_face, "patch_nodes_onto_inner_edges": on_inner_edges}
        plans = []
        tol_of = {}
        for i, p in enumerate(patches):
            tol = float(p["tolerance"])
            # a border node may sit further from its edge than a node from its face (a fit that puts a rib's
            # root line on the fillet): it is still the patch's border, and goes onto the nearest border edge
            btol = float(p.get("border_tolerance", 2 * tol))
            xyz = {int(n[0]): (float(n[1]), float(n[2]), float(n[3])) for n in p["nodes"]}
            # border nodes onto the border vertices and curves of this patch
            mine = [c for c, o in border.items() if o == i]
            on_curve = {c: [] for c in mine}
            vertex_key = {}
            for key in p["border"]:
                q = moved.get(key, xyz[key])
                best = None
                for c in mine:
                    if bbox_distance(curve_box[c], q) > btol:
                        continue
                    try:
                        cp, _ = gmsh.model.getClosestPoint(1, c, list(q))
                    except Exception:  # a degenerate edge (a cone's apex) has no curve
                        continue
                    d = dist(cp, q)
                    if best is None or d < best[0]:
                        best = (d, c, cp)
                if best is None or best[0] > btol:
                    report["border_nodes_not_on_an_edge"] += 1
                    continue
                d, c, cp = best
                # (gmsh 4.8's getClosestPoint returns no parameter on curves: ask for it)
                u = gmsh.model.getParametrization(1, c, list(cp))[0]
                on_curve[c].append((u, key, cp))
            # each vertex of these curves takes a border node of its curves as its node: one node per
            # vertex, nearest pairs first, and only a node where the patch's border chain leaves the curve
            # (its neighbour along the chain is on another curve; a curve too short to hold a node is
            # passed over). Nearest alone, two vertices a short edge apart (CTC-02's lug corner, 1.8 mm)
            # took the same node, or a vertex took the node after the chain's turn, and the rest's
            # border ran in another order than the patch's: free edges.
            curve_of = {key: c for c in mine for _, key, _ in on_curve[c]}
            chain = {}
            for a, b in p.get("border_edges") or []:
                chain.setdefault(int(a), []).append(int(b))
                chain.setdefault(int(b), []).append(int(a))

            def at_turn(key, c):
                return any(curve_of.get(n) != c for n in chain.get(key, []))
            corners = sorted({v for c in mine for v in curve_ends[c]})
            taken = set()
            for strict in (True, False):  # a vertex with no node at a turn takes its nearest free node
                pairs = []
                for v in corners:
                    if v in vertex_key:
                        continue
                    vx = vertex_xyz[v]
                    for c in mine:
                        if v in curve_ends[c]:
                            pairs += [(dist(cp, vx), v, key) for u, key, cp in on_curve[c]
                                      if not strict or at_turn(key, c)]
                for d, v, key in sorted(pairs):
                    if d > btol:
                        break
                    if v in vertex_key or key in taken:
                        continue
                    vertex_key[v] = key
                    taken.add(key)
                    moved[key] = tuple(vertex_xyz[v])
            report["vertices_without_patch_node"] += [v for v in corners if v not in vertex_key]
            for c in mine:
                tol_of[c] = tol
            plans.append((mine, on_curve, vertex_key))
            log(f"patch {i}: {len(xyz)} nodes onto {len(boxes)} faces, {len(p['border'])} border nodes onto {len(mine)} curves")

        # transition zones (a feature's "transition_zone" rule): around such a patch the rest's element
        # size grows linearly from the patch's to the part's over the given width, measured from the
        # patch's border edges
        zones = []
        for i, p in enumerate(patches):
            z = p.get("transition")
            if not z:
                continue
            width, small = float(z["width"]), float(z["size"])
            curves = [c for c, o in border.items() if o == i]
            if not (width > 0 and small > 0 and curves):
                continue
            d = gmsh.model.mesh.field.add("Distance")
            gmsh.model.mesh.field.setNumbers(d, "CurvesList", curves)
            gmsh.model.mesh.field.setNumber(d, "NumPointsPerCurve", 100)
            t = gmsh.model.mesh.field.add("Threshold")
            gmsh.model.mesh.field.setNumber(t, "InField", d)
            for k, v in (("SizeMin", min(small, size)), ("SizeMax", size), ("DistMin", 0.0), ("DistMax", width)):
                gmsh.model.mesh.field.setNumber(t, k, v)
            zones.append(t)
        if zones:
            m = gmsh.model.mesh.field.add("Min")
            gmsh.model.mesh.field.setNumbers(m, "FieldsList", zones)
            gmsh.model.mesh.field.setAsBackgroundMesh(m)
        report["transition_zones"] = len(zones)

        # the covered faces are not meshed: their mesh is the patches' (the model's entities go, the
        # curves they share with the rest stay)
        gmsh.model.removeEntities(gmsh.model.getEntities(3))
        gmsh.model.removeEntities([(2, s) for s in surfaces if owner[s] >= 0])
        gmsh.model.mesh.generate(1)
        log("1D mesh done")

        node_tag = int(max(gmsh.model.mesh.getNodes()[0], default=0))
        elem_tag = [0]  # the last element tag used (a list: one_segment below adds to it)
        _, etags, _ = gmsh.model.mesh.getElements()
        for b in etags:
            if len(b):
                elem_tag[0] = max(elem_tag[0], int(max(b)))
        for mine, on_curve, vertex_key in plans:
            for v, key in vertex_key.items():
                tags, _, _ = gmsh.model.mesh.getNodes(0, v)
                if len(tags):
                    joined[int(tags[0])] = key
            used_by_vertex = set(vertex_key.values())
            def one_segment(c):
                """A border edge shorter than the patch's elements (a short arc end) has no patch node
                between its vertices: if both vertices are the patch's, one segment joins them, as the
                patch does; else gmsh's own mesh stays and the curve is reported."""
                ends = curve_ends[c]
                if len(ends) != 2 or ends[0] == ends[1] or not all(v in vertex_key for v in ends):
                    report["curves_without_patch_nodes"].append(c)
                    return
                elem_tag[0] += 1
                v0 = int(gmsh.model.mesh.getNodes(0, ends[0])[0][0])
                v1 = int(gmsh.model.mesh.getNodes(0, ends[1])[0][0])
                gmsh.model.mesh.clear([(1, c)])
                gmsh.model.mesh.addElements(1, c, [1], [[elem_tag[0]]], [[v0, v1]])
                report["short_curves_one_segment"] += 1

            for c in mine:
                pts = sorted((u, key, cp) for u, key, cp in on_curve[c] if key not in used_by_vertex)
                if not pts:
                    one_segment(c)
                    continue
                # the line elements run from the vertex at the curve's first parameter to the one at its
                # last (a closed curve, a circle, has one vertex at both ends)
                ends = curve_ends[c]
                lo, hi = gmsh.model.getParametrizationBounds(1, c)
                p_lo = gmsh.model.getValue(1, c, [lo[0]])
                if len(ends) > 1 and dist(vertex_xyz[ends[0]], p_lo) > dist(vertex_xyz[ends[-1]], p_lo):
                    ends = [ends[-1], ends[0]]
                # one node per key, in order along the curve, none on top of a vertex or of the node
                # before it (gmsh stops on a zero-length segment). A node that lands on top of another
                # (a fit that puts the patch's border a little off the edge folds its nodes together
                # there) is not dropped, which left a hole: a run of crowded nodes is spread evenly
                # between its free neighbours along the curve.
                gap = 0.1 * tol_of[c]
                ends_xyz = [vertex_xyz[v] for v in curve_ends[c]]
                seen, uniq = set(), []
                for u, key, cp in pts:
                    if key not in seen:
                        seen.add(key)
                        uniq.append([u, key, cp])
                crowded = [any(dist(cp, e) < gap for e in ends_xyz) or (k and dist(cp, uniq[k - 1][2]) < gap)
                           for k, (u, key, cp) in enumerate(uniq)]
                k = 0
                while k < len(uniq):
                    if not crowded[k]:
                        k += 1
                        continue
                    b = k
                    while b < len(uniq) and crowded[b]:
                        b += 1
                    # between the free neighbours that stay (or the curve's ends), evenly
                    u_a = uniq[k - 1][0] if k > 0 else lo[0]
                    u_b = uniq[b][0] if b < len(uniq) else hi[0]
                    for j in range(k, b):
                        u = u_a + (u_b - u_a) * (j - k + 1) / (b - k + 1)
                        uniq[j][0], uniq[j][2] = u, tuple(gmsh.model.getValue(1, c, [u]))
                    report["border_nodes_spread"] += b - k
                    k = b
                uniq = [tuple(x) for x in uniq]
                v0 = gmsh.model.mesh.getNodes(0, ends[0])[0]
                v1 = gmsh.model.mesh.getNodes(0, ends[-1])[0]
                gmsh.model.mesh.clear([(1, c)])
                tags = list(range(node_tag + 1, node_tag + 1 + len(uniq)))
                node_tag += len(uniq)
                gmsh.model.mesh.addNodes(1, c, tags, [x for _, _, cp in uniq for x in cp], [u for u, _, _ in uniq])
                for t, (_, key, cp) in zip(tags, uniq):
                    joined[t] = key
                    moved[key] = tuple(cp)
                seq = [int(v0[0])] + tags + [int(v1[0])]
                conn = []
                for a, b in zip(seq[:-1], seq[1:]):
                    conn += [a, b]
                etg = list(range(elem_tag[0] + 1, elem_tag[0] + len(seq)))
                elem_tag[0] += len(seq) - 1
                gmsh.model.mesh.addElements(1, c, [1], [etg], [conn])
                log(f"curve {c}: ends {ends} u [{lo[0]:.3g}, {hi[0]:.3g}] nodes at u " + " ".join(f"{u:.3g}" for u, _, _ in uniq))

        t_mesh = time.time()
        try:
            gmsh.model.mesh.generate(2)
            log("2D mesh done")
        except Exception as e:
            fail(2, f"{part}: gmsh failed to mesh the rest of the part: {e}")
        # gmsh renumbers nodes after meshing: find the joined nodes again by entity and position
        joined_after = {}
        pos_key = {key: moved.get(key) for key in joined.values()}
        def near_key(entity_dim, entity_tag, by_pos):
            tags, coords, _ = gmsh.model.mesh.getNodes(entity_dim, entity_tag)
            out = {}
            for j, t in enumerate(tags):
                q = coords[3 * j:3 * j + 3]
                k = by_pos.get(tuple(round(x, 9) for x in q))
                if k is not None:
                    out[int(t)] = k
            return out
        by_pos = {tuple(round(x, 9) for x in pos): key for key, pos in pos_key.items() if pos is not None}
        for c in border:
            joined_after.update(near_key(1, c, by_pos))
        for v in border_vertices:
            joined_after.update(near_key(0, v, by_pos))

        nodes, tris = {}, []
        for s in rest:
            types, _, conns = gmsh.model.mesh.getElements(2, s)
            for et, conn in zip(types, conns):
                if et != 2:
                    fail(2, f"{part}: gmsh made elements of type {et} on face {s}")
                for j in range(0, len(conn), 3):
                    tri = [int(conn[j]), int(conn[j + 1]), int(conn[j + 2])]
                    tris.append([s] + tri)
                    for t in tri:
                        nodes[t] = None
        for t in list(nodes):
            x = gmsh.model.mesh.getNode(t)[0]
            nodes[t] = [float(v) for v in x]

        fixed_face, fixed_nodes, fixed_keys = fixed_face_and_nodes(
            [s for s in surfaces if feature_owner[s] < 0], feature_owner, curve_faces, joined_after)
        # plain mesh: a rigid set is the nodes of the face most of the patch's set lies on
        rigid_faces, rigid_nodes = {}, {}
        for p in (patches if plain else []):
            for name, keys in p.get("rigid", {}).items():
                votes = {}
                for k in keys:
                    q = moved.get(k)
                    if q is None:
                        continue
                    for f in p["faces"]:
                        try:
                            cp, _ = gmsh.model.getClosestPoint(2, f, list(q))
                        except Exception:
                            continue
                        if dist(cp, q) <= 1e-6 * max(1.0, size):
                            votes[f] = votes.get(f, 0) + 1
                if votes:
                    face = max(votes, key=lambda f: (votes[f], -f))
                    rigid_faces[name] = face
                    tags, _, _ = gmsh.model.mesh.getNodes(2, face, includeBoundary=True)
                    rigid_nodes[name] = sorted({int(t) for t in tags})
        out = {
            "nodes": [[t] + nodes[t] for t in sorted(nodes) if t not in joined_after],
            "triangles": tris,
            "joined": sorted([t, k] for t, k in joined_after.items()),
            "moved": [] if plain else sorted([k] + list(p) for k, p in moved.items()),
            "fixed_face": fixed_face,
            "fixed_nodes": fixed_nodes,
            "fixed_keys": [] if plain else fixed_keys,
            "rigid_faces": rigid_faces,
            "rigid_nodes": rigid_nodes,
            "report": dict(report, rest_faces=len(rest), rest_nodes=len(nodes), rest_triangles=len(tris),
                           seconds=round(time.time() - t0, 3), mesh_seconds=round(time.time() - t_mesh, 3),
                           gmsh=gmsh.__version__),
        }
        with open(sys.argv[2], "w") as f:
            json.dump(out, f)
    finally:
        gmsh.finalize()


def fill(job):
    """Tetrahedra inside a closed triangle surface: {"fill": true, "nodes": [[id, x, y, z], ...],
    "triangles": [[id, id, id], ...], "size": S} -> {"nodes": [[tag, x, y, z], ...] (the new, inner
    ones), "tets": [[n1, n2, n3, n4], ...] (surface nodes by their ids, inner ones by tag)}. The surface
    mesh is kept as it is: the tetrahedra's faces on the surface are its triangles."""
    t0 = time.time()
    try:
        ids = [int(n[0]) for n in job["nodes"]]
        xyz = [float(c) for n in job["nodes"] for c in n[1:4]]
        tris = [int(v) for t in job["triangles"] for v in t]
        size = float(job["size"])
    except (KeyError, TypeError, ValueError, IndexError) as e:
        fail(1, f"{sys.argv[1]}: not a fill job: {e}")
    start_gmsh()
    try:
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.add("fill")
        surf = gmsh.model.addDiscreteEntity(2)
        gmsh.model.mesh.addNodes(2, surf, ids, xyz)
        gmsh.model.mesh.addElements(2, surf, [2], [list(range(1, len(tris) // 3 + 1))], [tris])
        loop = gmsh.model.geo.addSurfaceLoop([surf])
        gmsh.model.geo.addVolume([loop])
        gmsh.model.geo.synchronize()
        try:
            gmsh.model.mesh.generate(3)
        except Exception as e:
            fail(2, f"gmsh could not fill the part with tetrahedra: {e}")
        key = {tuple(xyz[3 * i:3 * i + 3]): ids[i] for i in range(len(ids))}
        tags, coords, _ = gmsh.model.mesh.getNodes()
        name, inner = {}, []
        for j, t in enumerate(tags):
            q = tuple(float(c) for c in coords[3 * j:3 * j + 3])
            if q in key:
                name[int(t)] = key[q]
            else:
                name[int(t)] = -int(t)  # inner node: negative until numbered by the core
                inner.append([int(t)] + list(q))
        tets = []
        for _, v in gmsh.model.getEntities(3):
            types, _, conns = gmsh.model.mesh.getElements(3, v)
            for et, conn in zip(types, conns):
                if et != 4:
                    fail(2, f"gmsh made elements of type {et} inside the part")
                tets += [[name[int(conn[k])] for k in range(j, j + 4)] for j in range(0, len(conn), 4)]
        if not tets:
            fail(2, "gmsh made no tetrahedra: the surface is not closed")
        with open(sys.argv[2], "w") as f:
            json.dump({"nodes": inner, "tets": tets,
                       "report": {"tets": len(tets), "inner_nodes": len(inner), "seconds": round(time.time() - t0, 3)}}, f)
    finally:
        gmsh.finalize()


def fixed_face_and_nodes(rest, owner, curve_faces, joined):
    """The largest face of the rest with no covered neighbour (the plate's underside, not its top that
    carries the features) is the suggested support; its nodes: gmsh tags, and keys of joined nodes."""
    if not rest:
        return 0, [], []
    neighbours = {s: set() for s in rest}
    for c, fs in curve_faces.items():
        for s in fs:
            if s in neighbours:
                neighbours[s] |= fs - {s}
    area = {s: gmsh.model.occ.getMass(2, s) for s in rest}
    free = [s for s in rest if all(owner[n] < 0 for n in neighbours[s])]
    pick = max(free or rest, key=lambda s: (area[s], -s))
    tags, _, _ = gmsh.model.mesh.getNodes(2, pick, includeBoundary=True)
    tags = [int(t) for t in tags]
    return pick, sorted({t for t in tags if t not in joined}), sorted({joined[t] for t in tags if t in joined})


if __name__ == "__main__":
    main()
