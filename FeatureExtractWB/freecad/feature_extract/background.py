"""Long work off the GUI thread, with progress and Cancel: the one helper of the commands and the
task panels.

The work runs in a Python thread (the core releases the GIL) and gets a progress(stage, fraction)
callback that returns False once the user cancelled. A timer on the GUI thread shows the progress
in a view and, when the thread ends, calls done(kind, value) with kind "ok" (value: what the work
returned), "cancelled" or "error" (value: the message). Document changes belong in done(), on the
GUI thread. The view is a progress dialog with Cancel (DialogView, the commands') or the task
panel's own progress bar and Cancel button (any object with show, cancelled and close)."""
import threading

import FreeCADGui as Gui

from . import translate

running = None  # the job in progress, one at a time (commands are unavailable meanwhile; tests wait on it)


class DialogView:
    """A progress dialog with Cancel over the main window."""

    def __init__(self, title, label):
        from PySide import QtGui
        self.label = label
        self.dialog = QtGui.QProgressDialog(label, translate("FeatureExtract", "Cancel"), 0, 100, Gui.getMainWindow())
        self.dialog.setWindowTitle(title)
        self.dialog.setMinimumDuration(0)

    def show(self, stage, fraction):
        self.dialog.setValue(int(100 * fraction))
        if stage:
            self.dialog.setLabelText(f"{self.label}\n{stage}")

    def cancelled(self):
        return self.dialog.wasCanceled()

    def close(self):
        self.dialog.close()


class Job:
    def __init__(self, work, done, view):
        from PySide import QtCore
        self.state = {"stage": "", "progress": 0.0, "outcome": None, "cancel": False}
        self.view = view
        self.done = done
        self.thread = threading.Thread(target=self._work, args=(work,), daemon=True)
        self.timer = QtCore.QTimer()
        self.timer.timeout.connect(self._poll)

    @property
    def dialog(self):
        """The progress dialog, for a job shown in one."""
        return getattr(self.view, "dialog", None)

    def progress(self, stage, fraction):
        self.state["stage"], self.state["progress"] = stage, fraction
        return not self.state["cancel"]

    def cancel(self):
        """Asks the work to stop at its next progress report (done() then gets "cancelled")."""
        self.state["cancel"] = True

    def _work(self, work):
        import featureextract as fx
        try:
            self.state["outcome"] = ("ok", work(self.progress))
        except fx.Cancelled:
            self.state["outcome"] = ("cancelled", None)
        except Exception as e:  # noqa: BLE001  (shown to the user as a sentence)
            self.state["outcome"] = ("error", str(e))

    def _end(self):
        global running
        self.timer.stop()
        self.view.close()
        if running is self:
            running = None

    def _poll(self):
        self.view.show(self.state["stage"], self.state["progress"])
        if self.view.cancelled():
            self.cancel()
        if self.thread.is_alive():
            return
        self._end()
        kind, value = self.state["outcome"] or ("error", "the work stopped without a result")
        self.done(kind, value)

    def abandon(self, timeout=2.0):
        """Stops the work and drops its outcome: done() is not called (a panel closed while running)."""
        self.cancel()
        self.thread.join(timeout=timeout)
        self._end()

    def start(self):
        global running
        running = self
        self.thread.start()
        self.timer.start(100)
        return self


def start(title, label, work, done, view=None):
    """Runs work(progress) in the background; done(kind, value) on the GUI thread when it ends. The
    progress shows in view, else in a progress dialog titled title, saying label."""
    return Job(work, done, view or DialogView(title, label)).start()
