"""The add-on's operators: load and classify a volume into the scene, compute its ambient
occlusion, composite Occlux's EXR layers with the render. Each checks its input first and
creates nothing when it fails.

The long ones are jobs: `prepare` reads the settings and checks them on the main thread and
returns the work, a function of a `JobProgress` that touches no Blender data (so that it can run
in a thread); `finish` brings its result into the scene on the main thread."""

from __future__ import annotations

import gzip
import math
import os
import shutil
import struct
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import bpy
import numpy as np
from bpy.props import EnumProperty, IntProperty, StringProperty

from . import nodes, scenes

RAW_DTYPES = {
    "uint8": "<u1",
    "int8": "<i1",
    "uint16": "<u2",
    "int16": "<i2",
    "uint32": "<u4",
    "int32": "<i4",
    "float32": "<f4",
    "float64": "<f8",
}

# A scene for `occlux.ao_volume`, which reads only its classification: the volume is passed
# explicitly and the camera is unused.
AO_SCENE = '[volume]\nphantom = "sphere"\nsize = 4\n[camera]\nposition = [0, -4, 0]\n'


def output_dir(settings) -> Path:
    """The output folder: `//` is the .blend file's folder (a temporary folder for an unsaved
    file)."""
    raw = settings.output_dir or "//occlux/"
    if raw.startswith("//") and not bpy.data.filepath:
        return Path(tempfile.gettempdir()) / "occlux" / raw[2:]
    return Path(bpy.path.abspath(raw))


def header_dims(path: Path, raw_dims: tuple[int, int, int]) -> tuple[int, ...] | None:
    """The voxel counts a volume file declares, read from its header without loading it; None
    where the header says nothing dense (OpenVDB: sparse, the core checks it while loading) or
    the format is unknown (the loader reports it)."""
    name = path.name.lower()
    if name.endswith(".raw"):
        return raw_dims
    if name.endswith((".nrrd", ".nhdr")):
        with path.open("rb") as f:
            header = f.read(1 << 16).split(b"\n\n")[0].decode("latin-1")
        for line in header.splitlines():
            if line.lower().startswith("sizes:"):
                return tuple(int(n) for n in line.split(":", 1)[1].split())
        raise ValueError(f"{path}: the NRRD header has no 'sizes' field")
    if name.endswith(".npy"):
        return np.load(path, mmap_mode="r").shape  # maps the file; reads only the header
    if name.endswith((".nii", ".nii.gz")):
        opener = gzip.open if name.endswith(".gz") else open
        with opener(path, "rb") as f:
            header = f.read(348)
        # NIfTI-1: sizeof_hdr = 348 at 0 gives the byte order; dim[0..7] int16 at 40.
        order = "<" if struct.unpack("<i", header[:4])[0] == 348 else ">"
        dim = struct.unpack(f"{order}8h", header[40:56])
        return dim[1 : 1 + max(0, min(dim[0], 7))]
    return None


def check_budget(path: Path, raw_dims: tuple[int, int, int], budget_mb: int) -> None:
    """Refuses a volume whose float32 copy (what the core holds) exceeds the memory budget,
    before anything is loaded."""
    dims = header_dims(path, raw_dims)
    if dims is None:
        return
    need = math.prod(dims) * 4
    if need > budget_mb * (1 << 20):
        raise ValueError(
            f"{path.name}: {' x '.join(map(str, dims))} voxels need {need / (1 << 20):.0f} MB "
            f"as float32, over the memory budget of {budget_mb} MB (Occlux panel)"
        )


