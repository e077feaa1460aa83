"""The frame of the add-on's long operators (jobs) and where they write.

A job's `prepare` reads the settings and checks them on the main thread and returns the work, a
function of a `JobProgress` that touches no Blender data (so that it can run in a thread);
`finish` brings its result into the scene on the main thread. From the UI (invoke) the work runs
on a thread while a modal timer shows its progress and ESC cancels it; from scripts (execute) it
runs on the calling thread. A job whose main-thread part is long (the Cycles renders of the
check: bpy may only be called from the main thread) gives it as `finish_steps`, which the timer
runs one step at a time, showing progress and taking ESC between steps. A job that fails or is
cancelled adds nothing."""

from __future__ import annotations

import tempfile
import threading
import warnings
from collections.abc import Callable, Generator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import bpy
import occlux
from bpy.props import IntProperty


def output_dir(settings) -> Path:
    """The output folder: `//` is the .blend file's folder, for an unsaved file the temporary
    folder (so the default `//occlux/` is TMP/occlux/: `unsaved_output`)."""
    raw = settings.output_dir or "//occlux/"
    if raw.startswith("//") and not bpy.data.filepath:
        return Path(tempfile.gettempdir()) / raw[2:]
    return Path(bpy.path.abspath(raw))


def unsaved_output(settings) -> str:
    """Where the output goes when it is not where the panel's Output says (`//` of an unsaved
    .blend file: a temporary folder), as the panel and the jobs' reports say it; "" otherwise."""
    raw = settings.output_dir or "//occlux/"
    if not raw.startswith("//") or bpy.data.filepath:
        return ""
    return f"the .blend file is unsaved: Output {raw} is {output_dir(settings)}"


def report_dir(settings) -> Path:
    """Beside the .blend file; the output folder for an unsaved file."""
    return Path(bpy.path.abspath("//")) if bpy.data.filepath else output_dir(settings)


# The core's messages name the CLI's flags and the scene file's keys; in Blender they are the
# panel's settings (the Device menu), or the panel has none (a replacement for non-finite
# voxels): then the message says what to do instead.
PANEL_WORDS = {
    "--device cpu": "Device: CPU in the Occlux panel",
    "--device gpu": "Device: GPU in the Occlux panel",
    "unless a replacement value is given (scene key volume.replace_non_finite)": (
        "(the Occlux panel has no replacement for them: replace them in the file, or load it "
        "with the occlux CLI and a scene file's volume.replace_non_finite)"
    ),
}


def panel_words(message: str) -> str:
    """A core message with the CLI's flags and scene keys named as the panel's settings."""
    for flag, setting in PANEL_WORDS.items():
        message = message.replace(flag, setting)
    return message


