"""`cmake --install` into a user prefix, then FreeCAD with nothing but that installation (issue 11,
"Installable"): HOME is a temporary folder, the prefix is HOME/.local, no FeatureExtract environment
variable is set and no checkout is on any path.

    /usr/bin/python3 tests/install/test_install.py BUILD_DIR MODELS_DIR
"""
import glob
import os
import subprocess
import sys
import tempfile
import unittest

BUILD, MODELS = sys.argv[1], sys.argv[2]
HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


class Installed(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.home = tempfile.mkdtemp(prefix="fe_install_")
        cls.prefix = os.path.join(cls.home, ".local")
        cls.install = subprocess.run(["cmake", "--install", BUILD, "--prefix", cls.prefix], capture_output=True, text=True)
        cls.env = {"HOME": cls.home, "PATH": "/usr/bin:/bin", "LANG": "C.UTF-8"}

    def test_files_land_where_freecad_python_and_the_cli_look(self):
        self.assertEqual(self.install.returncode, 0, self.install.stderr)
        p = self.prefix
        self.assertTrue(os.access(os.path.join(p, "bin", "featureextract"), os.X_OK))
        for f in ("fe_library.py", "fe_db.py", "fe_gmsh_rest.py", "make_feature.py"):
            self.assertTrue(os.path.isfile(os.path.join(p, "share", "featureextract", f)), f)
        self.assertTrue(glob.glob(os.path.join(p, "lib", "python3.*", "site-packages", "featureextract", "_core*.so")))
        mod = os.path.join(p, "share", "FreeCAD", "Mod", "FeatureExtract")  # the user's Mod folder for HOME
        with open(os.path.join(mod, "package.xml")) as f:
            pkg = f.read()
        self.assertIn("<icon>Resources/icons/FeatureExtract.svg</icon>", pkg)
        self.assertTrue(os.path.isfile(os.path.join(mod, "Resources", "icons", "FeatureExtract.svg")))
        self.assertIn('<license file="LICENSE">', pkg)
        self.assertTrue(os.path.isfile(os.path.join(mod, "LICENSE")))
        self.assertEqual(len(glob.glob(os.path.join(mod, "Resources", "library", "*", "feature.json"))), 6)
        self.assertFalse(glob.glob(os.path.join(mod, "**", "__pycache__"), recursive=True))

    def test_installed_cli_runs_its_python_programs(self):
        cli = os.path.join(self.prefix, "bin", "featureextract")
        r = subprocess.run([cli, "--version"], capture_output=True, text=True, env=self.env)
        self.assertEqual(r.returncode, 0, r.stderr)
        lib = os.path.join(self.prefix, "share", "FreeCAD", "Mod", "FeatureExtract", "Resources", "library")
        r = subprocess.run([cli, "library", "list", lib], capture_output=True, text=True, env=self.env)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("6 features", r.stdout)

    def test_freecad_finds_the_installed_workbench_by_itself(self):
        r = subprocess.run(["freecadcmd", os.path.join(HERE, "headless_installed.py")], capture_output=True, text=True,
                           env=dict(self.env, FE_TEST_MODEL=os.path.join(MODELS, "ribs_bosses.step")), timeout=600)
        self.assertEqual(r.returncode, 0, r.stdout[-3000:] + r.stderr[-3000:])
        self.assertIn("5 ribs found", r.stdout)

    def test_system_prefixes_install_into_debians_freecad_mod_folder(self):
        # the layout for the default prefix, computed as `cmake --install` does, without writing there
        for prefix, py, mod in (("/usr/local", "/usr/local/lib/python3.11/dist-packages", "/usr/share/freecad/Mod"),
                                ("/usr", "/usr/lib/python3/dist-packages", "/usr/share/freecad/Mod"),
                                ("/opt/fe", "/opt/fe/lib/python3.11/site-packages", "/opt/fe/share/FreeCAD/Mod")):
            r = subprocess.run(["cmake", f"-DCMAKE_INSTALL_PREFIX={prefix}", "-DFE_PYTHON_VERSION=3.11",
                                "-P", os.path.join(ROOT, "cmake", "install_layout.cmake")], capture_output=True, text=True)
            self.assertIn(f"Python module in {py}, workbench in {mod}/FeatureExtract", r.stdout + r.stderr)


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
