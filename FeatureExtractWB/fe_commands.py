"""Registers the FeatureExtract commands with FreeCAD.

FreeCAD's macro recorder writes `import <module>` for the module that called Gui.addCommand, named
after its file. Called from freecad/feature_extract/commands.py, that was `import commands`, which
no replayed macro could import (issue 11). This module sits at the top of the workbench's Mod folder,
which FreeCAD puts on sys.path, so a recorded macro's `import fe_commands` works; importing it again
registers nothing twice."""
import FreeCADGui as Gui

from freecad.feature_extract import commands

NAMES = list(commands.COMMANDS)
_known = set(Gui.listCommands())
for _name, _cls in commands.COMMANDS.items():
    if _name not in _known:
        Gui.addCommand(_name, _cls())
