"""Headless workbench tests (issue 3), run by `freecadcmd tests/freecad/test_app.py` with FE_MODELS
(generated models), FE_WB (the FeatureExtractWB folder) and FEATUREEXTRACT_PYTHONPATH set by CTest.
Exits 0 when every test passes."""
import os
import sys
import tempfile
import traceback
import unittest

sys.path.insert(0, os.environ["FE_WB"])
import freecad  # noqa: E402  (FreeCAD's namespace package; extend it with the workbench's folder)

if os.path.join(os.environ["FE_WB"], "freecad") not in freecad.__path__:
    freecad.__path__.append(os.path.join(os.environ["FE_WB"], "freecad"))

import FreeCAD as App  # noqa: E402
import Part  # noqa: E402

from freecad.feature_extract import api  # noqa: E402

# the workbench under test, not another checkout's that the user's Mod folder may link to
if not os.path.realpath(api.__file__).startswith(os.path.realpath(os.environ["FE_WB"])):
    print(f"FAIL: testing {api.__file__}, not the workbench in {os.environ['FE_WB']} (re-run ./setup.sh here)")
    sys.stdout.flush()
    os._exit(1)

MODELS = os.environ["FE_MODELS"]


def rib_faces(shape, x, halfwidth=8.0):
    """FaceN of the rib standing at x on the example plate (its faces above the plate top)."""
    out = []
    for i, f in enumerate(shape.Faces, 1):
        b = f.BoundBox
        if b.XMin >= x - halfwidth and b.XMax <= x + halfwidth and b.ZMin > -1e-3 and b.ZMax > 0.5:
            out.append(f"Face{i}")
    return out


