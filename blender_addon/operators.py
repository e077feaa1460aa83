"""The add-on's operators: load and classify a volume into the scene, composite Occlux's EXR
layers with the render. Each checks its input first and creates nothing when it fails."""

from __future__ import annotations

import tempfile
from pathlib import Path

import bpy
import numpy as np
from bpy.props import EnumProperty, StringProperty

from . import nodes

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


def output_dir(settings) -> Path:
    """The output folder: `//` is the .blend file's folder (a temporary folder for an unsaved
    file)."""
    raw = settings.output_dir or "//occlux/"
    if raw.startswith("//") and not bpy.data.filepath:
        return Path(tempfile.gettempdir()) / "occlux" / raw[2:]
    return Path(bpy.path.abspath(raw))


class Progress:
    """Occlux progress callbacks as Blender's window-manager progress."""

    def __init__(self, context: bpy.types.Context) -> None:
        self.wm = context.window_manager
        self.wm.progress_begin(0, 1)

    def __call__(self, done: int, total: int) -> None:
        self.wm.progress_update(done / max(total, 1))

    def end(self) -> None:
        self.wm.progress_end()


def load_volume(settings):
    """The volume file as an `occlux.Volume`, scaled so its largest side is `settings.fit` and
    centred at the origin."""
    import occlux

    path = Path(bpy.path.abspath(settings.volume_path))
    if not settings.volume_path or not path.is_file():
        raise FileNotFoundError(f"no volume file at '{path}'")
    if path.suffix.lower() == ".raw":
        nx, ny, nz = settings.raw_dims
        dtype = np.dtype(RAW_DTYPES[settings.raw_type])
        expected = nx * ny * nz * dtype.itemsize
        if path.stat().st_size != expected:
            raise ValueError(
                f"{path} holds {path.stat().st_size} bytes, but {nx}x{ny}x{nz} "
                f"{settings.raw_type} needs {expected}"
            )
        values = np.fromfile(path, dtype=dtype).reshape(nz, ny, nx)
        volume = occlux.Volume(values, spacing=tuple(settings.raw_spacing))
    else:
        volume = occlux.Volume.load(path)
    dims = np.array(volume.dims, float)
    extent = dims * np.array(volume.spacing)
    scale = settings.fit / extent.max()
    spacing = np.array(volume.spacing) * scale
    origin = -0.5 * extent * scale + 0.5 * spacing
    return occlux.Volume(volume.values, spacing=tuple(spacing), origin=tuple(origin)), path


class OCCLUX_OT_import_volume(bpy.types.Operator):
    """Load the volume file, classify it with the preset and add it as a Volume object"""

    bl_idname = "occlux.import_volume"
    bl_label = "Load Volume"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context: bpy.types.Context) -> set[str]:
        import occlux

        settings = context.scene.occlux
        progress = Progress(context)
        try:
            volume, source = load_volume(settings)
            classification = occlux.Classification.preset(
                settings.preset, density_scale=settings.density_scale
            )
            density = classification.extinction(volume)
            folder = output_dir(settings)
            folder.mkdir(parents=True, exist_ok=True)
            vdb = folder / f"{source.name.split('.')[0]}.vdb"
            occlux.write_vdb(vdb, {"density": density, "value": volume})
        except (OSError, ValueError, TypeError, occlux.OccluxError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        finally:
            progress.end()
        obj = add_volume_object(context, vdb, classification, volume, has_ao=False)
        self.report({"INFO"}, f"loaded {source.name} as '{obj.name}' ({vdb})")
        return {"FINISHED"}


def add_volume_object(context, vdb: Path, classification, volume, has_ao: bool):
    """A Volume object for `vdb` with the Occlux material; the previous one is replaced."""
    name = vdb.stem
    old = bpy.data.objects.get(name)
    if old is not None:
        bpy.data.objects.remove(old)
    data = bpy.data.volumes.new(name)
    data.filepath = str(vdb)
    data.grids.load()
    obj = bpy.data.objects.new(name, data)
    context.scene.collection.objects.link(obj)
    material = nodes.volume_material(
        f"Occlux {name}",
        classification.points,
        volume.value_range,
        classification.units,
        has_ao,
        context.scene.occlux.ao_factor,
    )
    data.materials.append(material)
    obj["occlux_source"] = context.scene.occlux.volume_path
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


CLASSES = (OCCLUX_OT_import_volume, OCCLUX_OT_composite)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister() -> None:
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
