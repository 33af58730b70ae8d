"""The workbench's commands. Each one that changes the document goes through Gui.doCommand with a
plain call of `freecad.feature_extract.api`, so the macro recorder captures a replayable script."""
import os

import FreeCAD as App
import FreeCADGui as Gui

from . import actions, icon, translate


class BackgroundCommand:
    """A command whose work runs in the background (background.py): available while a document is
    open and no other background job runs, since one progress at a time is what a user follows."""

    def IsActive(self):
        from . import background
        return App.ActiveDocument is not None and background.running is None


class Tessellate(BackgroundCommand):
    def GetResources(self):
        return {"Pixmap": icon("Tessellate"), "MenuText": translate("FeatureExtract", "Show samples and key points"),
                "ToolTip": translate("FeatureExtract", "Toggle an overlay of the dense and sparse samples (grey, blue) "
                                                       "and key points (red) of the selected solid")}

    def Activated(self):
        from . import overlay
        obj = actions.selected_solid()
        if obj is None:
            actions.report_error(translate("FeatureExtract", "Select a solid (a part with faces) first."))
            return
        if overlay.shown(obj):
            overlay.hide(obj)
            return
        import featureextract as fx
        from . import api, background
        refs = actions.references(obj.Document)
        try:  # the shape is read here, on the GUI thread; describing it (seconds on a real part) is not
            L = api.reference_shape(refs[0]).BoundBox.DiagonalLength if refs else obj.Shape.BoundBox.DiagonalLength / 5
            brep = api.target_shape(obj).exportBrepToString()
        except Exception as e:  # noqa: BLE001  (shown to the user as a sentence)
            actions.report_error(str(e))
            return

        def work(progress):
            rel, absolute = fx.tessellation_for_feature(L)
            mesh = fx.read_brep_string(brep, obj.Label, rel, absolute)
            return mesh, fx.describe(mesh, fx.Description.Role.Target, L, fx.Params(), progress)

        def done(kind, value):
            if kind == "error":
                actions.report_error(value)
                return
            try:
                alive = obj.Document is not None
            except Exception:  # noqa: BLE001  (the object was deleted meanwhile)
                alive = False
            if kind == "cancelled" or not alive:
                return
            mesh, d = value
            overlay.show(obj, d)
            App.Console.PrintMessage(
                f"FeatureExtract: {obj.Label}: {mesh.triangles.shape[0]} triangles, {d.dense_points.shape[0]} dense and "
                f"{d.sparse_points.shape[0]} sparse samples, {d.key_points.shape[0]} key points (feature size {L:.2f})\n")

        background.start(translate("FeatureExtract", "Show samples and key points"),
                         translate("FeatureExtract", "Sampling and describing {name}...").format(name=obj.Label), work, done)


class PickReference:
    def GetResources(self):
        return {"Pixmap": icon("PickReference"), "MenuText": translate("FeatureExtract", "Pick reference feature"),
                "ToolTip": translate("FeatureExtract", "Make the faces selected on a solid a persistent reference feature")}

    def IsActive(self):
        return App.ActiveDocument is not None

    def Activated(self):
        obj, names = actions.picked_faces()
        if obj is None:
            actions.report_error(names)
            return
        actions.do(f"freecad.feature_extract.api.make_reference(App.getDocument('{obj.Document.Name}')"
            f".getObject('{obj.Name}'), {names!r})")


class SaveReference:
    def GetResources(self):
        return {"Pixmap": icon("SaveReference"), "MenuText": translate("FeatureExtract", "Save reference as BREP"),
                "ToolTip": translate("FeatureExtract", "Write the selected reference feature's faces to a BREP file")}

    def IsActive(self):
        return App.ActiveDocument is not None and bool(actions.references(App.ActiveDocument))

    def Activated(self):
        from PySide import QtGui
        sel = [s.Object for s in Gui.Selection.getSelectionEx() if s.Object in actions.references(s.Object.Document)]
        refs = sel or actions.references(App.ActiveDocument)
        path, _ = QtGui.QFileDialog.getSaveFileName(Gui.getMainWindow(), translate("FeatureExtract", "Save reference"),
                                                    refs[0].Label + ".brep", "BREP (*.brep *.brp)")
        if not path:
            return
        actions.do(f"freecad.feature_extract.api.save_reference(App.getDocument('{refs[0].Document.Name}')"
            f".getObject('{refs[0].Name}'), {path!r})")


