"""The workbench's modules import one way (issue 11, layout by role): each imports only modules of
the layers below its own, function-level imports included, so no module dodges a cycle by importing
inside a function. Read from the source (ast), so it needs no FreeCAD."""
import ast
import os

PACKAGE = os.path.join(os.path.dirname(__file__), "..", "..", "FeatureExtractWB", "freecad", "feature_extract")

# lowest first; a module may import from the layers before its own
LAYERS = [
    ["__init__"],                    # icons, translate, where the resources are
    ["model"],                       # what a document holds, no GUI, no core
    ["objects", "overlay"],          # document objects and their view providers; the samples overlay
    ["api"],                         # the headless API (freecadcmd, macros)
    ["library"],                     # the feature library on top of the API
    ["background"],                  # the one background-job helper
    ["actions"],                     # what the GUI does: messages, selection, the library's actions
    ["taskpanel", "library_panel"],  # task panels
    ["commands"],                    # toolbar commands, one base class
    ["init_gui"],                    # the workbench
]


def modules():
    return sorted(f[:-3] for f in os.listdir(PACKAGE) if f.endswith(".py"))


def imported(name):
    """The package's modules that module `name` imports, anywhere in its text."""
    tree = ast.parse(open(os.path.join(PACKAGE, name + ".py")).read())
    mods = set(modules())
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level == 1 or base.startswith("freecad.feature_extract"):
                sub = base.split(".")[-1] if node.level == 1 else base[len("freecad.feature_extract"):].lstrip(".")
                if sub:
                    out.add(sub)
                else:  # from . import x: a module, or a name of __init__
                    out |= {a.name if a.name in mods else "__init__" for a in node.names}
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("freecad.feature_extract."):
                    out.add(a.name.split(".")[2])
    out.discard(name)
    return out


def test_every_module_has_a_layer():
    placed = [m for layer in LAYERS for m in layer]
    assert sorted(placed) == modules(), "a new module needs its place in LAYERS"


def test_imports_go_down_only():
    level = {m: i for i, layer in enumerate(LAYERS) for m in layer}
    wrong = [(m, d) for m in modules() for d in sorted(imported(m)) if level[d] >= level[m]]
    assert not wrong, f"imports that go up or sideways (module, imported): {wrong}"


def test_the_check_sees_function_level_imports():
    # the commands import the task panels inside Activated(); that must count
    assert "taskpanel" in imported("commands") and "library_panel" in imported("commands")
    assert "model" in imported("api")