def run_recording(work: Callable[[JobProgress], Any], progress: JobProgress) -> tuple[Any, list]:
    """Runs the work and returns its result with the core's notices (its RuntimeWarnings, e.g.
    the CPU used for want of a GPU adapter), in the panel's words. One job runs at a time, so
    recording the warnings process-wide catches only this job's."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        result = work(progress)
    notices = [panel_words(str(w.message)) for w in caught if w.category is RuntimeWarning]
    return result, notices


class JobProgress:
    """The progress callback the core calls, from its own threads: it only records (no Blender
    calls off the main thread) and answers False once cancelled, which stops the core."""

    def __init__(self, cancel_after: int = 0) -> None:
        self.done = 0
        self.total = 1
        self.calls = 0
        self.steps_done = 0  # of the main-thread part, counted by the job
        self.cancel_after = cancel_after
        self.cancel = threading.Event()
        self.lock = threading.Lock()

    def __call__(self, done: int, total: int) -> bool:
        with self.lock:
            self.done, self.total = done, max(total, 1)
            self.calls += 1
            if self.cancel_after and self.calls >= self.cancel_after:
                self.cancel.set()
        return not self.cancel.is_set()

    @property
    def fraction(self) -> float:
        with self.lock:
            return min(self.done / self.total, 1.0)


@dataclass(frozen=True)
class Step:
    """A step of a job's main-thread part done: `done` of `total` of `what` (e.g. Cycles'
    renders)."""

    what: str
    done: int
    total: int

    @property
    def fraction(self) -> float:
        return min(self.done / max(self.total, 1), 1.0)

    def status(self, label: str) -> str:
        return f"{label}: {self.what} {self.done} of {self.total} (Esc cancels)"


# A job's main-thread part: yields after each step, returns the job's message.
Steps = Generator[Step, None, str]


def set_status(context: bpy.types.Context, text: str, fraction: float = 0.0) -> None:
    """The status line and progress bar the panel shows."""
    settings = context.scene.occlux
    settings.status = text
    settings.progress = fraction
    for window in context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()


class BackgroundRun:
    """A job's work on its own thread. The core releases the GIL while it computes, so
    Blender's main thread stays free to poll `running` from a modal timer."""

    def __init__(self, work: Callable[[JobProgress], Any], progress: JobProgress) -> None:
        self.progress = progress
        self.result: Any = None
        self.notices: list[str] = []
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, args=(work,), daemon=True)
        ACTIVE.add(self)
        self.thread.start()

    def _run(self, work: Callable[[JobProgress], Any]) -> None:
        try:
            self.result, self.notices = run_recording(work, self.progress)
        except BaseException as e:  # handed to the main thread, which reports it
            self.error = e

    @property
    def running(self) -> bool:
        if self.thread.is_alive():
            return True
        ACTIVE.discard(self)
        return False


# Runs in flight: unregistering the add-on cancels them, so no thread outlives it.
ACTIVE: set[BackgroundRun] = set()


def cancel_all() -> None:
    """Cancels the runs in flight and waits for their threads (on unregister)."""
    for run in list(ACTIVE):
        run.progress.cancel.set()
        run.thread.join()
    ACTIVE.clear()


def scripted_cancel_property(name: str, counted: str) -> Any:
    """A hidden operator property that cancels the job after a number of `counted`, as ESC
    does: for scripts and tests."""
    return IntProperty(
        name=name,
        description=f"Cancel after this many {counted}, as ESC does (for scripts and tests; "
        "0: never)",
        min=0,
        default=0,
        options={"HIDDEN", "SKIP_SAVE"},
    )


