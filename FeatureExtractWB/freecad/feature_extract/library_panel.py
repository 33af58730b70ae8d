"""The feature library's task panel (issue 13): every feature with its thumbnail, class, description
and meshing rules; the picked faces added as a new feature; the selected part searched with all of
them. The work is done by actions.add_picked_faces and actions.search_part (background, Cancel), as
the commands AddToLibrary and SearchLibrary do it, so the panel and the toolbar do the same thing."""
import os

import FreeCADGui as Gui
from PySide import QtCore, QtGui

from . import translate

current = None  # the open panel (the GUI tests drive it)


class LibraryPanel:
    def __init__(self, lib=None):
        global current
        from . import library
        current = self
        self.library = os.path.abspath(lib or library.default_library())
        self.entries = []
        self.form = QtGui.QWidget()
        self.form.setWindowTitle(translate("FeatureExtract", "Feature library"))
        lay = QtGui.QVBoxLayout(self.form)

        row = QtGui.QHBoxLayout()
        self.path = QtGui.QLineEdit(self.library)
        self.path.setReadOnly(True)
        self.path.setToolTip(translate("FeatureExtract", "The library: a folder of feature folders"))
        self.path.setMinimumWidth(60)  # the task panel is narrow: the path scrolls inside its field
        choose = QtGui.QPushButton("...")
        choose.setToolTip(translate("FeatureExtract", "Choose another library folder"))
        choose.setMaximumWidth(36)
        choose.clicked.connect(self.choose)
        row.addWidget(self.path, 1)
        row.addWidget(choose)
        lay.addLayout(row)

        self.list = QtGui.QListWidget()
        self.list.setIconSize(QtCore.QSize(72, 72))
        self.list.setWordWrap(True)
        self.list.setHorizontalScrollBarPolicy(QtCore.Qt.ScrollBarAlwaysOff)
        self.list.setTextElideMode(QtCore.Qt.ElideRight)
        self.list.currentRowChanged.connect(self._show_details)
        lay.addWidget(self.list, 1)
        self.details = QtGui.QLabel()
        self.details.setWordWrap(True)
        self.details.setTextInteractionFlags(QtCore.Qt.TextSelectableByMouse)
        lay.addWidget(self.details)

        add = QtGui.QGroupBox(translate("FeatureExtract", "New feature from picked faces"))
        form = QtGui.QFormLayout(add)
        form.setRowWrapPolicy(QtGui.QFormLayout.WrapLongRows)
        form.setFieldGrowthPolicy(QtGui.QFormLayout.AllNonFixedFieldsGrow)
        self.name = QtGui.QLineEdit()
        self.name.setPlaceholderText(translate("FeatureExtract", "e.g. mounting lug"))
        self.cls = QtGui.QLineEdit()
        self.cls.setPlaceholderText(translate("FeatureExtract", "e.g. lug"))
        self.description = QtGui.QLineEdit()
        self.description.setPlaceholderText(translate("FeatureExtract", "what the rule is for"))
        for w in (self.name, self.cls, self.description):
            w.setMinimumWidth(40)
        form.addRow(translate("FeatureExtract", "Name"), self.name)
        form.addRow(translate("FeatureExtract", "Class"), self.cls)
        form.addRow(translate("FeatureExtract", "Description"), self.description)
        self.add_button = QtGui.QPushButton(translate("FeatureExtract", "Add picked faces"))
        self.add_button.clicked.connect(self.add_picked)
        form.addRow(self.add_button)
        lay.addWidget(add)

        self.search_button = QtGui.QPushButton(translate("FeatureExtract", "Search the selected part"))
        self.search_button.setToolTip(translate("FeatureExtract", "Find every instance of every feature listed above on the "
                                                                 "selected solid (or the document's only solid)"))
        self.search_button.clicked.connect(self.search)
        lay.addWidget(self.search_button)
        self.status = QtGui.QLabel()
        self.status.setWordWrap(True)
        lay.addWidget(self.status)
        self.refresh()

    def refresh(self, select=None):
        """Lists the library's features; `select`: the folder to make current."""
        from . import library
        self.list.clear()
        self.entries = []
        try:
            self.entries = library.features(self.library) if os.path.isdir(self.library) else []
        except Exception as e:  # noqa: BLE001  (an unreadable library: said in the panel, nothing listed)
            self.status.setText(str(e))
        for f in self.entries:
            item = QtGui.QListWidgetItem(f"{f['name']}\n{f['class'] or '-'}")
            if f.get("thumbnail"):
                item.setIcon(QtGui.QIcon(f["thumbnail"]))
            item.setToolTip(f.get("rules") or "")
            self.list.addItem(item)
        if not self.entries:
            self.details.setText(translate("FeatureExtract", "No features in this folder yet: pick faces and add them."))
        rows = [i for i, f in enumerate(self.entries) if select and os.path.normpath(f["dir"]) == os.path.normpath(select)]
        if self.entries:
            self.list.setCurrentRow(rows[0] if rows else 0)

    def _show_details(self, row):
        if not 0 <= row < len(self.entries):
            return
        f = self.entries[row]
        s = f.get("search") or {}
        scales = f"{s.get('scale_min', 0.8):g} to {s.get('scale_max', 2.6):g} times its size"
        text = [f"<b>{_esc(f['name'])}</b> ({_esc(f['class'] or 'no class')})"]
        if f.get("description"):
            text.append(_esc(f["description"]))
        text.append(translate("FeatureExtract", "Meshing rules: ") + _esc(f.get("rules") or translate("FeatureExtract", "none")))
        text.append(translate("FeatureExtract", "Searched from ") + scales)
        self.details.setText("<br>".join(text))

    def choose(self, path=None):
        from . import library
        if path is None:
            path = QtGui.QFileDialog.getExistingDirectory(Gui.getMainWindow(), translate("FeatureExtract", "Feature library folder"),
                                                          self.library)
            if not path:
                return
        try:
            library.set_default_library(path)
        except Exception as e:  # noqa: BLE001
            self.status.setText(str(e))
            return
        self.library = os.path.abspath(path)
        self.path.setText(self.library)
        self.status.setText("")
        self.refresh()

    def _busy(self, busy):
        self.add_button.setEnabled(not busy)
        self.search_button.setEnabled(not busy)

    def add_picked(self):
        from . import actions, background
        name = self.name.text().strip()
        if not name:
            self.status.setText(translate("FeatureExtract", "Give the new feature a name first."))
            return
        self._busy(True)

        def done(kind, value):
            self._busy(False)
            if kind == "ok":
                self.status.setText(translate("FeatureExtract", "Added {name}.").format(name=name))
                self.name.clear()
                self.refresh(select=value)
            else:
                self.status.setText(actions.last_error or translate("FeatureExtract", "Nothing was added."))

        actions.last_error = None
        actions.add_picked_faces(name, self.cls.text().strip(), self.description.text().strip(), self.library, done)
        if background.running is None:  # refused before starting (the selection): said in the panel
            self._busy(False)
            self.status.setText(actions.last_error or "")

    def search(self):
        from . import actions, background
        self._busy(True)
        self.status.setText(translate("FeatureExtract", "Searching..."))

        def done(kind, value):
            self._busy(False)
            if kind == "ok":
                found = sum(len(f["matches"]) for f in value["features"])
                kinds = sum(1 for f in value["features"] if f["matches"])
                self.status.setText(translate("FeatureExtract", "{n} instances of {k} features found; see the report view.")
                                    .format(n=found, k=kinds))
            else:
                self.status.setText(actions.last_error or translate("FeatureExtract", "Cancelled; the document was not changed."))

        actions.last_error = None
        actions.search_part(self.library, done)
        if background.running is None:  # refused before starting (no solid): said in the panel
            self._busy(False)
            self.status.setText(actions.last_error or "")

    # --- task dialog protocol
    def getStandardButtons(self):
        return int(QtGui.QDialogButtonBox.Close)

    def reject(self):
        global current
        Gui.Control.closeDialog()
        current = None
        return True

    def accept(self):
        return self.reject()


def _esc(text):
    return str(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")