@dataclass(frozen=True)
class VolumeInput:
    """The volume settings, read on the main thread so that the work needs no Blender data."""

    path: Path
    setting: str  # the path as the user typed it, kept on the object
    raw_dims: tuple[int, int, int]
    raw_type: str
    raw_spacing: tuple[float, float, float]
    fit: float

    @staticmethod
    def from_settings(settings) -> VolumeInput:
        path = Path(bpy.path.abspath(settings.volume_path))
        if not settings.volume_path or not path.is_file():
            raise FileNotFoundError(f"no volume file at '{path}'")
        check_budget(path, tuple(settings.raw_dims), settings.memory_budget_mb)
        return VolumeInput(
            path,
            settings.volume_path,
            tuple(settings.raw_dims),
            settings.raw_type,
            tuple(settings.raw_spacing),
            settings.fit,
        )

    @property
    def stem(self) -> str:
        return self.path.name.split(".")[0]

    def load(self):
        """The volume file as an `occlux.Volume`, scaled so its largest side is `fit` and
        centred at the origin."""
        import occlux

        path = self.path
        if path.suffix.lower() == ".raw":
            nx, ny, nz = self.raw_dims
            dtype = np.dtype(RAW_DTYPES[self.raw_type])
            expected = nx * ny * nz * dtype.itemsize
            if path.stat().st_size != expected:
                raise ValueError(
                    f"{path} holds {path.stat().st_size} bytes, but {nx}x{ny}x{nz} "
                    f"{self.raw_type} needs {expected}"
                )
            values = np.fromfile(path, dtype=dtype).reshape(nz, ny, nx)
            volume = occlux.Volume(values, spacing=self.raw_spacing)
        else:
            volume = occlux.Volume.load(path)
        dims = np.array(volume.dims, float)
        extent = dims * np.array(volume.spacing)
        scale = self.fit / extent.max()
        spacing = np.array(volume.spacing) * scale
        origin = -0.5 * extent * scale + 0.5 * spacing
        return occlux.Volume(volume.values, spacing=tuple(spacing), origin=tuple(origin))


def write_vdb(path: Path, grids: dict) -> None:
    """Writes the grids under a temporary name in the same folder, then renames it into place:
    a cancelled or failed job never leaves a partial file under the name Blender would load."""
    import occlux

    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=".vdb", dir=path.parent)
    os.close(fd)
    try:
        occlux.write_vdb(tmp, grids)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


class JobProgress:
    """The progress callback the core calls, from its own threads: it only records (no Blender
    calls off the main thread) and answers False once cancelled, which stops the core."""

    def __init__(self, cancel_after: int = 0) -> None:
        self.done = 0
        self.total = 1
        self.calls = 0
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
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, args=(work,), daemon=True)
        ACTIVE.add(self)
        self.thread.start()

    def _run(self, work: Callable[[JobProgress], Any]) -> None:
        try:
            self.result = work(self.progress)
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


class OccluxJob:
    """The frame of a long operator (see the module's docstring). From the UI (invoke) the work
    runs on a thread while a modal timer shows its progress and ESC cancels it; from scripts
    (execute) it runs on the calling thread."""

    cancel_after: IntProperty(
        name="Cancel after",
        description="Cancel after this many progress reports, as ESC does (for scripts and "
        "tests; 0: never)",
        min=0,
        default=0,
        options={"HIDDEN", "SKIP_SAVE"},
    )

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Any]:
        raise NotImplementedError

    def finish(self, context: bpy.types.Context, result: Any) -> str:
        raise NotImplementedError

    def errors(self) -> tuple[type[BaseException], ...]:
        import occlux

        return (OSError, ValueError, TypeError, occlux.OccluxError)

    def execute(self, context: bpy.types.Context) -> set[str]:
        """The synchronous path (scripts, EXEC_DEFAULT): the same work, on this thread."""
        progress = JobProgress(self.cancel_after)
        set_status(context, f"{self.bl_label}: running")
        try:
            result = self.prepare(context)(progress)
        except self.errors() as e:
            return self.failed(context, e, progress)
        return self.succeeded(context, result)

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
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 1)
        wm.modal_handler_add(self)
        set_status(context, f"{self.bl_label}: running (Esc cancels)")
        return {"RUNNING_MODAL"}

    def modal(self, context: bpy.types.Context, event: bpy.types.Event) -> set[str]:
        run = self._run
        if event.type == "ESC" and event.value == "PRESS":
            run.progress.cancel.set()  # the core stops at its next progress report
            set_status(context, f"{self.bl_label}: cancelling", run.progress.fraction)
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        wm = context.window_manager
        if run.running:
            wm.progress_update(run.progress.fraction)
            set_status(context, f"{self.bl_label}: running (Esc cancels)", run.progress.fraction)
            return {"RUNNING_MODAL"}
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if run.error is None:
            return self.succeeded(context, run.result)
        if isinstance(run.error, self.errors()):
            return self.failed(context, run.error, run.progress)
        raise run.error

    def succeeded(self, context: bpy.types.Context, result: Any) -> set[str]:
        try:
            message = self.finish(context, result)
        except self.errors() as e:
            return self.failed(context, e, None)
        set_status(context, message, 1.0)
        self.report({"INFO"}, message)
        return {"FINISHED"}

    def failed(
        self, context: bpy.types.Context, error: BaseException, progress: JobProgress | None
    ) -> set[str]:
        if progress is not None and progress.cancel.is_set():
            message = f"{self.bl_label}: cancelled, nothing was added"
            set_status(context, message)
            self.report({"WARNING"}, message)
        else:
            set_status(context, f"{self.bl_label} failed: {error}")
            self.report({"ERROR"}, str(error))
        return {"CANCELLED"}