class Extract:
    def GetResources(self):
        return {"Pixmap": icon("Extract"), "MenuText": translate("FeatureExtract", "Extract similar features"),
                "ToolTip": translate("FeatureExtract", "Find every region of the selected solid similar to a reference feature")}

    def IsActive(self):
        return App.ActiveDocument is not None and Gui.Control.activeDialog() is False

    def Activated(self):
        from .taskpanel import ExtractPanel
        doc = App.ActiveDocument
        refs = actions.references(doc)
        if not refs:
            actions.report_error(translate("FeatureExtract", "Pick a reference feature first (select faces, then Pick reference)."))
            return
        target = actions.selected_solid() or refs[0].Source
        if target is None:
            actions.report_error(translate("FeatureExtract", "Select the solid to search."))
            return
        Gui.Control.showDialog(ExtractPanel(target, refs))


class PlaceMesh(BackgroundCommand):
    """Runs the extraction with a reference feature folder's geometry in the background (progress
    dialog with Cancel), then places the feature's FE mesh on every instance by a recorded
    `api.place_meshes(...)` call."""

    def GetResources(self):
        return {"Pixmap": icon("PlaceMesh"), "MenuText": translate("FeatureExtract", "Place feature FE meshes"),
                "ToolTip": translate("FeatureExtract", "Find the instances of a reference feature folder (geometry + FE mesh + "
                                                       "meshing specification) on the selected solid and place its mesh on each, "
                                                       "colored by element quality")}

    def Activated(self, feature_dir=None):
        from PySide import QtGui
        from . import RESOURCES, api
        target = actions.selected_solid()
        if target is None:
            actions.report_error(translate("FeatureExtract", "Select the solid to mesh first."))
            return
        if feature_dir is None:
            feature_dir = QtGui.QFileDialog.getExistingDirectory(
                Gui.getMainWindow(), translate("FeatureExtract", "Reference feature folder (with feature.json)"),
                os.path.join(RESOURCES, "library"))
            if not feature_dir:
                return
        try:
            import featureextract as fx
            feature = fx.read_feature(feature_dir)
            job = api.prepare(target, feature.geometry_path)
        except Exception as e:  # noqa: BLE001
            actions.report_error(str(e))
            return

        def placed(_):
            actions.do(f"freecad.feature_extract.api.place_meshes(App.getDocument('{target.Document.Name}')"
                f".getObject('{target.Name}'), {feature_dir!r})")
            meshes = api.meshes_for(target)
            App.Console.PrintMessage(  # the user sees that it worked, and where (issue 11)
                f"FeatureExtract: {len(meshes)} FE mesh(es) of {os.path.basename(os.path.normpath(feature_dir))} "
                f"placed on {target.Label} ({sum(m.FemMesh.FaceCount + m.FemMesh.VolumeCount for m in meshes)} elements)\n")

        actions.start(translate("FeatureExtract", "Place feature FE meshes"),
                      translate("FeatureExtract", "Finding the instances of {name}...").format(name=feature.name),
                      lambda progress: api.run(job, progress), placed)


