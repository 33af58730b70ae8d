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