class App_(unittest.TestCase):
    def setUp(self):
        self.doc = App.newDocument("fe_test")
        self.part = self.doc.addObject("Part::Feature", "Part")
        self.part.Shape = Part.read(os.path.join(MODELS, "ribs_bosses.step"))
        self.doc.recompute()

    def tearDown(self):
        App.closeDocument(self.doc.Name)

    def test_progress_is_one_fraction_of_the_whole_run(self):
        # issue 11, item 9: the bar restarted at 0 for every stage and sat at 'ransac 0%' until done
        seen = []
        api.compute(self.part, os.path.join(MODELS, "rib_reference.step"), progress=lambda s, f: seen.append((s, f)) or True, seed=1)
        values = [f for _, f in seen]
        self.assertEqual(seen[0][0], "tessellating")
        self.assertLessEqual(values[0], 0.05)
        self.assertEqual(values[-1], 1.0)
        self.assertTrue(all(b >= a for a, b in zip(values, values[1:])), "never goes back")
        self.assertGreater(len(set(values)), 15)
        ransac = {f for s, f in seen if s == "ransac"}
        self.assertGreater(len(ransac), 3, "RANSAC moves the bar while it runs")
        # the mirror image's pass goes on in the rest of the bar (a mirrored L pad reference)
        pads = self.doc.addObject("Part::Feature", "Pads")
        pads.Shape = Part.read(os.path.join(MODELS, "l_pads.step"))
        seen.clear()
        api.compute(pads, os.path.join(MODELS, "l_pad_reference.brep"), progress=lambda s, f: seen.append((s, f)) or True, seed=1)
        values = [f for _, f in seen]
        self.assertTrue(all(b >= a for a, b in zip(values, values[1:])))
        self.assertGreater(sum(1 for s, _ in seen if s.startswith("reference")), 4)  # two passes

    def test_reference_from_faces_extract_save_reopen(self):
        faces = rib_faces(self.part.Shape, 60.0)
        self.assertGreaterEqual(len(faces), 15)
        ref = api.make_reference(self.part, faces)
        self.assertEqual(len(ref.Shape.Faces), len(faces))
        results = api.extract(self.part, ref, seed=1)
        self.assertEqual(len(results), 5)
        picked = {int(f[4:]) for f in faces}
        own = max(results, key=lambda r: len(picked & set(r.Faces)))
        self.assertGreaterEqual(len(picked & set(own.Faces)), 0.8 * len(picked))  # finds itself
        for r in results:
            self.assertGreater(r.Score, 0.9)
            self.assertGreaterEqual(len(r.Faces), 15)
            self.assertAlmostEqual(r.Transform.A44, 1.0)
        # save, close, reopen: the results are intact
        path = os.path.join(tempfile.mkdtemp(), "results.FCStd")
        saved = [(r.Name, list(r.Faces), r.Score, r.Transform.A14) for r in results]
        ref_name = ref.Name
        self.doc.saveAs(path)
        App.closeDocument(self.doc.Name)
        self.doc = App.openDocument(path)
        group = self.doc.getObject(api.RESULT_GROUP)
        self.assertIsNotNone(group)
        again = sorted((r.Name, list(r.Faces), r.Score, r.Transform.A14) for r in group.Group)
        self.assertEqual(again, sorted(saved))
        for r in group.Group:
            self.assertEqual(r.Target.Name, "Part")
            self.assertIsNotNone(r.Reference)
        # running again replaces the results instead of piling them up, with the same plain labels
        api.extract(self.doc.getObject("Part"), self.doc.getObject(ref_name), seed=1)
        self.assertEqual(len(self.doc.getObject(api.RESULT_GROUP).Group), 5)
        for r in self.doc.getObject(api.RESULT_GROUP).Group:
            self.assertRegex(r.Label, r"^Similar [1-5] \(\d\.\d\d\)$")

    def test_document_objects_and_old_view_provider_names(self):
        """Issue 11, layout by role: the document objects stay in objects.py (Document.xml names each
        proxy by module and class: their saved path is unchanged); the view providers live in
        view_providers.py, and objects still answers the names older documents saved in
        GuiDocument.xml (freecad.feature_extract.objects.ViewProviderResult, ...), FreeCAD taking
        the class from the module by name."""
        import zipfile
        from freecad.feature_extract import objects, view_providers
        for name in ("ViewProviderReference", "ViewProviderResult", "ViewProviderFeatureMesh"):
            self.assertIs(getattr(objects, name), getattr(view_providers, name))
        with self.assertRaises(AttributeError):
            objects.ViewProviderSomethingElse  # noqa: B018
        ref = api.make_reference(self.part, rib_faces(self.part.Shape, 60.0))
        self.assertEqual(ref.Proxy.Type, "FeatureExtract::ReferenceFeature")
        path = os.path.join(tempfile.mkdtemp(), "reference.FCStd")
        self.doc.saveAs(path)
        with zipfile.ZipFile(path) as z:
            xml = z.read("Document.xml").decode()
        self.assertIn('module="freecad.feature_extract.objects" class="ReferenceFeature"', xml)

    def test_reference_file_and_saved_brep(self):
        results = api.extract(self.part, os.path.join(MODELS, "rib_reference.step"))
        self.assertEqual(len(results), 5)
        ref = api.make_reference(self.part, rib_faces(self.part.Shape, 25.0))
        brep = os.path.join(tempfile.mkdtemp(), "rib.brep")
        api.save_reference(ref, brep)
        self.assertEqual(len(Part.read(brep).Faces), len(ref.Faces))

    def test_box_cut_reference_and_mirrored_pads(self):
        """Issue 9 in FreeCAD: a reference cut out of the part with a box (Part's common, as a user
        does it) finds every rib; mirrored L pads are results with Mirrored set."""
        box = Part.makeBox(24, 52, 30, App.Vector(13, 14, -10))
        results = api.extract(self.part, self.part.Shape.common(box), seed=1)
        self.assertEqual(len(results), 5)
        pads = self.doc.addObject("Part::Feature", "Pads")
        pads.Shape = Part.read(os.path.join(MODELS, "l_pads.step"))
        found = api.extract(pads, os.path.join(MODELS, "l_pad_reference.brep"), seed=1)
        self.assertEqual([r.Mirrored for r in sorted(found, key=lambda r: r.Center.x)], [False, False, True, True])

    def test_shape_reference(self):
        """A Part.Shape (not a document object) as reference: found, recorded without a link."""
        ref_shape = Part.read(os.path.join(MODELS, "rib_reference.step"))
        results = api.extract(self.part, ref_shape, seed=1)
        self.assertEqual(len(results), 5)
        for r in results:
            self.assertIsNone(r.Reference)
            self.assertEqual(r.ReferenceText, "shape")
        # again: replaces those results instead of adding a second set
        api.extract(self.part, ref_shape, seed=1)
        self.assertEqual(len(self.doc.getObject(api.RESULT_GROUP).Group), 5)

    def test_failed_recording_is_rolled_back(self):
        """freecadcmd has no undo (UndoMode 0): a failure half-way through add_results must still leave
        the document exactly as it was, earlier results included."""
        api.extract(self.part, os.path.join(MODELS, "rib_reference.step"), seed=1)
        before = sorted(o.Name for o in self.doc.Objects)
        good = api.compute(self.part, os.path.join(MODELS, "rib_reference.step"), seed=1)

        class Broken:  # the third match is unusable: created objects must be removed again
            matches = list(good.matches[:2]) + [object()]
        with self.assertRaises(AttributeError):
            api.add_results(self.part, os.path.join(MODELS, "rib_reference.step"), Broken())
        self.assertEqual(sorted(o.Name for o in self.doc.Objects), before)
        # also when the result group itself was created by the failing call
        doc2 = App.newDocument("fe_test2")
        try:
            part2 = doc2.addObject("Part::Feature", "Part")
            part2.Shape = self.part.Shape
            with self.assertRaises(AttributeError):
                api.add_results(part2, "x.step", Broken())
            self.assertEqual(sorted(o.Name for o in doc2.Objects), ["Part"])
        finally:
            App.closeDocument(doc2.Name)

    def test_feature_meshes_placed_saved_and_reopened(self):
        """Issue 5: a reference feature folder's FE mesh on every boss, as FEM mesh objects with their
        quality, saved and restored; a bad folder changes nothing."""
        features = os.path.join(os.path.dirname(os.environ["FE_WB"]), "Resources", "library")
        part = self.doc.addObject("Part::Feature", "Bosses")
        part.Shape = Part.read(os.path.join(MODELS, "suite", "bosses.step"))
        self.doc.recompute()
        before = sorted(o.Name for o in self.doc.Objects)
        with self.assertRaises(api.FeatureExtractError):
            api.place_meshes(part, os.path.join(features, "no_such_feature"))
        self.assertEqual(sorted(o.Name for o in self.doc.Objects), before)
        meshes = api.place_meshes(part, os.path.join(features, "boss"), seed=1)
        self.assertEqual(len(meshes), 5)
        for m in meshes:
            self.assertEqual(m.TypeId, "Fem::FemMeshObjectPython")
            self.assertEqual(m.FemMesh.NodeCount, 229)
            self.assertEqual(m.FemMesh.FaceCount, 228)
            self.assertEqual(m.InvertedElements, 0)
            self.assertEqual(m.UnprojectedNodes, 0)
            self.assertGreater(m.MinScaledJacobian, 0.5)
            self.assertIn("BOLT_RIGID", m.NodeSets)
            self.assertEqual(len(m.ScaledJacobian), 228)
            self.assertIsNotNone(m.Result)
            # every node on the part's surface (within the tessellation's deflection)
            worst = max(part.Shape.distToShape(Part.Vertex(v))[0] for v in m.FemMesh.Nodes.values())
            self.assertLess(worst, 0.05)
        path = os.path.join(tempfile.mkdtemp(), "meshes.FCStd")
        saved = sorted((m.Name, m.FemMesh.NodeCount, round(m.MinScaledJacobian, 9)) for m in meshes)
        self.doc.saveAs(path)
        App.closeDocument(self.doc.Name)
        self.doc = App.openDocument(path)
        again = sorted((o.Name, o.FemMesh.NodeCount, round(o.MinScaledJacobian, 9)) for o in self.doc.Objects
                       if o.TypeId == "Fem::FemMeshObjectPython")
        self.assertEqual(again, saved)
        # placing again replaces the meshes (and results) instead of piling them up
        api.place_meshes(self.doc.getObject("Bosses"), os.path.join(features, "boss"), seed=1)
        self.assertEqual(len([o for o in self.doc.Objects if o.TypeId == "Fem::FemMeshObjectPython"]), 5)

    def test_part_meshed_whole_and_solved_by_freecads_calculix(self):
        """Issue 12: the whole plate meshed with the rib and boss rules (mesh-part in a child process), a
        CalculiX analysis set up in the document, solved by FreeCAD's own ccx tools; a failure changes
        nothing."""
        features = os.path.join(os.path.dirname(os.environ["FE_WB"]), "Resources", "library")
        before = sorted(o.Name for o in self.doc.Objects)
        with self.assertRaises(api.FeatureExtractError) as err:
            api.mesh_part(self.part, [os.path.join(features, "no_such_feature")])
        self.assertIn("no_such_feature", str(err.exception))
        self.assertEqual(sorted(o.Name for o in self.doc.Objects), before)
        seen = []
        # 10-node tetrahedra with a coarser rest (size 6): ccx takes 30 s, not 220 s as at the default size
        mesh, analysis = api.mesh_part(self.part, [os.path.join(features, f) for f in ("rib", "boss")], size=6,
                                       progress=lambda stage, f: seen.append(stage))
        self.assertIn("meshing the rest (gmsh)", seen)
        self.assertEqual(mesh.TypeId, "Fem::FemMeshObject")
        self.assertGreater(mesh.FemMesh.VolumeCount, 30000)
        some = mesh.FemMesh.Volumes[0]
        self.assertEqual(len(mesh.FemMesh.getElementNodes(some)), 10)  # quadratic
        names = sorted(o.Name for o in analysis.Group)
        self.assertIn("Support", names)
        self.assertEqual([n for n in names if n.startswith("Bolt_")], ["Bolt_SCREW_BOSS_1", "Bolt_SCREW_BOSS_2"])
        self.assertEqual(len(self.part.Shape.Faces), 139)
        from femtools import ccxtools
        solver = [o for o in analysis.Group if o.Name.startswith("CalculiX")][0]
        fea = ccxtools.FemToolsCcx(analysis, solver)
        fea.update_objects()
        fea.setup_working_dir()
        fea.setup_ccx()
        self.assertEqual(fea.check_prerequisites(), "")
        fea.write_inp_file()
        with open(fea.inp_file_name) as f:
            self.assertIn("TYPE=C3D10", f.read())  # FreeCAD writes the 10-node tetrahedra back as CalculiX's
        fea.ccx_run()
        fea.load_results()
        results = [o for o in self.doc.Objects if o.isDerivedFrom("Fem::FemResultObject")]
        self.assertEqual(len(results), 1)
        umax = max(results[0].DisplacementLengths)
        self.assertGreater(umax, 0)
        self.assertLess(umax, 1e-3)  # 200 N on a steel plate held on its underside: far below a micron

    def test_library_search_progress_never_goes_back_with_features_side_by_side(self):
        # features that share a description are searched two at a time: their lines interleave
        from freecad.feature_extract import library
        seen = []
        report = library._overall(lambda stage, f: seen.append((stage, f)) or True)
        for stage, f in [("rib (1 of 3): reference: sampling", 0.0), ("rib (1 of 3): ransac", 0.5), ("rib (1 of 3): done", 1.0),
                         ("a (2 of 3): reference: sampling", 0.0), ("b (3 of 3): reference: sampling", 0.0),
                         ("b (3 of 3): ransac", 0.6), ("a (2 of 3): ransac", 0.2), ("a (2 of 3): done", 1.0),
                         ("b (3 of 3): ransac", 0.9), ("b (3 of 3): done", 1.0)]:
            self.assertTrue(report(stage, f))
        fractions = [f for _, f in seen]
        self.assertEqual(fractions, sorted(fractions), seen)
        self.assertEqual(fractions[-1], 1.0)
        self.assertTrue(seen[6][0].startswith("a (2 of 3): ransac"), seen[6])  # each line keeps its feature's name

    def test_library_search_groups_per_feature_and_bad_input(self):
        # issue 13, item 4, headless: a library searched from a macro; one group per feature found
        import shutil
        from freecad.feature_extract import library
        lib = tempfile.mkdtemp(prefix="fe_app_library_")
        for d in ("rib", "boss"):
            shutil.copytree(os.path.join(library.SHIPPED, d), os.path.join(lib, d))
        self.assertEqual(sorted(f["name"] for f in library.features(lib)), ["rib", "screw boss"])
        before = sorted(o.Name for o in self.doc.Objects)
        with self.assertRaisesRegex(api.FeatureExtractError, r"'Face999' is not one of its faces"):
            library.add_faces(self.part, ["Face999"], "x", lib)
        with self.assertRaisesRegex(api.FeatureExtractError, "needs a name"):
            library.add_faces(self.part, ["Face1"], "  ", lib)
        with self.assertRaisesRegex(api.FeatureExtractError, "not a folder"):
            library.search(self.part, os.path.join(lib, "no_such_library"))
        self.assertEqual(sorted(o.Name for o in self.doc.Objects), before)
        seen = []
        groups = library.search(self.part, lib, progress=lambda stage, f: seen.append(f) or True)
        self.assertEqual(sorted(g.Label for g in groups), ["rib on Part (5)", "screw boss on Part (2)"])
        self.assertEqual(len(api.results_for(self.part)), 7)
        self.assertTrue(seen and seen == sorted(seen) and seen[-1] == 1.0, "progress is one fraction that never goes back")
        for g in groups:
            self.assertEqual(len({tuple(r.Color) for r in g.Group}), 1)
            self.assertTrue(all(r.ReferenceText == "library: " + g.LibraryFeature for r in g.Group))
        # searched again (the cached result): the groups are replaced, not added to
        again = library.search(self.part, lib)
        self.assertEqual(len(again), 2)
        self.assertEqual(len(library.groups_for(self.part)), 2)
        self.assertEqual(len(api.results_for(self.part)), 7)

    def test_bad_input_leaves_the_document_unchanged(self):
        before = sorted(o.Name for o in self.doc.Objects)
        with self.assertRaises(api.FeatureExtractError):
            api.make_reference(self.part, [])
        with self.assertRaises(api.FeatureExtractError):
            api.make_reference(self.part, ["Edge3"])
        with self.assertRaises(api.FeatureExtractError):
            api.make_reference(self.part, ["Face9999"])
        with self.assertRaises(api.FeatureExtractError):  # a shape is not a document object
            api.make_reference(self.part.Shape, ["Face1"])
        # one flat face, or coplanar ones, refused at pick time in an analyst's words (issue 11)
        flat = [f"Face{i}" for i, f in enumerate(self.part.Shape.Faces, 1) if type(f.Surface).__name__ == "Plane"]
        with self.assertRaisesRegex(api.FeatureExtractError, "one flat plane"):
            api.make_reference(self.part, flat[:1])
        ref = api.make_reference(self.part, rib_faces(self.part.Shape, 60.0))  # a rib's faces are fine
        before.append(ref.Name)
        empty = self.doc.addObject("App::FeaturePython", "NoShape")
        before.append(empty.Name)
        with self.assertRaises(api.FeatureExtractError):
            api.extract(empty, os.path.join(MODELS, "rib_reference.step"))
        with self.assertRaises(ValueError):  # the core's InputError: a planar reference
            api.extract(self.part, os.path.join(MODELS, "flat_reference.step"))
        with self.assertRaises(ValueError):
            api.extract(self.part, os.path.join(MODELS, "rib_reference.step"), no_such_parameter=3)
        # STEP files that crash OpenCASCADE (SIGSEGV): FreeCAD must survive them with the user's work
        bad = os.path.join(os.path.dirname(os.path.dirname(os.environ["FE_WB"])), "shared", "data", "bad-input")
        for name in ["step_unknown_entity_FOO.step", "step_dangling_ref.step", "brep_segv.brep"]:
            with self.assertRaisesRegex(ValueError, name):
                api.extract(self.part, os.path.join(bad, name))
        self.assertEqual(sorted(o.Name for o in self.doc.Objects), sorted(before))


# freecadcmd runs a script with __name__ set to its module name, not "__main__": run unconditionally.
try:
    suite = unittest.defaultTestLoader.loadTestsFromTestCase(App_)
    ok = unittest.TextTestRunner(verbosity=2).run(suite).wasSuccessful()
except Exception:
    traceback.print_exc()
    ok = False
sys.stdout.flush()
sys.stderr.flush()
os._exit(0 if ok else 1)
