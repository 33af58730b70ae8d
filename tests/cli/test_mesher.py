"""The mesher of mesh-part, core/mesher/fe_gmsh_rest.py, alone (issue 12): a patch on the top face of a
box whose border nodes lie on the face's edges and corners; the rest of the box must be meshed on
exactly those nodes. Bad jobs: one line, exit 1 (the job) or 2 (the part). The box is made here by
gmsh itself. Usage: test_mesher.py FE_GMSH_REST.py"""
import json
import os
import subprocess
import sys
import tempfile
import unittest

MESHER = sys.argv[1]


def box(path):
    code = f"""
import gmsh
gmsh.initialize(); gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.occ.addBox(0, 0, 0, 10, 10, 10); gmsh.model.occ.synchronize()
top = [t for _, t in gmsh.model.getEntities(2) if abs(gmsh.model.occ.getCenterOfMass(2, t)[2] - 10) < 1e-9]
gmsh.write({path!r}); print(top[0]); gmsh.finalize()
"""
    return int(subprocess.run(["/usr/bin/python3", "-c", code], capture_output=True, text=True, check=True).stdout)


class Mesher(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="fe_mesher_")
        cls.part = os.path.join(cls.dir, "box.brep")
        cls.top = box(cls.part)

    def run_job(self, job):
        jp, op = os.path.join(self.dir, "job.json"), os.path.join(self.dir, "out.json")
        with open(jp, "w") as f:
            json.dump(job, f)
        if os.path.exists(op):
            os.remove(op)
        r = subprocess.run(["/usr/bin/python3", MESHER, jp, op], capture_output=True, text=True, timeout=300)
        if r.returncode != 0:
            return r, None
        with open(op) as f:
            return r, json.load(f)

    def grid_patch(self, n=5):
        # n x n nodes on the top face z = 10, slightly off it (the mesher puts them on); perimeter = border
        nodes, border = [], []
        for j in range(n):
            for i in range(n):
                k = j * n + i
                nodes.append([k, 10 * i / (n - 1), 10 * j / (n - 1), 10.02])
                if i in (0, n - 1) or j in (0, n - 1):
                    border.append(k)
        return {"faces": [self.top], "tolerance": 1.0, "nodes": nodes, "border": border}

    def test_the_rest_is_built_on_the_patch_border(self):
        p = self.grid_patch()
        r, out = self.run_job({"part": self.part, "faces": 6, "size": 2.0, "patches": [p]})
        self.assertEqual(r.returncode, 0, r.stderr)
        joined = {t: k for t, k in out["joined"]}
        self.assertEqual(sorted(joined.values()), sorted(p["border"]))  # all 16 border nodes, corners included
        used = {v for tri in out["triangles"] for v in tri[1:]}
        self.assertTrue(set(joined) <= used, "every joined node is used by the rest's triangles")
        self.assertEqual(len(out["moved"]), 25)
        for k, x, y, z in out["moved"]:
            self.assertAlmostEqual(z, 10.0, places=9)  # onto the B-rep face
        self.assertEqual({tri[0] for tri in out["triangles"]} & {self.top}, set(), "the top face is the patch's")
        self.assertEqual(len({tri[0] for tri in out["triangles"]}), 5)
        self.assertEqual(out["report"]["border_nodes_not_on_an_edge"], 0)
        self.assertEqual(out["report"]["vertices_without_patch_node"], [])
        # the support: a face of the rest (every side touches the top: the largest one is taken)
        self.assertIn(out["fixed_face"], {tri[0] for tri in out["triangles"]})

    def test_border_nodes_that_land_on_top_of_each_other_are_spread_not_dropped(self):
        # a fit that puts the patch's border off the edge folds its nodes together there: on the edge
        # y = 0 the second and third nodes land 0.01 apart (both within the tolerance of the edge)
        p = self.grid_patch()
        p["nodes"][1][1:3] = [2.5, 0.0]
        p["nodes"][2][1:3] = [2.51, 0.3]
        r, out = self.run_job({"part": self.part, "faces": 6, "size": 2.0, "patches": [p]})
        self.assertEqual(r.returncode, 0, r.stderr)
        joined = {t: k for t, k in out["joined"]}
        self.assertEqual(sorted(joined.values()), sorted(p["border"]))  # none left out: no hole
        self.assertGreaterEqual(out["report"]["border_nodes_spread"], 1)
        moved = {k: (x, y, z) for k, x, y, z in out["moved"]}
        xs = sorted(moved[k][0] for k in (0, 1, 2, 3, 4))
        self.assertEqual(sorted(moved[k][1] for k in (0, 1, 2, 3, 4)), [0.0] * 5)  # on the edge y = 0, z = 10
        self.assertGreater(min(b - a for a, b in zip(xs, xs[1:])), 1.0)  # and apart along it, in order
        used = {v for tri in out["triangles"] for v in tri[1:]}
        self.assertTrue(set(joined) <= used)

    def test_a_plain_job_meshes_every_face(self):
        r, out = self.run_job({"part": self.part, "faces": 6, "size": 2.0, "plain": True,
                               "patches": [dict(self.grid_patch(), rigid={"TOP": [12]})]})
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(out["joined"], [])
        self.assertEqual(len({tri[0] for tri in out["triangles"]}), 6)
        self.assertEqual(out["rigid_faces"], {"TOP": self.top})
        self.assertGreater(len(out["rigid_nodes"]["TOP"]), 9)

    def test_a_projection_job_puts_points_onto_their_b_rep_face(self):
        # the 10-node tetrahedra's surface middles: from the triangulation's chord onto the exact face
        cyl = os.path.join(self.dir, "cylinder.brep")
        code = f"""
import gmsh
gmsh.initialize(); gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.occ.addCylinder(0, 0, 0, 0, 0, 10, 5); gmsh.model.occ.synchronize()
side = [t for _, t in gmsh.model.getEntities(2) if gmsh.model.getType(2, t) == "Cylinder"]
gmsh.write({cyl!r}); print(side[0]); gmsh.finalize()
"""
        side = int(subprocess.run(["/usr/bin/python3", "-c", code], capture_output=True, text=True, check=True).stdout)
        import math
        pts = [[4.95 * math.cos(a), 4.95 * math.sin(a), 1 + a, side] for a in (0.3, 1.7, 4.0)]  # inside the chord
        r, out = self.run_job({"project": True, "part": cyl, "points": pts + [[5, 0, 5, 999]]})
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(len(out["points"]), 4)
        for p, q in zip(pts, out["points"]):
            self.assertAlmostEqual(math.hypot(q[0], q[1]), 5.0, places=7)
            self.assertAlmostEqual(math.atan2(q[1], q[0]), math.atan2(p[1], p[0]), places=7)
            self.assertAlmostEqual(q[2], p[2], places=7)
        self.assertIsNone(out["points"][3])  # no such face: left to the caller
        self.assertEqual(out["report"]["placed"], 3)
        r, _ = self.run_job({"project": True, "part": cyl, "points": [[1, 2]]})
        self.assertEqual(r.returncode, 1)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
        self.assertIn("not a projection job", r.stderr)

    def test_bad_jobs_are_one_line(self):
        cases = [({"faces": 6, "size": 2.0, "patches": []}, 1, "not a mesh job"),
                 ({"part": self.part, "faces": 6, "size": -1, "patches": []}, 1, "size must be > 0"),
                 ({"part": os.path.join(self.dir, "missing.step"), "faces": 6, "size": 2.0, "patches": []}, 2, "missing.step"),
                 ({"part": self.part, "faces": 7, "size": 2.0, "patches": [dict(self.grid_patch(), faces=[7])]}, 2,
                  "does not read"),
                 ({"part": self.part, "faces": 6, "size": 2.0, "patches": [],
                   "face_centroids": [[50, 50, 50]] * 6}, 2, "face numbers do not agree")]
        for job, code, fragment in cases:
            r, _ = self.run_job(job)
            self.assertEqual(r.returncode, code, (job, r.stderr))
            lines = r.stderr.strip().splitlines()
            self.assertEqual(len(lines), 1, r.stderr)
            self.assertIn(fragment, lines[0])


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0], "-v"])