class MeshPart(BackgroundCommand):
    """One FE mesh of the whole selected solid with the rules of one or more feature folders (issue 12):
    `featureextract mesh-part` runs in the background (progress dialog with Cancel), then a recorded
    `api.mesh_part(...)` adds the mesh and a CalculiX analysis that the FEM workbench solves."""

    def GetResources(self):
        return {"Pixmap": icon("PlaceMesh"), "MenuText": translate("FeatureExtract", "Mesh part with feature rules"),
                "ToolTip": translate("FeatureExtract", "Mesh the whole selected solid: every instance of the chosen reference "
                                                       "features gets its feature's FE mesh, gmsh meshes the rest (conforming, "
                                                       "tetrahedra inside), and a CalculiX analysis is set up (support, bolt "
                                                       "loads, steel)")}

    @staticmethod
    def feature_folders(folder):
        """The folder itself if it is a feature folder, else its feature subfolders (a library)."""
        if os.path.isfile(os.path.join(folder, "feature.json")):
            return [folder]
        return sorted(os.path.join(folder, d) for d in os.listdir(folder)
                      if os.path.isfile(os.path.join(folder, d, "feature.json")))

    def Activated(self, folder=None):
        from PySide import QtGui
        from . import RESOURCES, api
        target = actions.selected_solid()
        if target is None:
            actions.report_error(translate("FeatureExtract", "Select the solid to mesh first."))
            return
        if folder is None:
            folder = QtGui.QFileDialog.getExistingDirectory(
                Gui.getMainWindow(), translate("FeatureExtract", "A feature folder, or a folder of feature folders"),
                os.path.join(RESOURCES, "library"))
            if not folder:
                return
        dirs = self.feature_folders(folder) if os.path.isdir(folder) else []
        if not dirs:
            actions.report_error(translate("FeatureExtract", "{folder}: no feature.json there, nor in its subfolders.").format(folder=folder))
            return
        try:
            shape = api.target_shape(target)
        except Exception as e:  # noqa: BLE001
            actions.report_error(str(e))
            return

        def meshed(_):
            actions.do(f"freecad.feature_extract.api.mesh_part(App.getDocument('{target.Document.Name}')"
                f".getObject('{target.Name}'), {dirs!r})")
            meshes = [o for o in target.Document.Objects if o.Name.startswith("PartMesh")]
            if meshes:
                m = meshes[-1].FemMesh
                App.Console.PrintMessage(f"FeatureExtract: {target.Label} meshed whole: {m.NodeCount} nodes, "
                                         f"{m.VolumeCount or m.FaceCount} elements; solve it in the FEM workbench\n")

        actions.start(translate("FeatureExtract", "Mesh part with feature rules"),
                      translate("FeatureExtract", "Meshing {name} with {n} feature(s)...").format(name=target.Label, n=len(dirs)),
                      lambda progress: api.compute_part_mesh(target, dirs, progress=progress, shape=shape), meshed)


class AddToLibrary(BackgroundCommand):
    """The faces picked on a solid become a new feature of the library (geometry, FE mesh by gmsh,
    feature.json, thumbnail), made in the background by `featureextract library add`. The document is
    not changed."""

    def GetResources(self):
        return {"Pixmap": icon("AddToLibrary"), "MenuText": translate("FeatureExtract", "Add picked faces to the library"),
                "ToolTip": translate("FeatureExtract", "Make the faces selected on a solid a new feature of the feature library, "
                                                       "with an FE mesh and a thumbnail")}

    def Activated(self):
        actions.add_picked_faces()


class SearchLibrary(BackgroundCommand):
    """Searches the selected solid for every feature of the library in the background (progress
    dialog with Cancel), then records one result group per feature found, colored per feature, by a
    recorded `library.search(...)` call."""

    def GetResources(self):
        return {"Pixmap": icon("SearchLibrary"), "MenuText": translate("FeatureExtract", "Search the part with the library"),
                "ToolTip": translate("FeatureExtract", "Find every instance of every feature of the feature library on the "
                                                       "selected solid; one result group per feature, in its own color")}

    def Activated(self):
        actions.search_part()


class Library:
    def GetResources(self):
        return {"Pixmap": icon("Library"), "MenuText": translate("FeatureExtract", "Feature library"),
                "ToolTip": translate("FeatureExtract", "The library of reference features: thumbnails and meshing rules; "
                                                       "add picked faces to it, search a part with it")}

    def IsActive(self):
        return Gui.Control.activeDialog() is False

    def Activated(self):
        from .library_panel import LibraryPanel
        Gui.Control.showDialog(LibraryPanel())


class ClearColors:
    def GetResources(self):
        return {"Pixmap": icon("ClearColors"), "MenuText": translate("FeatureExtract", "Clear result colors"),
                "ToolTip": translate("FeatureExtract", "Give every searched part its plain color back (results are kept)")}

    def IsActive(self):
        return App.ActiveDocument is not None

    def Activated(self):
        from .model import RESULT_GROUP, results_for
        from .view_providers import clear_colors
        group = App.ActiveDocument.getObject(RESULT_GROUP)
        targets = {r.Target.Name: r.Target for r in (group.Group if group else [])
                   if getattr(r, "Target", None) is not None}
        for t in targets.values():
            clear_colors(t)
            for r in results_for(t):
                r.ViewObject.Visibility = False


COMMANDS = {"FE_Tessellate": Tessellate, "FE_PickReference": PickReference, "FE_SaveReference": SaveReference,
            "FE_Extract": Extract, "FE_PlaceMesh": PlaceMesh, "FE_MeshPart": MeshPart, "FE_Library": Library,
            "FE_AddToLibrary": AddToLibrary, "FE_SearchLibrary": SearchLibrary, "FE_ClearColors": ClearColors}

