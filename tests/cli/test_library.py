"""The feature library, library search and the batch over a vault (issue 13), with the real programs:
`featureextract library|search|batch|report` (fe_library.py), gmsh for the feature meshes, a real
`dask scheduler` and two `dask worker` processes on localhost (one killed mid-batch), real SQLite
files. Usage: test_library.py FEATUREEXTRACT MODELS_DIR"""
import json
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
import unittest

EXE, MODELS = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHIPPED = os.path.join(ROOT, "Resources", "library")
LIB = tempfile.mkdtemp(prefix="fe_lib_")  # the shipped rib and boss (the example plate's features)
for _name in ("rib", "boss"):
    shutil.copytree(os.path.join(SHIPPED, _name), os.path.join(LIB, _name))
PLATE = os.path.join(MODELS, "ribs_bosses.step")
BAD = os.path.join(ROOT, "..", "shared", "data", "bad-input")


def fx(*args, timeout=900, **kw):
    return subprocess.run([EXE, *args], capture_output=True, text=True, timeout=timeout, **kw)


class Library(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="fe_library_")
        out = os.path.join(cls.dir, "plate.json")
        r = fx("search", "--library", LIB, "--target", PLATE, "--output", out)
        assert r.returncode == 0, r.stderr
        with open(out) as f:
            cls.plate = json.load(f)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.dir, ignore_errors=True)

    def test_search_finds_every_feature_of_the_library_on_the_plate(self):
        got = {f["name"]: len(f["matches"]) for f in self.plate["features"]}
        self.assertEqual(got, {"rib": 5, "screw boss": 2})
        self.assertTrue(all(f["error"] is None for f in self.plate["features"]))
        self.assertEqual(self.plate["overlaps"], [])  # ribs and bosses share no faces
        self.assertGreater(self.plate["target"]["faces"], 10)
        for f in self.plate["features"]:  # the parameters each was searched with, and its warnings
            self.assertEqual(f["params"]["size_ladder"], 3, f["name"])
            self.assertEqual(f["params"]["seed"], 1, f["name"])
            self.assertIsInstance(f["warnings"], list)
            self.assertGreater(f["ransac_searches"], 0, f["name"])  # what each search cost, in RANSAC searches

    def test_two_features_on_the_same_faces_are_reported_and_ranked(self):
        lib = os.path.join(self.dir, "twice")
        shutil.copytree(LIB, lib)
        shutil.copytree(os.path.join(LIB, "rib"), os.path.join(lib, "rib_copy"))
        spec_path = os.path.join(lib, "rib_copy", "feature.json")
        with open(spec_path) as f:
            spec = json.load(f)
        spec["name"] = "rib (second rule)"
        with open(spec_path, "w") as f:
            json.dump(spec, f)
        out = os.path.join(self.dir, "twice.json")
        r = fx("search", "--library", lib, "--target", PLATE, "--output", out, "-q")
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(out) as f:
            res = json.load(f)
        self.assertEqual(len(res["overlaps"]), 5)  # each rib claimed by both
        for g in res["overlaps"]:
            self.assertEqual(sorted(c["feature"] for c in g["claims"]), ["rib", "rib (second rule)"])
            self.assertEqual([c["rank"] for c in g["claims"]], [1, 2])
            self.assertGreaterEqual(g["claims"][0]["score"], g["claims"][1]["score"])
            self.assertTrue(g["faces"])
        # the same features' descriptions are shared: the rib twice costs one target description
        self.assertLessEqual(res["descriptions_built"], 2)

    def test_features_searched_side_by_side_find_what_one_at_a_time_finds(self):
        # three features on one rung of the size ladder: the first describes the part on both
        # threads, the other two are searched at the same time on one thread each
        lib = os.path.join(self.dir, "thrice")
        for k, name in enumerate(("rib", "rib b", "rib c")):
            shutil.copytree(os.path.join(SHIPPED, "rib"), os.path.join(lib, f"rib{k}"))
            spec_path = os.path.join(lib, f"rib{k}", "feature.json")
            with open(spec_path) as f:
                spec = json.load(f)
            spec["name"] = name
            with open(spec_path, "w") as f:
                json.dump(spec, f)
        res = {}
        for threads in (2, 1):  # 2: side by side; 1: one after the other
            out = os.path.join(self.dir, f"thrice{threads}.json")
            r = fx("search", "--library", lib, "--target", PLATE, "--output", out, "-q", "--set", f"threads={threads}")
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(out) as f:
                res[threads] = json.load(f)
            self.assertEqual(res[threads]["descriptions_built"], 1)
        by_name = {t: {f["name"]: f for f in res[t]["features"]} for t in res}
        self.assertEqual(sorted(by_name[2]), ["rib", "rib b", "rib c"])
        self.assertEqual(sorted(f["params"]["threads"] for f in res[2]["features"]), [1, 1, 2])
        self.assertEqual([f["params"]["threads"] for f in res[1]["features"]], [1, 1, 1])
        for name, f in by_name[2].items():
            self.assertEqual(len(f["matches"]), 5, name)
            self.assertEqual(f["matches"], by_name[1][name]["matches"], name)  # the same to the last digit
            self.assertEqual(f["matches"], by_name[2]["rib"]["matches"], name)
        self.assertEqual(res[2]["overlaps"], res[1]["overlaps"])

    def test_faces_picked_on_a_part_become_a_feature_that_is_found_again(self):
        boss = next(f for f in self.plate["features"] if f["name"] == "screw boss")["matches"][0]
        lib = os.path.join(self.dir, "mine")
        r = fx("library", "add", lib, "--from", PLATE, "--faces", ",".join(map(str, boss["faces"])), "--name", "plate boss",
               "--class", "boss", "--description", "boss found on the example plate")
        self.assertEqual(r.returncode, 0, r.stderr)
        folder = os.path.join(lib, "plate_boss")
        for f in ("feature.json", "geometry.brep", "mesh.inp", "thumbnail.png"):
            self.assertTrue(os.path.isfile(os.path.join(folder, f)), f)
        with open(os.path.join(folder, "feature.json")) as f:
            spec = json.load(f)
        self.assertEqual((spec["name"], spec["class"]), ("plate boss", "boss"))
        self.assertEqual(spec["source"]["faces"], boss["faces"])
        self.assertGreater(spec["counts"]["elements"], 20)
        r = fx("library", "check", lib)
        self.assertEqual(r.returncode, 0, r.stderr + r.stdout)
        r = fx("library", "list", lib, "--json")
        self.assertEqual([x["name"] for x in json.loads(r.stdout)], ["plate boss"])
        out = os.path.join(self.dir, "mine.json")
        r = fx("search", "--library", lib, "--target", PLATE, "--output", out, "-q")
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(out) as f:
            res = json.load(f)
        self.assertEqual(len(res["features"][0]["matches"]), 2)  # both bosses
        # adding it again is refused, with --replace it is rewritten
        r = fx("library", "add", lib, "--from", PLATE, "--faces", "1", "--name", "plate boss")
        self.assertEqual(r.returncode, 3)
        self.assertIn("already there", r.stderr)

    def test_bad_library_input_is_one_line_and_exit_3(self):
        lib = os.path.join(self.dir, "broken")
        shutil.copytree(LIB, lib)
        with open(os.path.join(lib, "rib", "feature.json"), "w") as f:
            f.write("{ not json")
        r = fx("library", "check", lib)
        self.assertEqual(r.returncode, 3)
        bad = [x for x in r.stderr.splitlines() if "rib" in x]
        self.assertEqual(len(bad), 1, r.stderr)
        self.assertIn("feature.json", bad[0])
        r = fx("search", "--library", os.path.join(self.dir, "nowhere"), "--target", PLATE, "--output", os.path.join(self.dir, "x.json"))
        self.assertEqual(r.returncode, 3)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1)
        r = fx("library", "add", lib, "--from", PLATE, "--faces", "9999", "--name", "x")
        self.assertEqual(r.returncode, 3)
        self.assertIn("9999", r.stderr)
        r = fx("library", "add", lib, "--from", PLATE, "--faces", "a,b", "--name", "x")
        self.assertEqual(r.returncode, 2)


