"""The featureextract command-line contract (issue 2): exit codes, one-line errors naming the file,
progress on stderr, and the result JSON. Usage: test_cli.py FEATUREEXTRACT MODELS_DIR"""
import json
import os
import subprocess
import sys
import tempfile
import unittest

EXE, MODELS = sys.argv[1], sys.argv[2]
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BAD = os.path.join(os.path.dirname(ROOT), "shared", "data", "bad-input")  # files that crashed or hung earlier builds
REF = os.path.join(MODELS, "rib_reference.step")
TGT = os.path.join(MODELS, "ribs_bosses.step")


def run(*args):
    return subprocess.run([EXE, *args], capture_output=True, text=True, timeout=600)


def no_nan(x):
    raise ValueError("non-finite number in JSON: " + x)


class Cli(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp()
        self.out = os.path.join(self.dir, "out.json")

    def write(self, name, data):
        p = os.path.join(self.dir, name)
        with open(p, "wb") as f:
            f.write(data)
        return p

    def assert_input_error(self, r, path):
        self.assertEqual(r.returncode, 3, r.stderr)
        # the error is the last line of stderr (progress lines may come before it), and one line
        errors = [l for l in r.stderr.strip().splitlines() if "%" not in l]
        self.assertEqual(len(errors), 1, r.stderr)
        self.assertIn(path, errors[0])
        self.assertFalse(os.path.exists(self.out), "no output on failure")

    def test_help_documents_every_parameter(self):
        r = run("extract", "--help")
        self.assertEqual(r.returncode, 0)
        for name in ["seed", "dense_spacing", "shot_radii", "scale_max", "pair_distance", "cluster_tolerance",
                     "ransac_patience", "volume_ratio_max", "max_anisotropy", "face_coverage"]:
            self.assertIn(name, r.stdout)
        self.assertIn("default", r.stdout)
        self.assertIn("Exit codes", r.stdout)

    def test_usage_errors_exit_2(self):
        self.assertEqual(run().returncode, 2)
        self.assertEqual(run("extract", "--reference", REF, "--output", self.out).returncode, 2)
        r = run("extract", "-r", REF, "-t", TGT, "-o", self.out, "--set", "no_such_parameter=1")
        self.assertEqual(r.returncode, 2)
        self.assertIn("no_such_parameter", r.stderr)
        cfg = self.write("bad.json", b"{\"si_band\": 5}")
        r = run("extract", "-r", REF, "-t", TGT, "-o", self.out, "--config", cfg)
        self.assertEqual(r.returncode, 2)
        self.assertIn("si_band", r.stderr)

    def test_bad_input_exits_3_with_one_line(self):
        missing = os.path.join(self.dir, "nope.step")
        self.assert_input_error(run("extract", "-r", REF, "-t", missing, "-o", self.out), missing)
        garbage = self.write("garbage.step", bytes((i * 7919) % 251 for i in range(20000)))
        self.assert_input_error(run("extract", "-r", REF, "-t", garbage, "-o", self.out), garbage)
        empty = self.write("empty.stl", b"")
        self.assert_input_error(run("extract", "-r", empty, "-t", TGT, "-o", self.out), empty)
        nan = self.write("nan.stl", b"solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 nan\nvertex 0 1 0\n"
                                    b"endloop\nendfacet\nendsolid a\n")
        self.assert_input_error(run("extract", "-r", nan, "-t", TGT, "-o", self.out), nan)
        flat = os.path.join(MODELS, "flat_reference.step")
        r = run("extract", "-r", flat, "-t", TGT, "-o", self.out)
        self.assert_input_error(r, flat)
        self.assertIn("no distinctive key points", r.stderr)
        r = run("extract", "-r", TGT, "-t", REF, "-o", self.out)
        self.assert_input_error(r, TGT)
        self.assertIn("larger than the target", r.stderr)

    def test_bad_input_files_never_crash_or_hang(self):
        """../shared/data/bad-input (see its README): each crashed (SIGSEGV in OpenCASCADE), hung or ran
        for a minute. Each must now end within the reading bound with exit 3 and one line naming it."""
        small = os.path.join(BAD, "small_reference.stl")
        for name, role in [("step_unknown_entity_FOO.step", "reference"), ("step_dangling_ref.step", "reference"),
                           ("brep_segv.brep", "target"), ("stl_bin_one_coord_1e12.stl", "target"),
                           ("brep_edge_token_1e.brep", "target"), ("obj_polygon_199_hang.obj", "target"),
                           ("ply_bin_type_uint_slow_48s.ply", "target"), ("brep_truncated_line438_hang.brep", "target")]:
            with self.subTest(name):
                bad = os.path.join(BAD, name)
                ref, tgt = (bad, small) if role == "reference" else (small, bad)
                r = subprocess.run([EXE, "extract", "-q", "-r", ref, "-t", tgt, "-o", self.out], capture_output=True,
                                   text=True, timeout=120)  # a hang guard, not a speed goal
                self.assert_input_error(r, bad)
        rib = os.path.join(ROOT, "Resources", "library", "rib", "geometry.step")
        for name, why in [("feature_name_number", '"name" must be a string'), ("feature_geometry_name_300chars", "File name too long")]:
            with self.subTest(name):
                out_dir = os.path.join(self.dir, name)
                r = run("mesh", "-q", "--feature", os.path.join(BAD, name), "-t", rib, "-o", out_dir)
                self.assertEqual(r.returncode, 3, r.stderr)
                self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
                self.assertIn(os.path.join(BAD, name, "feature.json"), r.stderr)
                self.assertIn(why, r.stderr)

    def test_a_malformed_meshing_rule_is_a_one_line_error(self):
        """The mesh steps read a feature's rules and axis as numbers: a rule that is not what they
        expect is named with feature.json when the folder is read, for `mesh` and `mesh-part` alike,
        not an exception from inside the transfer (a non-string "rule" used to end in an internal error)."""
        import json
        import shutil
        boss = os.path.join(ROOT, "Resources", "library", "boss")
        good = json.load(open(os.path.join(boss, "feature.json")))
        rib = os.path.join(ROOT, "Resources", "library", "rib", "geometry.step")
        cases = [("rule_not_a_string", lambda j: j["rules"].append({"rule": 5}), '"rules"[3] must be an object with a string "rule"'),
                 ("zone_without_width", lambda j: j["rules"].append({"rule": "transition_zone", "width": "wide"}), '"rules"[3]."width" must be a number'),
                 ("zone_negative", lambda j: j["rules"].append({"rule": "transition_zone", "width": -2}), "needs a positive \"width\""),
                 ("rules_not_array", lambda j: j.update(rules={"rule": "element_size"}), '"rules" must be an array'),
                 ("axis_short", lambda j: j["axis"].update(point=[1, 2]), '"axis"."point" must be an array of 3 numbers'),
                 ("axis_zero", lambda j: j["axis"].update(direction=[0, 0, 0]), '"axis"."direction" must not be zero'),
                 ("step_zero", lambda j: j["rules"][0].update(angle_step_deg=0), '"angle_step_deg" must be in (0, 360]'),
                 ("analysis_kind_number", lambda j: j["analysis"][0].update(kind=1), '"analysis"[0]."kind" must be a string')]
        for name, spoil, why in cases:
            folder = os.path.join(self.dir, name)
            shutil.copytree(boss, folder)
            j = json.loads(json.dumps(good))
            spoil(j)
            json.dump(j, open(os.path.join(folder, "feature.json"), "w"))
            for cmd in (["mesh", "-q", "--feature", folder, "-t", rib, "-o", os.path.join(self.dir, name + "_out")],
                        ["mesh-part", "-q", "--feature", folder, "--target", rib, "--output", os.path.join(self.dir, name + "_part")]):
                with self.subTest(name=name, cmd=cmd[0]):
                    r = run(*cmd)
                    self.assertEqual(r.returncode, 3, r.stderr)
                    self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
                    self.assertIn(os.path.join(folder, "feature.json"), r.stderr)
                    self.assertIn(why, r.stderr)

    def test_every_option_is_checked(self):
        base = ["extract", "-q", "-r", REF, "-t", TGT, "-o", self.out]
        for opt, value in [("--threads", "-5"), ("--seed", "-1"), ("--seed", "1e3"), ("--time-limit", "nan"), ("--time-limit", "-1")]:
            with self.subTest(opt + " " + value):
                r = run(*base, opt, value)
                self.assertEqual(r.returncode, 2, r.stderr)
                self.assertIn(opt, r.stderr)
                self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
        for value in ["nan", "inf", "-1", "0"]:
            with self.subTest("--max-projection " + value):
                r = run("mesh", "-q", "--feature", os.path.join(ROOT, "Resources", "library", "rib"), "-t", TGT,
                        "-o", os.path.join(self.dir, "m"), "--max-projection", value)
                self.assertEqual(r.returncode, 2, r.stderr)
                self.assertIn("--max-projection", r.stderr)
        self.assertFalse(os.path.exists(self.out))

    def test_messages_stay_on_one_line(self):
        odd = os.path.join(self.dir, "two\nlines.step")
        with open(odd, "wb") as f:
            f.write(b"ISO-10303-21;\nnot really\n")
        r = run("extract", "-q", "-r", REF, "-t", odd, "-o", self.out)
        self.assertEqual(r.returncode, 3, r.stderr)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
        self.assertIn("two\\nlines.step", r.stderr)
        r = run("extract", "-q", "-r", REF, "-t", self.dir, "-o", self.out)  # a folder
        self.assert_input_error(r, self.dir)
        self.assertIn("is a folder", r.stderr)
        r = run("extract", "-q", "-r", REF, "-t", TGT, "-o", self.out, "--config", os.path.join(self.dir, "none.json"))
        self.assertEqual(r.returncode, 3, r.stderr)  # a config file is input
        self.assertIn("none.json", r.stderr)

    def test_time_limit_stops_a_run_with_exit_5(self):
        # 1 s: reading both files takes a fifth of that alone, and can take more than 0.3 s when the
        # other test process is busy; the search itself takes about 3 s
        r = run("extract", "-q", "-r", REF, "-t", TGT, "-o", self.out, "--time-limit", "1")
        self.assertEqual(r.returncode, 5, r.stderr)
        self.assertIn("--time-limit", r.stderr)
        self.assertIn(TGT, r.stderr)
        self.assertFalse(os.path.exists(self.out))

    def test_time_limit_hit_while_reading_is_exit_5_not_a_bad_file(self):
        # the CAD reader's child is stopped by the caller's limit: that is the time limit (5), not a
        # corrupt file (3); on a loaded machine the 0.3 s run above can run out of time while reading
        r = run("extract", "-q", "-r", REF, "-t", TGT, "-o", self.out, "--time-limit", "0.001")
        self.assertEqual(r.returncode, 5, r.stderr)
        self.assertIn("--time-limit", r.stderr)
        self.assertIn(REF, r.stderr)
        self.assertNotIn("corrupt", r.stderr)
        self.assertFalse(os.path.exists(self.out))

    def test_extract_writes_the_json_contract(self):
        r = run("extract", "--reference", REF, "--target", TGT, "--output", self.out, "--seed", "3")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("%", r.stderr)  # progress
        with open(self.out) as f:
            j = json.load(f, parse_constant=no_nan)
        for key in ["matches", "reference", "target", "parameters", "timings"]:
            self.assertIn(key, j)
        self.assertEqual(j["parameters"]["seed"], 3)
        self.assertEqual(len(j["matches"]), 5)
        for m in j["matches"]:
            self.assertEqual(len(m["transform"]), 4)
            self.assertTrue(all(len(row) == 4 for row in m["transform"]))
            self.assertAlmostEqual(m["transform"][3][3], 1.0)
            self.assertTrue(0 <= m["score"] <= 1)
            self.assertEqual(len(m["center"]), 3)
            self.assertEqual(len(m["bbox"]), 2)
            self.assertTrue(all(isinstance(f, int) and f >= 1 for f in m["faces"]))
            # every face the rib reaches into, with its covered share; the listed faces are the ones
            # covered for face_coverage (0.5) or more, and a rib covers its own top whole
            shares = dict(m["face_shares"])
            self.assertEqual([f for f, _ in m["face_shares"]], sorted(shares))
            self.assertTrue(all(0.05 <= s <= 1 for s in shares.values()), shares)
            self.assertTrue(set(m["faces"]) <= set(shares), (m["faces"], shares))
            self.assertTrue(all((shares[f] >= 0.4995) == (f in m["faces"]) for f in shares), (m["faces"], shares))
            self.assertGreaterEqual(max(shares.values()), 0.9, shares)
            self.assertGreater(m["pairs"], 0)
        self.assertGreater(j["timings"]["total"], 0)

    def test_waiting_threads_sleep_unless_the_caller_chose(self):
        # OpenMP's waiting threads spin by default, which slows a search down by a third when another
        # program is busy (core/cli/main.cpp): the program starts itself again with the passive policy.
        env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
        p = subprocess.Popen([EXE, "extract", "-q", "-r", REF, "-t", TGT, "-o", self.out], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        seen = set()
        while p.poll() is None:
            try:
                with open(f"/proc/{p.pid}/environ", "rb") as f:
                    seen |= {v for v in f.read().split(b"\0") if v.startswith(b"OMP_WAIT_POLICY=")}
            except OSError:
                pass
            if seen:
                break
        _, err = p.communicate(timeout=600)
        self.assertEqual(p.returncode, 0, err)
        self.assertEqual(seen, {b"OMP_WAIT_POLICY=PASSIVE"})
        # the library commands (Python) inherit it, and a policy the caller set is kept
        script = self.write("show_policy.py", b"import os\nprint(os.environ.get('OMP_WAIT_POLICY'))\n")
        for given, expected in ((None, "PASSIVE"), ("ACTIVE", "ACTIVE")):
            e = dict(env, FE_LIBRARY_PROGRAM=script)
            if given:
                e["OMP_WAIT_POLICY"] = given
            r = subprocess.run([EXE, "library", "list", self.dir], env=e, capture_output=True, text=True, timeout=60)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertEqual(r.stdout.strip(), expected)

    def test_nothing_similar_is_exit_0_and_empty(self):
        r = run("extract", "-q", "-r", REF, "-t", os.path.join(MODELS, "boss_only.step"), "-o", self.out)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stderr, "")  # --quiet
        with open(self.out) as f:
            self.assertEqual(json.load(f, parse_constant=no_nan)["matches"], [])

    def test_non_utf8_file_name_in_a_warning(self):
        """A warning quotes the target's file name; bytes that are not UTF-8 must not abort the JSON."""
        import shutil
        tgt = os.path.join(os.fsencode(self.dir), b"t\xffrget.step")
        shutil.copy(os.fsencode(TGT), tgt)
        r = subprocess.run([EXE, "extract", "-q", "-r", REF, "-t", tgt, "-o", self.out, "--set", "max_dense_points=20000"],
                           capture_output=True, timeout=600)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(self.out, encoding="utf-8") as f:
            j = json.load(f, parse_constant=no_nan)
        self.assertTrue(any("described" in w and "coarser" in w and "\ufffd" in w for w in j["warnings"]), j["warnings"])

    def test_unwritable_output_exits_4(self):
        r = run("extract", "-q", "-r", REF, "-t", os.path.join(MODELS, "boss_only.step"), "-o", "/nonexistent/dir/out.json")
        self.assertEqual(r.returncode, 4)
        self.assertIn("/nonexistent/dir/out.json", r.stderr)


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0], "-v"])
