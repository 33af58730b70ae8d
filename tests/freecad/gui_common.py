"""What the GUI tests share (run by FreeCAD under Xvfb): checks that count failures, the workbench
under test on the path, waiting while the GUI processes events, the report view, the exit status.
The tests import it from <repo>/tests/freecad, found beside FE_WB (<repo>/FeatureExtractWB)."""
import os
import sys
import time
import traceback

failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    sys.stdout.flush()
    if not cond:
        failures.append(what)


def use_workbench():
    """The workbench in FE_WB, not another checkout's that the user's Mod folder may link to."""
    sys.path.insert(0, os.environ["FE_WB"])
    import freecad
    if os.path.join(os.environ["FE_WB"], "freecad") not in freecad.__path__:
        freecad.__path__.append(os.path.join(os.environ["FE_WB"], "freecad"))


def wait_for(cond, seconds):
    """Processes GUI events until cond() or the time is up; returns how many times it polled."""
    from PySide import QtGui
    end = time.time() + seconds
    ticks = 0
    while not cond() and time.time() < end:
        QtGui.QApplication.processEvents()
        time.sleep(0.02)
        ticks += 1
    return ticks


def report_view():
    """FreeCAD's report view widget, or None."""
    import FreeCADGui as Gui
    from PySide import QtGui
    found = None
    for cls in (QtGui.QTextEdit, QtGui.QPlainTextEdit):
        for w in Gui.getMainWindow().findChildren(cls):
            if "report" in (w.objectName() or "").lower():
                found = w
    return found


def finish(name, main):
    """Runs main(), then exits FreeCAD (it does not exit by itself) with 0 when every check passed."""
    try:
        main()
    except Exception:
        traceback.print_exc()
        failures.append("exception")
    print(f"{0 if failures else 1} passed, {1 if failures else 0} failed: {name}")
    sys.stdout.flush()
    os._exit(1 if failures else 0)


def compare_to_reference(image, name, tolerance=0.02):
    """Compares a QImage with the stored tests/freecad/reference/<name>.png (as freecad.gears does
    with its screenshots): (the fraction of pixels that differ by more than 48 in a channel, or 1.0
    when the sizes differ, a sentence). FE_UPDATE_REFERENCE=1 stores the image as the new reference;
    otherwise the image is kept beside the build's screenshots (FE_SHOT's folder) to look at."""
    from PySide import QtGui
    here = os.path.dirname(os.path.abspath(__file__))
    path = os.path.join(here, "reference", name + ".png")
    if os.environ.get("FE_UPDATE_REFERENCE"):
        image.save(path)
    out = os.path.join(os.path.dirname(os.environ.get("FE_SHOT", path)), name + "_actual.png")
    image.save(out)
    ref = QtGui.QImage(path)
    if ref.isNull():
        return 1.0, f"no reference image {path}"
    if ref.size() != image.size():
        return 1.0, f"{image.width()}x{image.height()} against the reference's {ref.width()}x{ref.height()} ({out})"
    a, b = image.convertToFormat(QtGui.QImage.Format_RGB32), ref.convertToFormat(QtGui.QImage.Format_RGB32)
    differ = total = 0
    for y in range(0, a.height(), 2):
        for x in range(0, a.width(), 2):
            p, q = a.pixel(x, y), b.pixel(x, y)
            total += 1
            if any(abs(((p >> s) & 255) - ((q >> s) & 255)) > 48 for s in (0, 8, 16)):
                differ += 1
    frac = differ / max(1, total)
    return frac, f"{100 * frac:.2f} % of pixels differ from {path} (at most {100 * tolerance:.0f} %; actual: {out})"
