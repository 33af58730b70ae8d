"""The Extract task panel: presets and every parameter (with unit and help as tooltip), a background
run with a progress bar and Cancel. The UI never waits on the computation: it runs on the workbench's
one background helper (background.py), which shows its progress in this panel's bar. When it
succeeds, a recorded (so replayable) `api.extract(...)` call adds the results, taking the computed
result from the api's cache."""
import FreeCAD as App
import FreeCADGui as Gui
from PySide import QtCore, QtGui

from . import actions, background, translate

PRESETS = {
    "Balanced": {},
    # 1/3-3x in scale bands (one more pass below 0.8 and one above 2.6, each judged with the usual
    # bounds relative to its band): slower, the part is described again for the small instances
    "Wide scale (1/3-3x)": {"scale_min": 1.0 / 3.0, "scale_max": 3.0},
    "Cylindrical (holes, lugs)": {"ridge_rut_spacing": 0.05},
    "Strict fit": {"accept_error": 0.03, "min_score": 0.8},
    "Fast (coarser)": {"dense_spacing": 0.02, "sparse_spacing": 0.05, "ransac_patience": 300},
}
PRESET_TIPS = {
    "Wide scale (1/3-3x)": "Instances from a third of the reference's size to three times it. Slower: one more "
                           "pass for the instances under 0.8x (the part is described finer) and one over 2.6x.",
}

def label_of(name, unit):
    """'shot_radius', 'x L' -> 'Shot radius (x L)': what the panel shows for a parameter."""
    text = name.replace("_", " ")
    text = text[0].upper() + text[1:]
    for word, shown in ((" si ", " SI "), ("Si ", "SI "), ("Shot", "SHOT"), (" shot ", " SHOT ")):
        text = text.replace(word, shown)
    return text + (f" ({unit})" if unit else "")


current = None  # the open panel (tests drive it)