def db_rows(path):
    """What a batch stored, without ids, times and run numbers: per part (path, ok, error) and per
    instance (path, feature, score, faces, transform), sorted. SQLite file or postgresql:// URL."""
    if path.startswith("postgresql://"):
        import psycopg2
        con = psycopg2.connect(path)
    else:
        con = sqlite3.connect(path)

    def q(s):
        cur = con.cursor()
        cur.execute(s)
        return [tuple(r) for r in cur.fetchall()]
    results = sorted(q("SELECT p.path, r.ok, r.error FROM results r JOIN parts p ON p.id = r.part_id"))
    matches = sorted(q("SELECT p.path, f.name, m.score, m.faces, m.transform, m.mirrored FROM matches m "
                       "JOIN results r ON r.id = m.result_id JOIN parts p ON p.id = r.part_id "
                       "JOIN features f ON f.id = m.feature_id"))
    per_part = q("SELECT part_id, COUNT(*) FROM results GROUP BY part_id HAVING COUNT(*) > 1")
    con.close()
    return results, matches, per_part


def start_postgres(folder):
    """A PostgreSQL server of its own in `folder` (initdb, pg_ctl; as the postgres user when run as
    root, which PostgreSQL refuses to be), on a free port. Returns (URL, stop())."""
    import glob
    import socket
    bins = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"))
    if not bins:
        raise AssertionError("PostgreSQL is not installed (apt-get install postgresql): setup.sh installs it")
    bindir = os.path.dirname(bins[-1])
    as_user = ["runuser", "-u", "postgres", "--"] if os.geteuid() == 0 else []
    if os.geteuid() == 0:
        shutil.chown(folder, "postgres")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    data = os.path.join(folder, "data")
    subprocess.run(as_user + [os.path.join(bindir, "initdb"), "-D", data, "-A", "trust", "-U", "fe"], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    subprocess.run(as_user + [os.path.join(bindir, "pg_ctl"), "-D", data, "-o", f"-k {folder} -p {port} -h 127.0.0.1",
                              "-l", os.path.join(folder, "log"), "-w", "start"], check=True, stdout=subprocess.DEVNULL)
    subprocess.run(as_user + [os.path.join(bindir, "createdb"), "-h", "127.0.0.1", "-p", str(port), "-U", "fe", "fe"], check=True)

    def stop():
        subprocess.run(as_user + [os.path.join(bindir, "pg_ctl"), "-D", data, "-m", "immediate", "stop"],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return f"postgresql://fe@127.0.0.1:{port}/fe", stop


class Batch(unittest.TestCase):
    """A vault of five parts in two folders (three good, an empty file, a STEP with a dangling reference)."""

    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="fe_batch_")
        cls.vault = os.path.join(cls.dir, "vault")
        os.makedirs(os.path.join(cls.vault, "sub"))
        for name in ("ribs_bosses.step", "boss_only.step"):
            shutil.copy(os.path.join(MODELS, name), os.path.join(cls.vault, name))
        shutil.copy(os.path.join(MODELS, "ribs_bosses_rotated.step"), os.path.join(cls.vault, "sub", "rotated.step"))
        open(os.path.join(cls.vault, "empty.step"), "w").close()
        shutil.copy(os.path.join(BAD, "step_dangling_ref.step"), os.path.join(cls.vault, "sub", "dangling.step"))
        cls.pattern = os.path.join(cls.vault, "**", "*.step")
        cls.serial = os.path.join(cls.dir, "serial.sqlite")
        r = fx("batch", "--library", LIB, "--parts", cls.pattern, "--db", cls.serial, "--serial")
        assert r.returncode == 0, r.stderr
        cls.serial_log = r.stderr
        cls.reference = db_rows(cls.serial)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.dir, ignore_errors=True)

    def test_serial_batch_stores_every_part_once_with_errors_as_rows(self):
        results, matches, dup = self.reference
        self.assertEqual(len(results), 5)
        self.assertEqual(dup, [])
        ok = {os.path.basename(p): o for p, o, _ in results}
        self.assertEqual(ok, {"ribs_bosses.step": 1, "boss_only.step": 1, "rotated.step": 1, "empty.step": 0, "dangling.step": 0})
        errors = {os.path.basename(p): e for p, o, e in results if not o}
        for name, e in errors.items():
            self.assertIn(name, e)  # the one-line message names the file
            self.assertNotIn("\n", e)
        count = {}
        for p, f, *_ in matches:
            count[(os.path.basename(p), f)] = count.get((os.path.basename(p), f), 0) + 1
        self.assertEqual(count[("ribs_bosses.step", "rib")], 5)
        self.assertEqual(count[("ribs_bosses.step", "screw boss")], 2)
        self.assertEqual(count[("rotated.step", "rib")], 5)  # the plate turned in 3D
        self.assertEqual(count[("boss_only.step", "screw boss")], 2)
        self.assertNotIn(("boss_only.step", "rib"), count)  # a plate with two bosses and no rib
        self.assertIn("5/5 parts", self.serial_log)  # progress: parts done / total
        # a second run skips everything and adds no row
        r = fx("batch", "--library", LIB, "--parts", self.pattern, "--db", self.serial, "--serial")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("5 already in", r.stderr)
        self.assertEqual(db_rows(self.serial), self.reference)

    def test_dask_cluster_with_a_worker_killed_mid_batch_gives_the_serial_rows(self):
        sched_file = os.path.join(self.dir, "scheduler.json")
        env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
        procs = []
        try:
            procs.append(subprocess.Popen(["dask", "scheduler", "--scheduler-file", sched_file, "--host", "127.0.0.1", "--port", "0",
                                           "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env))
            for _ in range(200):
                if os.path.isfile(sched_file) and os.path.getsize(sched_file) > 0:
                    break
                time.sleep(0.1)
            with open(sched_file) as f:
                address = json.load(f)["address"]
            workers = [subprocess.Popen(["dask", "worker", "--scheduler-file", sched_file, "--nworkers", "1", "--nthreads", "1",
                                         "--no-dashboard", "--no-nanny", "--host", "127.0.0.1"],
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env) for _ in range(2)]
            procs += workers
            db = os.path.join(self.dir, "dask.sqlite")
            batch = subprocess.Popen([EXE, "batch", "--library", LIB, "--parts", self.pattern, "--db", db, "--scheduler", address],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            # kill one worker once the first part is done (the other is busy with a part by then)
            line = batch.stderr.readline()
            log = [line]
            while line and "1/5 parts" not in line:
                line = batch.stderr.readline()
                log.append(line)
            workers[0].send_signal(signal.SIGKILL)
            _, rest = batch.communicate(timeout=900)
            log.append(rest)
            self.assertEqual(batch.returncode, 0, "".join(log))
            self.assertIn("5/5 parts", "".join(log))
            self.assertEqual(db_rows(db), self.reference)
        finally:
            for p in procs:
                if p.poll() is None:
                    p.kill()
                p.wait()

    def test_a_batch_killed_and_started_again_finishes_with_every_row_once(self):
        db = os.path.join(self.dir, "resumed.sqlite")
        batch = subprocess.Popen([EXE, "batch", "--library", LIB, "--parts", self.pattern, "--db", db, "--workers", "2"],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
        line = batch.stderr.readline()
        while line and "2/5 parts" not in line:
            line = batch.stderr.readline()
        os.killpg(batch.pid, signal.SIGKILL)  # the driver and its local cluster, at once
        batch.wait()
        results, _, _ = db_rows(db)
        self.assertGreaterEqual(len(results), 2)
        self.assertLess(len(results), 5)
        r = fx("batch", "--library", LIB, "--parts", self.pattern, "--db", db, "--workers", "2")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn(f"{len(results)} already in", r.stderr)
        self.assertEqual(db_rows(db), self.reference)

    def test_postgresql_gets_the_rows_sqlite_gets(self):
        folder = tempfile.mkdtemp(prefix="fe_pg_")
        url, stop = start_postgres(folder)
        try:
            r = fx("batch", "--library", LIB, "--parts", self.pattern, "--db", url, "--workers", "2")
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertEqual(db_rows(url), self.reference)
            r = fx("batch", "--library", LIB, "--parts", self.pattern, "--db", url, "--serial")
            self.assertIn("5 already in", r.stderr)
            self.assertEqual(db_rows(url), self.reference)
            r = fx("report", "--db", url, "--output", os.path.join(folder, "r.html"))
            self.assertEqual(r.returncode, 0, r.stderr)
        finally:
            stop()
            shutil.rmtree(folder, ignore_errors=True)
        r = fx("batch", "--library", LIB, "--parts", self.pattern, "--db", url, "--serial")  # the server is gone
        self.assertEqual(r.returncode, 3)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
        self.assertIn("cannot open the database", r.stderr)

    def test_a_part_smaller_than_every_feature_is_searched_with_notes_not_an_error(self):
        vault = os.path.join(self.dir, "small")
        os.makedirs(vault)
        shutil.copy(os.path.join(ROOT, "..", "shared", "data", "mfcad", "5-5-5-5-12-23.step"), os.path.join(vault, "slots.step"))
        db = os.path.join(self.dir, "small.sqlite")
        r = fx("batch", "--library", LIB, "--parts", os.path.join(vault, "*.step"), "--db", db, "--serial")
        self.assertEqual(r.returncode, 0, r.stderr)
        con = sqlite3.connect(db)
        ok, error, notes = con.execute("SELECT ok, error, notes FROM results").fetchone()
        con.close()
        self.assertEqual((ok, error), (1, None))
        self.assertEqual(len(notes.splitlines()), 2, notes)  # the rib and the boss, each larger than the part
        self.assertIn("larger", notes)

    def test_report_lists_every_part_and_feature(self):
        html = os.path.join(self.dir, "report.html")
        csv = os.path.join(self.dir, "matches.csv")
        r = fx("report", "--db", self.serial, "--output", html, "--csv", csv)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(html) as f:
            page = f.read()
        for name in ("ribs_bosses.step", "empty.step", "rib", "screw boss"):
            self.assertIn(name, page)
        # a picture of each readable part with its instances in their feature's color, its matches as JSON
        files = os.path.join(self.dir, "report_files")
        pics = re.findall(r"<img src='report_files/(part\d+\.png)'", page)
        self.assertGreaterEqual(len(pics), 3, page[:2000])
        for p in pics:
            self.assertTrue(os.path.getsize(os.path.join(files, p)) > 1000, p)
        links = re.findall(r"<a href='report_files/(part\d+\.json)'>", page)
        found = [json.load(open(os.path.join(files, x))) for x in links]
        self.assertEqual(sum(len(x["matches"]) for x in found), len(self.reference[1]))
        plate = next(x for x in found if x["path"].endswith("ribs_bosses.step"))
        self.assertEqual(sorted({m["feature"] for m in plate["matches"]}), ["rib", "screw boss"])
        import matplotlib.image
        i = links.index(next(x for x in links if json.load(open(os.path.join(files, x)))["path"].endswith("ribs_bosses.step")))
        img = matplotlib.image.imread(os.path.join(files, links[i].replace(".json", ".png")))
        red = ((img[..., 0] > 0.5) & (img[..., 1] < 0.25) & (img[..., 2] < 0.25)).sum()  # the first feature's color
        blue = ((img[..., 2] > 0.45) & (img[..., 0] < 0.3)).sum()
        self.assertGreater(red, 20, "the ribs (red, the first feature) show on the plate's picture")
        self.assertGreater(blue, 20, "the bosses (blue) show on the plate's picture")
        with open(csv) as f:
            lines = f.read().strip().splitlines()
        self.assertEqual(len(lines) - 1, len(self.reference[1]))
        r = fx("report", "--db", os.path.join(self.dir, "none.sqlite"), "--output", html)
        self.assertEqual(r.returncode, 3)
        self.assertIn("none.sqlite", r.stderr)


class ShippedLibrary(unittest.TestCase):
    def test_every_shipped_feature_is_readable_and_listed(self):
        r = fx("library", "check", SHIPPED)
        self.assertEqual(r.returncode, 0, r.stderr + r.stdout)
        r = fx("library", "list", SHIPPED, "--json")
        self.assertEqual(r.returncode, 0, r.stderr)
        got = {x["class"] for x in json.loads(r.stdout)}
        self.assertLessEqual({"rib", "boss", "lug", "ear", "hole", "slot"}, got)


if __name__ == "__main__":
    try:
        unittest.main(argv=sys.argv[:1], verbosity=2)
    finally:
        shutil.rmtree(LIB, ignore_errors=True)
