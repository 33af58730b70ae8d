"""GUI test of the feature library in the workbench (issue 13, item 4), under a virtual display:
  FE_MODELS=... FE_WB=... FE_LIB_SHOT=out.png QTWEBENGINE_DISABLE_SANDBOX=1 \
    xvfb-run -a -s "-screen 0 1280x1024x24" freecad tests/freecad/test_gui_library.py
Opens the library panel on a copy of two shipped features (thumbnails, rules), refuses to add
without picked faces, adds a rib picked on a part as a third feature (gmsh, in the background),
searches the part with the three (background, one cancelled run that changes nothing), checks the
per-feature groups, their colors on the part's faces and the overlaps in the report view, re-runs
from the toolbar command, saves and reopens, and saves a screenshot. Exits 0 when all checks pass."""
import os
import shutil
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.environ["FE_WB"]), "tests", "freecad"))
from gui_common import check, finish, report_view, use_workbench, wait_for  # noqa: E402


def main():
    use_workbench()
    import FreeCAD as App
    import FreeCADGui as Gui
    import Part
    from PySide import QtGui

    if "FeatureExtractWorkbench" not in Gui.listWorkbenches():
        import freecad.feature_extract.init_gui  # noqa: F401
    Gui.activateWorkbench("FeatureExtractWorkbench")
    from freecad.feature_extract import actions, api, background, commands, library, library_panel
    actions.INTERACTIVE = False
    prefs = App.ParamGet(library.PARAMS)
    saved_choice = prefs.GetString("Library", "")
    try:
        run(App, Gui, Part, QtGui, api, background, commands, library, library_panel)
    finally:  # the user's own choice of library back
        prefs.SetString("Library", saved_choice)


