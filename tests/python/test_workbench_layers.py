"""The workbench's modules import one way (issue 11, layout by role): each imports only modules of
the layers below its own, function-level imports included, so no module dodges a cycle by importing
inside a function. Read from the source (ast), so it needs no FreeCAD."""
import ast
import os

PACKAGE = os.path.join(os.path.dirname(__file__), "..", "..", "FeatureExtractWB", "freecad", "feature_extract")

# lowest first; a module may import from the layers before its own
LAYERS = [
    ["__init__"],                    # icons, translate, where the resources are
    ["model"],                       # what a document holds, no GUI, no core; the proxies' base
    ["view_providers"],              # how the objects look: view providers, face and element colors
    ["objects", "overlay"],          # App-side document objects (they answer older documents' view
                                     # provider names from view_providers); the samples overlay
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
    # objects' lazy __getattr__ for older documents imports view_providers: it counts too
    assert "view_providers" in imported("objects")


def test_objects_are_app_only():
    # document objects work in freecadcmd: no GUI module anywhere in their text (issue 11, layout by role)
    for name in ("model", "objects"):
        tree = ast.parse(open(os.path.join(PACKAGE, name + ".py")).read())
        used = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        used |= {(n.module or "").split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
        assert not used & {"FreeCADGui", "PySide", "PySide2", "pivy"}, f"{name}.py imports {used}"
        assert not [n.name for n in ast.walk(tree) if isinstance(n, ast.ClassDef) and n.name.startswith("ViewProvider")]


def test_old_view_provider_paths_are_answered():
    # documents saved before the move name freecad.feature_extract.objects.ViewProvider*: objects
    # must answer every one of them with a class that view_providers defines
    tree = ast.parse(open(os.path.join(PACKAGE, "objects.py")).read())
    moved = next(ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign)
                 and any(getattr(t, "id", None) == "_MOVED_TO_VIEW_PROVIDERS" for t in n.targets))
    assert any(isinstance(n, ast.FunctionDef) and n.name == "__getattr__" for n in tree.body)
    vp = ast.parse(open(os.path.join(PACKAGE, "view_providers.py")).read())
    defined = {n.name for n in vp.body if isinstance(n, ast.ClassDef)}
    assert set(moved) == {"ViewProviderReference", "ViewProviderResult", "ViewProviderFeatureMesh"} <= defined