class OccluxJob:
    """The frame of a long operator (see the module's docstring)."""

    cancel_after: scripted_cancel_property("Cancel after", "progress reports")
    cancel_after_steps: scripted_cancel_property(
        "Cancel after steps", "steps of the main-thread part (e.g. Cycles' renders)"
    )

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Any]:
        raise NotImplementedError

    def finish(self, context: bpy.types.Context, result: Any) -> str:
        raise NotImplementedError

    def finish_steps(self, context: bpy.types.Context, result: Any) -> Steps:
        """The main-thread part in steps (see the module); by default one, `finish`. A step
        that adds data must remove it when the generator is closed (cancelled) or fails."""
        yield from ()
        return self.finish(context, result)

    def scripted_cancel(self, steps_done: int) -> bool:
        """Whether the scripted cancel (`cancel_after_steps`) falls after this many steps."""
        return 0 < self.cancel_after_steps <= steps_done

    def errors(self) -> tuple[type[BaseException], ...]:
        return (OSError, ValueError, TypeError, occlux.OccluxError)

    def execute(self, context: bpy.types.Context) -> set[str]:
        """The synchronous path (scripts, EXEC_DEFAULT): the same work, on this thread."""
        self._timer = None  # no modal timer: `end_modal` has nothing to end
        progress = JobProgress(self.cancel_after)
        set_status(context, f"{self.bl_label}: running")
        try:
            result, notices = run_recording(self.prepare(context), progress)
        except self.errors() as e:
            return self.failed(context, e, progress)
        steps = self.finish_steps(context, result)
        while True:
            state = self.advance(context, steps, progress, notices)
            if state is not None:
                return state

    @classmethod
    def poll(cls, context: bpy.types.Context) -> bool:
        return not any(run.running for run in list(ACTIVE))  # one job at a time

    def invoke(self, context: bpy.types.Context, event: bpy.types.Event) -> set[str]:
        if context.window is None:  # no window to poll from (headless): run it here
            return self.execute(context)
        try:
            work = self.prepare(context)
        except self.errors() as e:
            return self.failed(context, e, None)
        wm = context.window_manager
        self._run = BackgroundRun(work, JobProgress(self.cancel_after))
        self._steps: Steps | None = None
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 1)
        wm.modal_handler_add(self)
        set_status(context, f"{self.bl_label}: running (Esc cancels)")
        return {"RUNNING_MODAL"}

    def modal(self, context: bpy.types.Context, event: bpy.types.Event) -> set[str]:
        run = self._run
        if event.type == "ESC" and event.value == "PRESS":
            if self._steps is not None:  # between two main-thread steps: stop here
                return self.cancel_steps(context, self._steps, run.progress)
            run.progress.cancel.set()  # the core stops at its next progress report
            set_status(context, f"{self.bl_label}: cancelling", run.progress.fraction)
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if self._steps is None and run.running:
            context.window_manager.progress_update(run.progress.fraction)
            set_status(context, f"{self.bl_label}: running (Esc cancels)", run.progress.fraction)
            return {"RUNNING_MODAL"}
        if self._steps is None and run.error is not None:
            self.end_modal(context)
            if isinstance(run.error, self.errors()):
                return self.failed(context, run.error, run.progress)
            raise run.error
        if self._steps is None:
            self._steps = self.finish_steps(context, run.result)
        # One step per timer event: the UI, and ESC, get their turn between two.
        state = self.advance(context, self._steps, run.progress, run.notices)
        return {"RUNNING_MODAL"} if state is None else state

    def advance(
        self, context: bpy.types.Context, steps: Steps, progress: JobProgress, notices: list[str]
    ) -> set[str] | None:
        """Runs the next step of the main-thread part: the operator's final state once the
        steps end, fail or are cancelled, else None (more to do)."""
        try:
            step = next(steps)
        except StopIteration as end:
            self.end_modal(context)
            return self.succeeded(context, end.value, notices)
        except self.errors() as e:
            self.end_modal(context)
            return self.failed(context, e, None)
        progress.steps_done += 1
        if self.scripted_cancel(progress.steps_done):
            return self.cancel_steps(context, steps, progress)
        if self._timer is not None:
            context.window_manager.progress_update(step.fraction)
        set_status(context, step.status(self.bl_label), step.fraction)
        return None

    def cancel_steps(
        self, context: bpy.types.Context, steps: Steps, progress: JobProgress
    ) -> set[str]:
        """Cancels the main-thread part between two steps (closing it removes what it added)."""
        progress.cancel.set()
        steps.close()
        self.end_modal(context)
        return self.failed(context, None, progress)

    def end_modal(self, context: bpy.types.Context) -> None:
        """Removes the modal timer and the progress bar (none on the synchronous path)."""
        if self._timer is None:
            return
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()

    def succeeded(self, context: bpy.types.Context, message: str, notices: list[str]) -> set[str]:
        elsewhere = unsaved_output(context.scene.occlux)
        if elsewhere:
            message += f" ({elsewhere})"
        for notice in notices:
            self.report({"WARNING"}, notice)
            message += f"; {notice}"
        set_status(context, message, 1.0)
        self.report({"INFO"}, message)
        return {"FINISHED"}

    def failed(
        self,
        context: bpy.types.Context,
        error: BaseException | None,
        progress: JobProgress | None,
    ) -> set[str]:
        if progress is not None and progress.cancel.is_set():
            message = f"{self.bl_label}: cancelled, nothing was added"
            set_status(context, message)
            self.report({"WARNING"}, message)
        else:
            message = panel_words(str(error))
            set_status(context, f"{self.bl_label} failed: {message}")
            self.report({"ERROR"}, message)
        return {"CANCELLED"}
