"""FeatureExtract for FreeCAD: App-side package (works in freecadcmd without a GUI).

Finds the C++ core's Python module (`featureextract`, built into <repo>/build/python by ./setup.sh, or
the folder named by the FEATUREEXTRACT_PYTHONPATH environment variable) and puts it on sys.path.
The headless API is `freecad.feature_extract.api`."""
import os
import sys

_HERE = os.path.dirname(os.path.realpath(__file__))
REPO = os.path.normpath(os.path.join(_HERE, "..", "..", ".."))
ICONS = os.path.join(REPO, "Resources", "icons")


def _native_path():
    for p in (os.environ.get("FEATUREEXTRACT_PYTHONPATH"), os.path.join(REPO, "build", "python")):
        if p and os.path.isdir(os.path.join(p, "featureextract")):
            return p
    return None


_p = _native_path()
if _p and _p not in sys.path:
    sys.path.insert(0, _p)


def icon(name):
    return os.path.join(ICONS, name + ".svg")


def translate(context, text):
    """Qt translation when a GUI is up; the text itself otherwise (translations-ready strings)."""
    try:
        from PySide import QtCore
        return QtCore.QCoreApplication.translate(context, text)
    except Exception:
        return text