class ExtractPanel:
    def __init__(self, target, references):
        import featureextract as fx
        global current
        current = self
        self.target = target
        self.references = references
        self.table = fx.param_table()
        self.running = None  # the background job of a run in progress
        self.cancel_requested = False
        self.outcome = None  # ("ok", result) / ("error", message) / ("cancelled", None)
        self.finished = False
        self.created = []

        self.form = QtGui.QWidget()
        self.form.setWindowTitle(translate("FeatureExtract", "Extract similar features"))
        lay = QtGui.QVBoxLayout(self.form)
        top = QtGui.QFormLayout()
        top.addRow(translate("FeatureExtract", "Target"), QtGui.QLabel(target.Label))
        self.ref_box = QtGui.QComboBox()
        for i, r in enumerate(references):
            self.ref_box.addItem(r.Label)
            n = len(r.Faces)
            self.ref_box.setItemData(i, f"{n} face{'' if n == 1 else 's'} of {r.Source.Label if r.Source else '?'}",
                                     QtCore.Qt.ToolTipRole)
        if references:  # the reference picked last is the one the user means (issue 11)
            self.ref_box.setCurrentIndex(max(range(len(references)), key=lambda i: references[i].ID))
        top.addRow(translate("FeatureExtract", "Reference"), self.ref_box)
        self.preset = QtGui.QComboBox()
        self.preset.addItems(list(PRESETS))
        for i, name in enumerate(PRESETS):
            if name in PRESET_TIPS:
                self.preset.setItemData(i, translate("FeatureExtract", PRESET_TIPS[name]), QtCore.Qt.ToolTipRole)
        self.preset.currentIndexChanged.connect(self._apply_preset)
        top.addRow(translate("FeatureExtract", "Preset"), self.preset)
        lay.addLayout(top)

        self.advanced = QtGui.QGroupBox(translate("FeatureExtract", "Advanced"))
        self.advanced.setToolTip(translate("FeatureExtract", "Every parameter; lengths are fractions of L, the reference diagonal"))
        self.advanced.setCheckable(True)
        self.advanced.setChecked(False)
        self.fields = {}
        groups = {}
        inner = QtGui.QWidget()
        inner_lay = QtGui.QVBoxLayout(inner)
        # grouped by the paper's steps as the core's table lists them (its "group" of each parameter)
        for row in self.table:
            title = row["group"]
            if title not in groups:
                box = QtGui.QGroupBox(translate("FeatureExtract", title))
                f = QtGui.QFormLayout(box)
                f.setRowWrapPolicy(QtGui.QFormLayout.WrapAllRows)  # each label above its field: the panel is narrow
                f.setFieldGrowthPolicy(QtGui.QFormLayout.AllNonFixedFieldsGrow)
                inner_lay.addWidget(box)
                groups[title] = f
        for row in self.table:
            if row["type"] == "bool":
                w = QtGui.QCheckBox()
                w.setChecked(row["default"] == "true")
            elif row["type"] == "int":
                w = QtGui.QSpinBox()
                w.setRange(0, 2_000_000_000)
                w.setValue(int(float(row["default"])))
            else:
                w = QtGui.QDoubleSpinBox()
                w.setDecimals(4)
                w.setRange(0.0, 1e6)
                w.setSingleStep(0.01)
                w.setValue(float(row["default"]))
            tip = row["help"] + (f" [{row['unit']}]" if row["unit"] else "") + f" (default {row['default']})"
            w.setToolTip(tip)
            label = QtGui.QLabel(label_of(row["name"], row["unit"]))
            label.setToolTip(tip + f" ({row['name']})")
            w.setMinimumWidth(80)
            w.setMaximumWidth(140)
            groups[row["group"]].addRow(label, w)
            self.fields[row["name"]] = w
        scroll = QtGui.QScrollArea()
        scroll.setWidget(inner)
        scroll.setWidgetResizable(True)
        scroll.setHorizontalScrollBarPolicy(QtCore.Qt.ScrollBarAlwaysOff)  # the fields fit the panel's width
        self.scroll = scroll
        scroll.setMinimumHeight(200)
        adv_lay = QtGui.QVBoxLayout(self.advanced)
        adv_lay.addWidget(scroll)
        self.advanced.toggled.connect(scroll.setVisible)
        scroll.setVisible(False)
        lay.addWidget(self.advanced)

        self.bar = QtGui.QProgressBar()
        self.bar.setRange(0, 100)
        self.status = QtGui.QLabel(translate("FeatureExtract", "Ready."))
        self.status.setWordWrap(True)
        buttons = QtGui.QHBoxLayout()
        self.run_button = QtGui.QPushButton(translate("FeatureExtract", "Run"))
        self.cancel_button = QtGui.QPushButton(translate("FeatureExtract", "Cancel"))
        self.cancel_button.setEnabled(False)
        self.run_button.clicked.connect(self.run)
        self.cancel_button.clicked.connect(self.request_cancel)
        buttons.addWidget(self.run_button)
        buttons.addWidget(self.cancel_button)
        lay.addWidget(self.bar)
        lay.addWidget(self.status)
        lay.addLayout(buttons)

    # --- parameters
    def _apply_preset(self):
        values = PRESETS[self.preset.currentText()]
        for row in self.table:
            w = self.fields[row["name"]]
            v = values.get(row["name"], row["default"])
            if isinstance(w, QtGui.QCheckBox):
                w.setChecked(v is True or v == "true")
            elif isinstance(w, QtGui.QSpinBox):
                w.setValue(int(float(v)))
            else:
                w.setValue(float(v))

    def parameters(self):
        """The parameters that differ from the engine's defaults."""
        out = {}
        for row in self.table:
            w = self.fields[row["name"]]
            if isinstance(w, QtGui.QCheckBox):
                v, d = w.isChecked(), row["default"] == "true"
            elif isinstance(w, QtGui.QSpinBox):
                v, d = w.value(), int(float(row["default"]))
            else:
                v, d = round(w.value(), 6), float(row["default"])
            if v != d:
                out[row["name"]] = v
        return out

    # --- the run
    def run(self):
        from . import api
        if self.running is not None:
            return
        if background.running is not None:  # a command's job (one at a time: the core is busy)
            self._finish(("error", translate("FeatureExtract", "Another FeatureExtract job is running; wait for it or cancel it.")))
            return
        ref = self.references[self.ref_box.currentIndex()]
        self.params = self.parameters()
        try:
            job = api.prepare(self.target, ref, **self.params)  # document access: main thread only
        except Exception as e:  # noqa: BLE001
            self._finish(("error", str(e)))
            return
        self.reference = ref
        self.job = job
        self.cancel_requested = False
        self.finished = False
        self.outcome = None
        self.run_button.setEnabled(False)
        self.cancel_button.setEnabled(True)
        self.status.setText(translate("FeatureExtract", "Running..."))
        self.bar.setValue(0)

        def done(kind, value):
            self.running = None
            self._finish((kind, value))

        self.running = background.start(None, None, lambda progress: api.run(job, progress), done, view=_PanelView(self))

    def request_cancel(self):
        self.cancel_requested = True
        self.status.setText(translate("FeatureExtract", "Cancelling..."))

    def _finish(self, outcome):
        self.outcome = outcome
        kind, value = outcome
        self.run_button.setEnabled(True)
        self.cancel_button.setEnabled(False)
        if kind == "ok":
            args = ", ".join(f"{k}={v!r}" for k, v in sorted(self.params.items()))
            t, r = self.target, self.reference
            command = (f"freecad.feature_extract.api.extract(App.getDocument('{t.Document.Name}').getObject('{t.Name}'), "
                       f"App.getDocument('{r.Document.Name}').getObject('{r.Name}'){', ' + args if args else ''})")
            from . import api
            try:
                Gui.addModule("freecad.feature_extract.api")
                if hasattr(Gui, "doCommandSkip"):  # FreeCAD >= 0.21: record only, add what was computed here
                    api._cache.pop(self.job.key, None)
                    Gui.doCommandSkip(command)
                    self.created = api.add_results(t, r, value)
                else:
                    # FreeCAD 0.20: the recorded call runs; it takes the result just computed from the
                    # api's cache (keyed by target shape, reference and parameters, so a target edited
                    # meanwhile is searched again rather than given a stale result)
                    Gui.doCommand(command)
                    self.created = api.results_for(t)
                msg = translate("FeatureExtract", "{n} similar feature(s) found in {s:.1f} s.").format(
                    n=len(value.matches), s=sum(x for _, x in value.timings))
                self.bar.setValue(100)
            except Exception as e:  # noqa: BLE001
                kind, msg = "error", str(e)
        elif kind == "cancelled":
            msg = translate("FeatureExtract", "Cancelled; the document was not changed.")
            self.bar.setValue(0)
        else:
            msg = value
        self.status.setText(msg)
        if kind == "error":
            actions.report_error(msg)
        else:
            App.Console.PrintMessage("FeatureExtract: " + msg + "\n")
        self.finished = True

    # --- task dialog protocol
    def getStandardButtons(self):
        return int(QtGui.QDialogButtonBox.Close)

    def reject(self):
        global current
        if self.running is not None:
            # the worker stops at its next progress report; its outcome is dropped (nothing is added)
            self.running.abandon()
            self.running = None
        Gui.Control.closeDialog()
        current = None
        return True

    def accept(self):
        return self.reject()


class _PanelView:
    """The panel's progress bar and Cancel button as the background job's view."""

    def __init__(self, panel):
        self.panel = panel

    def show(self, stage, fraction):
        self.panel.bar.setValue(int(100 * fraction))
        if stage:
            self.panel.bar.setFormat(f"{stage} %p%")

    def cancelled(self):
        return self.panel.cancel_requested

    def close(self):
        pass
