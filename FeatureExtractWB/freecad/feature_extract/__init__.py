"""FeatureExtract for FreeCAD: App-side package (works in freecadcmd without a GUI).

Finds the C++ core's Python module (`featureextract`): the folder named by the
FEATUREEXTRACT_PYTHONPATH environment variable, else <repo>/build/python (built by ./setup.sh), else
wherever Python finds it (installed by `cmake --install`).
The headless API is `freecad.feature_extract.api`."""
import os
import sys

_HERE = os.path.dirname(os.path.realpath(__file__))
REPO = os.path.normpath(os.path.join(_HERE, "..", "..", ".."))  # the checkout, when run from one
# The icons and the shipped feature library: beside the workbench when installed (Mod/FeatureExtract/
# Resources), else the checkout's Resources.
_INSTALLED = os.path.normpath(os.path.join(_HERE, "..", "..", "Resources"))
RESOURCES = _INSTALLED if os.path.isdir(os.path.join(_INSTALLED, "icons")) else os.path.join(REPO, "Resources")
ICONS = os.path.join(RESOURCES, "icons")


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
