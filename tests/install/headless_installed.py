"""Run by test_install.py with freecadcmd, HOME set to a folder the project was installed into
(prefix HOME/.local) and no FeatureExtract environment variable: FreeCAD must find the workbench, the
Python module and the CLI of that installation by itself."""
import os
import sys
import traceback

home = os.environ["HOME"]


def main():
    import FreeCAD as App
    import Part
    from freecad.feature_extract import api, library
    import featureextract as fx
    for name, mod in (("workbench", api), ("Python module", fx)):
        assert os.path.realpath(mod.__file__).startswith(os.path.realpath(home)), f"{name} from {mod.__file__}, not the installation"
    cli = api._cli()
    assert os.path.realpath(cli) == os.path.realpath(os.path.join(home, ".local", "bin", "featureextract")), cli
    assert os.path.isfile(library.SHIPPED + "/rib/feature.json") and library.SHIPPED.startswith(home), library.SHIPPED
    names = sorted(f["name"] for f in library.features(library.SHIPPED))  # the installed CLI and fe_library.py
    assert len(names) == 6 and "rib" in names, names
    doc = App.newDocument("installed")
    part = doc.addObject("Part::Feature", "Part")
    part.Shape = Part.read(os.environ["FE_TEST_MODEL"])
    doc.recompute()
    rib = [f"Face{i}" for i, f in enumerate(part.Shape.Faces, 1)
           if f.BoundBox.XMin >= 17 and f.BoundBox.XMax <= 33 and f.BoundBox.ZMin > -1e-3 and f.BoundBox.ZMax > 0.5]
    results = api.extract(part, api.make_reference(part, rib), seed=1)
    assert len(results) == 5, [r.Label for r in results]
    print(f"installed: {len(results)} ribs found with the workbench, module and CLI under {home}")


try:
    main()
    ok = True
except Exception:
    traceback.print_exc()
    ok = False
sys.stdout.flush()
os._exit(0 if ok else 1)