@dataclass(frozen=True)
class Loaded:
    """A VDB written by a job, with what its material needs."""

    vdb: Path
    source: VolumeInput
    classification: Any
    volume: Any


def classification_of(settings):
    import occlux

    return occlux.Classification.preset(settings.preset, density_scale=settings.density_scale)


class OCCLUX_OT_import_volume(OccluxJob, bpy.types.Operator):
    """Load the volume file, classify it with the preset and add it as a Volume object"""

    bl_idname = "occlux.import_volume"
    bl_label = "Load Volume"
    bl_options = {"REGISTER", "UNDO"}

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Loaded]:
        settings = context.scene.occlux
        source = VolumeInput.from_settings(settings)
        classification = classification_of(settings)
        vdb = output_dir(settings) / f"{source.stem}.vdb"

        def work(progress: JobProgress) -> Loaded:
            volume = source.load()
            density = classification.extinction(volume)
            write_vdb(vdb, {"density": density, "value": volume})
            return Loaded(vdb, source, classification, volume)

        return work

    def finish(self, context: bpy.types.Context, result: Loaded) -> str:
        obj = add_volume_object(context, result, ao=None)
        return f"loaded {result.source.path.name} as '{obj.name}' ({result.vdb})"


class OCCLUX_OT_compute_ao(OccluxJob, bpy.types.Operator):
    """Compute the volume's ambient occlusion (VAO) with Occlux and add it as a Volume object
    whose material is shaded by the `ao` grid"""

    bl_idname = "occlux.compute_ao"
    bl_label = "Compute AO"
    bl_options = {"REGISTER", "UNDO"}

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Loaded]:
        import occlux

        settings = context.scene.occlux
        source = VolumeInput.from_settings(settings)
        classification = classification_of(settings)
        method, radius, device = settings.ao_method, settings.ao_radius, settings.device
        vdb = output_dir(settings) / f"{source.stem}-ao.vdb"

        def work(progress: JobProgress) -> Loaded:
            volume = source.load()
            scene = occlux.Scene.from_toml(AO_SCENE)
            scene.classification = classification
            ao = occlux.ao_volume(
                scene, method=method, radius=radius, device=device, volume=volume,
                progress=progress,
            )["ao"]  # fmt: skip
            density = classification.extinction(volume)
            write_vdb(vdb, {"density": density, "value": volume, "ao": ao})
            return Loaded(vdb, source, classification, volume)

        return work

    def finish(self, context: bpy.types.Context, result: Loaded) -> str:
        settings = context.scene.occlux
        obj = add_volume_object(context, result, ao=settings.ao_shading)
        return (
            f"AO ({settings.ao_method}, radius {settings.ao_radius}) of "
            f"{result.source.path.name} as '{obj.name}' ({result.vdb})"
        )


def dos_toml(settings) -> str:
    """The render section for directional occlusion shading."""
    lines = [
        "[render]",
        'method = "dos"',
        f"theta_deg = {settings.dos_theta_deg:.9g}",
        f"grid = {settings.dos_grid}",
        f'distance = "{settings.dos_distance}"',
    ]
    if settings.dos_slice_distance > 0.0:  # else the core's default, the smallest spacing
        lines.append(f"slice_distance = {settings.dos_slice_distance:.9g}")
    return "\n".join(lines) + "\n"


