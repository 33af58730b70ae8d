"""Long work off the GUI thread, with a progress dialog and Cancel (the commands' one helper).

The work runs in a Python thread (the core releases the GIL) and gets a progress(stage, fraction)
callback; a timer on the GUI thread moves the dialog and, when the thread ends, calls
done(kind, value) with kind "ok" (value: what the work returned), "cancelled" or "error" (value: the
message). Document changes belong in done(), on the GUI thread."""
import threading

import FreeCADGui as Gui

from . import translate

running = None  # the job in progress (the GUI tests wait on it)


class Job:
    def __init__(self, title, label, work, done):
        from PySide import QtCore, QtGui
        self.state = {"stage": "", "progress": 0.0, "outcome": None, "cancel": False}
        self.dialog = QtGui.QProgressDialog(label, translate("FeatureExtract", "Cancel"), 0, 100, Gui.getMainWindow())
        self.dialog.setWindowTitle(title)
        self.dialog.setMinimumDuration(0)
        self.label = label
        self.done = done
        self.thread = threading.Thread(target=self._work, args=(work,), daemon=True)
        self.timer = QtCore.QTimer()
        self.timer.timeout.connect(self._poll)

    def progress(self, stage, fraction):
        self.state["stage"], self.state["progress"] = stage, fraction
        return not self.state["cancel"]

    def _work(self, work):
        import featureextract as fx
        try:
            self.state["outcome"] = ("ok", work(self.progress))
        except fx.Cancelled:
            self.state["outcome"] = ("cancelled", None)
        except Exception as e:  # noqa: BLE001  (shown to the user as a sentence)
            self.state["outcome"] = ("error", str(e))

    def _poll(self):
        global running
        self.dialog.setValue(int(100 * self.state["progress"]))
        if self.state["stage"]:
            self.dialog.setLabelText(f"{self.label}\n{self.state['stage']}")
        if self.dialog.wasCanceled():
            self.state["cancel"] = True
        if self.thread.is_alive():
            return
        self.timer.stop()
        self.dialog.close()
        running = None
        kind, value = self.state["outcome"] or ("error", "the work stopped without a result")
        self.done(kind, value)

    def start(self):
        global running
        running = self
        self.thread.start()
        self.timer.start(100)
        return self


def start(title, label, work, done):
    """Runs work(progress) in the background; done(kind, value) on the GUI thread when it ends."""
    return Job(title, label, work, done).start()
