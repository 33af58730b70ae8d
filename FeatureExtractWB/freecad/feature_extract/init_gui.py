"""Registers the FeatureExtract workbench (FreeCAD imports this module on start-up)."""
import FreeCADGui as Gui

from . import icon, translate


class FeatureExtractWorkbench(Gui.Workbench):
    MenuText = translate("FeatureExtract", "FeatureExtract")
    ToolTip = translate("FeatureExtract", "Find every region of a part similar to a reference feature")
    Icon = icon("FeatureExtract")

    def Initialize(self):
        import fe_commands  # registers the commands; lazy: the C++ core is loaded when the workbench is used
        names = fe_commands.NAMES
        self.appendToolbar("FeatureExtract", names)
        self.appendMenu("&FeatureExtract", names)

    def GetClassName(self):
        return "Gui::PythonWorkbench"


Gui.addWorkbench(FeatureExtractWorkbench())