def run(App, Gui, Part, QtGui, api, background, commands, library, library_panel):

    report = report_view()
    check(report is not None, "report view found")

    def report_text():
        return report.toPlainText() if report is not None else ""

    work = tempfile.mkdtemp(prefix="fe_gui_library_")
    lib = os.path.join(work, "library")
    os.makedirs(lib)
    for d in ("rib", "boss"):
        shutil.copytree(os.path.join(library.SHIPPED, d), os.path.join(lib, d))

    doc = App.newDocument("gui_library")
    part = doc.addObject("Part::Feature", "Part")
    part.Shape = Part.read(os.path.join(os.environ["FE_MODELS"], "ribs_bosses.step"))
    doc.recompute()
    Gui.SendMsgToActiveView("ViewFit")

    # the panel: every feature with its thumbnail and rules
    Gui.runCommand("FE_Library")
    wait_for(lambda: library_panel.current is not None, 5)
    panel = library_panel.current
    check(panel is not None, "the Feature library command opens its panel")
    panel.choose(lib)
    check(library.default_library() == os.path.abspath(lib), "the chosen library is remembered in the preferences")
    check(panel.list.count() == 2, f"panel lists the library's 2 features ({panel.list.count()})")
    icons = [panel.list.item(i).icon() for i in range(panel.list.count())]
    check(all(not ic.isNull() and ic.availableSizes() for ic in icons), "each feature shows its thumbnail")
    panel.list.setCurrentRow([f["name"] for f in panel.entries].index("screw boss"))
    check("30 degrees" in panel.details.text() and "screw boss" in panel.details.text(),
          f"the selected feature's meshing rules are shown ({panel.details.text()[:80]!r})")

    # adding with nothing picked: a clear message in the panel, nothing added, document unchanged
    n0 = len(doc.Objects)
    Gui.Selection.clearSelection()
    panel.name.setText("rib copy")
    panel.add_picked()
    check("Select" in panel.status.text(), f"add without picked faces is refused in words ({panel.status.text()!r})")
    check(panel.list.count() == 2 and len(doc.Objects) == n0, "nothing added, document unchanged")

    # the first rib's faces picked and added (gmsh meshes it in the background)
    faces = [f"Face{i}" for i, f in enumerate(part.Shape.Faces, 1)
             if f.BoundBox.XMin >= 17 and f.BoundBox.XMax <= 33 and f.BoundBox.ZMin > -1e-3 and f.BoundBox.ZMax > 0.5]
    Gui.Selection.addSelection(part, faces)
    panel.cls.setText("rib")
    panel.description.setText("picked in the GUI test")
    panel.add_picked()
    check(background.running is not None, "adding runs in the background")
    ticks = wait_for(lambda: background.running is None, 180)
    check(ticks > 5, f"UI kept processing events while adding ({ticks} polls)")
    names = [f["name"] for f in panel.entries]
    check("rib copy" in names and panel.list.count() == 3, f"the new feature is listed ({names}; {panel.status.text()!r})")
    new = next((f for f in panel.entries if f["name"] == "rib copy"), None)
    check(new is not None and new.get("thumbnail") and os.path.isfile(new["thumbnail"]), "the new feature has a thumbnail")
    check(new is not None and panel.entries[panel.list.currentRow()]["name"] == "rib copy", "the new feature is made current")
    check(new is not None and os.path.isfile(os.path.join(new["dir"], "mesh.inp")), "the new feature has an FE mesh")
    check(len(doc.Objects) == n0, "adding to the library does not change the document")

    # a search cancelled: the document is not changed
    Gui.Selection.clearSelection()
    Gui.Selection.addSelection(part)
    panel.search()
    check(background.running is not None, "the search runs in the background")
    wait_for(lambda: background.running is None or background.running.state["progress"] > 0.05, 120)
    if background.running is not None:
        background.running.dialog.cancel()
    wait_for(lambda: background.running is None, 30)
    wait_for(lambda: False, 0.5)  # the report view shows a line on the next events
    check(len(doc.Objects) == n0, "a cancelled search leaves the document as it was")
    check("cancelled" in report_text(), "cancelling says so")

    # the search: one group per feature, in the feature's color, overlaps said
    panel.search()
    ticks = wait_for(lambda: background.running is None, 300)
    check(ticks > 5, f"UI kept processing events while searching ({ticks} polls)")
    wait_for(lambda: False, 0.5)
    groups = library.groups_for(part)
    labels = sorted(g.Label for g in groups)
    check(labels == ["rib copy on Part (5)", "rib on Part (5)", "screw boss on Part (2)"], f"one group per feature found ({labels})")
    for g in groups:
        colors = {tuple(round(c, 3) for c in r.Color[:3]) for r in g.Group}
        check(len(colors) == 1, f"{g.Label}: its instances share one color")
    check(len({tuple(round(c, 3) for c in g.Group[0].Color[:3]) for g in groups if g.Group}) == 3, "each feature has its own color")
    check(all(g.Rules for g in groups), "each group carries its feature's meshing rules")
    check("claimed by" in report_text(), "the faces two features claim are said in the report view")
    check("found" in panel.status.text(), f"the panel says what was found ({panel.status.text()!r})")
    wait_for(lambda: False, 0.5)  # deferred recolor
    boss = next(g for g in groups if g.LibraryFeature == "screw boss")
    dc = part.ViewObject.DiffuseColor
    want = tuple(round(c, 2) for c in boss.Group[0].Color[:3])
    check(len(dc) == len(part.Shape.Faces) and all(tuple(round(c, 2) for c in dc[f - 1][:3]) == want for f in boss.Group[0].Faces),
          "the boss's faces are colored in the boss feature's color")
    rib = next(g for g in groups if g.LibraryFeature == "rib")
    want = tuple(round(c, 2) for c in rib.Group[0].Color[:3])
    check(all(tuple(round(c, 2) for c in dc[f - 1][:3]) == want for f in rib.Group[0].Faces),
          "faces claimed by rib and rib copy show rib, the claim the report view keeps")
    first = sorted(o.Name for g in groups for o in g.Group)

    # the toolbar command, again: the groups are replaced, not added to, with clean labels
    Gui.Selection.clearSelection()
    Gui.Selection.addSelection(part)
    Gui.runCommand("FE_SearchLibrary")
    wait_for(lambda: background.running is None, 300)
    groups = library.groups_for(part)
    labels = sorted(g.Label for g in groups)
    check(labels == ["rib copy on Part (5)", "rib on Part (5)", "screw boss on Part (2)"], f"re-run replaces the groups ({labels})")
    check(len(api.results_for(part)) == 12 and sorted(o.Name for g in groups for o in g.Group) != first,
          f"re-run replaces the results ({len(api.results_for(part))})")
    check(not any(o.Label.endswith("001") for g in groups for o in g.Group), "re-run labels have no 001 suffix")

    # the screenshot: panel and colored part; the panel fits the task view (no horizontal scroll bar)
    Gui.Selection.clearSelection()
    scroll = panel.form.parentWidget()
    while scroll is not None and not isinstance(scroll, QtGui.QScrollArea):
        scroll = scroll.parentWidget()
    check(scroll is None or not scroll.horizontalScrollBar().isVisible(), "the panel fits the task view's width")
    Gui.ActiveDocument.ActiveView.viewIsometric()
    Gui.SendMsgToActiveView("ViewFit")
    wait_for(lambda: False, 0.5)
    shot = os.environ.get("FE_LIB_SHOT", os.path.join(work, "gui_library.png"))
    pix = QtGui.QPixmap.grabWindow(Gui.getMainWindow().winId()) if hasattr(QtGui.QPixmap, "grabWindow") else Gui.getMainWindow().grab()
    check(pix.save(shot), f"screenshot saved ({shot})")

    # save and reopen: the groups and their properties survive
    path = os.path.join(work, "library.FCStd")
    doc.saveAs(path)
    App.closeDocument(doc.Name)
    again = App.openDocument(path)
    p2 = again.getObject("Part")
    g2 = library.groups_for(p2)
    check(sorted(g.LibraryFeature for g in g2) == ["rib", "rib copy", "screw boss"] and len(api.results_for(p2)) == 12,
          "groups and results intact after reopening")
    panel.reject()
    check(library_panel.current is None and not Gui.Control.activeDialog(), "Close closes the panel")


finish("gui_library", main)
