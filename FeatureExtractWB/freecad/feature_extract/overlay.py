"""Coin3D overlay of the samples and key points of a shape (the Tessellate command)."""
import FreeCADGui as Gui

_overlays = {}  # (document name, object name) -> SoSeparator in the scene graph


def _points_node(points, color, size):
    from pivy import coin
    sep = coin.SoSeparator()
    style = coin.SoDrawStyle()
    style.pointSize = size
    mat = coin.SoMaterial()
    mat.diffuseColor.setValue(*color)
    mat.emissiveColor.setValue(*color)
    coords = coin.SoCoordinate3()
    coords.point.setValues(0, len(points), [tuple(float(x) for x in p) for p in points])
    ps = coin.SoPointSet()
    ps.numPoints = len(points)
    for n in (style, mat, coords, ps):
        sep.addChild(n)
    return sep


def show(obj, description):
    """Dense samples (grey), sparse samples (blue) and key points (red) over `obj`."""
    from pivy import coin
    hide(obj)
    root = coin.SoSeparator()
    root.addChild(_points_node(description.dense_points, (0.55, 0.55, 0.55), 1.0))
    root.addChild(_points_node(description.sparse_points, (0.1, 0.3, 0.9), 3.0))
    root.addChild(_points_node(description.key_points, (0.9, 0.05, 0.05), 7.0))
    Gui.getDocument(obj.Document.Name).ActiveView.getSceneGraph().addChild(root)
    _overlays[(obj.Document.Name, obj.Name)] = root


def hide(obj):
    root = _overlays.pop((obj.Document.Name, obj.Name), None)
    if root is not None:
        try:
            Gui.getDocument(obj.Document.Name).ActiveView.getSceneGraph().removeChild(root)
        except Exception:
            pass
        return True
    return False


def shown(obj):
    return (obj.Document.Name, obj.Name) in _overlays