class OCCLUX_OT_render_dos(OccluxJob, bpy.types.Operator):
    """Render the volume from the active camera with directional occlusion shading (the
    world's ambient light) and write the EXR (layers beauty, depth, dos, occlusion) for
    compositing"""

    bl_idname = "occlux.render_dos"
    bl_label = "Render DOS"
    bl_options = {"REGISTER"}

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Path]:
        import occlux

        settings = context.scene.occlux
        source = VolumeInput.from_settings(settings)
        render = context.scene.render
        width = max(1, render.resolution_x * render.resolution_percentage // 100)
        height = max(1, render.resolution_y * render.resolution_percentage // 100)
        toml = scenes.scene_toml(context, source, width, height, ambient_only=True)
        toml += dos_toml(settings)
        device = settings.device
        exr = output_dir(settings) / f"{source.stem}-dos.exr"

        def work(progress: JobProgress) -> Path:
            scene = occlux.Scene.from_toml(toml)
            result = occlux.render(scene, device=device, progress=progress)
            exr.parent.mkdir(parents=True, exist_ok=True)
            occlux.write_exr(exr, result, scene)  # atomic: a temporary file, then renamed
            return exr

        return work

    def finish(self, context: bpy.types.Context, exr: Path) -> str:
        context.scene.occlux.last_exr = str(exr)
        return f"DOS render written to {exr} (layers beauty, depth, dos, occlusion)"


@dataclass(frozen=True)
class Reference:
    """An Occlux reference and the scene and VDB it was made from (in a temporary folder)."""

    folder: Path
    scene: Path
    vdb: Path
    result: Any
    seconds: float


def image_size(render, longest: int) -> tuple[int, int]:
    """`longest` pixels along the render's longer side, its aspect kept."""
    w, h = render.resolution_x * render.pixel_aspect_x, render.resolution_y * render.pixel_aspect_y
    scale = longest / max(w, h)
    return max(1, round(w * scale)), max(1, round(h * scale))


def report_dir(settings) -> Path:
    """Beside the .blend file; the output folder for an unsaved file."""
    return Path(bpy.path.abspath("//")) if bpy.data.filepath else output_dir(settings)


class OCCLUX_OT_check_cycles(OccluxJob, bpy.types.Operator):
    """Render the volume with Occlux's Monte Carlo reference and with Cycles (same camera and
    lights), compare them pixel by pixel, and load the error map"""

    bl_idname = "occlux.check_cycles"
    bl_label = "Check Against Cycles"
    bl_options = {"REGISTER"}

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Reference]:
        import occlux
        import occlux.cycles as oc

        settings = context.scene.occlux
        source = VolumeInput.from_settings(settings)
        width, height = image_size(context.scene.render, settings.check_size)
        toml = scenes.scene_toml(context, source, width, height)
        estimator, spp = settings.check_estimator, settings.check_spp

        def work(progress: JobProgress) -> Reference:
            folder = Path(tempfile.mkdtemp(prefix="occlux-check-"))
            try:
                path = folder / f"{source.stem}.toml"
                path.write_text(toml)
                scene = occlux.Scene.load(path)
                volume = scene.load_volume()
                vdb = folder / f"{source.stem}.vdb"
                write_vdb(vdb, {"value": volume})  # what the harness maps onto Cycles
                started = time.perf_counter()
                result = occlux.reference(
                    scene, estimator=estimator, spp=spp, seed=oc.OCCLUX_SEED, volume=volume,
                    progress=progress,
                )  # fmt: skip
            except BaseException:
                shutil.rmtree(folder)
                raise
            return Reference(folder, path, vdb, result, time.perf_counter() - started)

        return work

    def finish(self, context: bpy.types.Context, ref: Reference) -> str:
        # Cycles renders through bpy, which only the main thread may call: this part blocks.
        import occlux.cycles as oc

        settings = context.scene.occlux
        estimator, spp, seeds = settings.check_estimator, settings.check_spp, settings.check_seeds
        try:
            scene = oc.build_scene(ref.scene, ref.vdb, estimator)
            cycles = oc.render_scene(scene, spp, seeds)
        finally:
            oc._remove_previous(bpy)  # the harness's scene, objects and world
            shutil.rmtree(ref.folder)
        occlux_image = oc.OccluxImage(
            np.asarray(ref.result.mean, np.float64),
            np.asarray(ref.result.stderr, np.float64),
            {"spp": ref.result.spp},
            {},
        )
        report = oc.compare(occlux_image, cycles.mean, cycles.stderr)
        if not (math.isfinite(report.rmse) and math.isfinite(report.rmse_over_noise)):
            raise ValueError(f"the comparison is not finite:\n{report.table()}")
        stem = f"{ref.scene.stem}-{estimator}"
        extra = {
            "source": settings.volume_path,
            "estimator": estimator,
            "spp": spp,
            "occlux_seconds": ref.seconds,
            "cycles_seconds": cycles.seconds,
        }
        _, png, js = oc.write_outputs(
            report_dir(settings), stem, occlux_image, cycles, report, extra
        )
        image = bpy.data.images.load(str(png), check_existing=True)
        image.reload()  # a previous check's map of the same name
        settings.check_rmse = report.rmse
        settings.check_rmse_over_noise = report.rmse_over_noise
        settings.check_rms_z = report.rms_z
        settings.check_agrees = report.agrees()
        settings.check_report = str(js)
        verdict = "agree within noise" if report.agrees() else "DISAGREE"
        return (
            f"Occlux vs Cycles ({estimator}, {spp} spp): RMSE {report.rmse:.4g}, "
            f"{report.rmse_over_noise:.3f} x the noise, {verdict}; error map '{image.name}'"
        )


def add_volume_object(context: bpy.types.Context, loaded: Loaded, ao: str | None):
    """A Volume object for the VDB with the Occlux material; the previous one of that name is
    replaced. If Blender cannot read the file, nothing is added (and the file is removed)."""
    name = loaded.vdb.stem
    data = bpy.data.volumes.new(name)
    data.filepath = str(loaded.vdb)
    if not data.grids.load():
        error = data.grids.error_message
        bpy.data.volumes.remove(data)
        loaded.vdb.unlink(missing_ok=True)
        raise OSError(f"Blender cannot read {loaded.vdb}: {error}")
    old = bpy.data.objects.get(name)
    if old is not None:
        bpy.data.objects.remove(old)
    obj = bpy.data.objects.new(name, data)
    context.scene.collection.objects.link(obj)
    material = nodes.volume_material(
        f"Occlux {name}",
        loaded.classification.points,
        loaded.volume.value_range,
        loaded.classification.units,
        ao,
        context.scene.occlux.ao_factor,
    )
    data.materials.append(material)
    obj["occlux_source"] = loaded.source.setting
    return obj


class OCCLUX_OT_composite(bpy.types.Operator):
    """Combine a layer of an Occlux EXR with the render in the compositor"""

    bl_idname = "occlux.composite"
    bl_label = "Composite Occlux Layer"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(name="EXR", subtype="FILE_PATH")
    layer: StringProperty(name="Layer", default="beauty")
    blend: EnumProperty(
        name="Blend",
        items=[
            ("MULTIPLY", "Multiply", "Shade the render by the layer (occlusion layers)"),
            ("MIX", "Mix", "Show the layer over the render"),
        ],
        default="MULTIPLY",
    )

    def execute(self, context: bpy.types.Context) -> set[str]:
        path = Path(bpy.path.abspath(self.filepath))
        if not path.is_file():
            self.report({"ERROR"}, f"no EXR file at '{path}'")
            return {"CANCELLED"}
        image = bpy.data.images.load(str(path), check_existing=True)
        try:
            nodes.compositor_group(context.scene, image, self.layer, self.blend)
        except ValueError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        context.scene.render.use_compositing = True
        return {"FINISHED"}


CLASSES = (
    OCCLUX_OT_import_volume,
    OCCLUX_OT_compute_ao,
    OCCLUX_OT_render_dos,
    OCCLUX_OT_check_cycles,
    OCCLUX_OT_composite,
)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister() -> None:
    for run in list(ACTIVE):
        run.progress.cancel.set()
        run.thread.join()
    ACTIVE.clear()
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
