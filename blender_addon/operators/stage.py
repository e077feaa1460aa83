"""Import Occlux Stage: a USD stage written by `occlux export` (or `occlux.usd`) through
Blender's own USD import, completed with what that import leaves out. Blender 5 reads no
`RenderSettings` (a stage came in at the factory 1920 x 1080, whatever its image size) and does
not make the stage's camera the scene camera; this operator applies the settings' resolution and
camera, sets the camera's lens from the USD apertures so that Cycles frames the volume as Occlux
did, and gives the volume a material if it has none (Blender's import adds none)."""

from __future__ import annotations

import importlib
import re
import site
import sys
from dataclasses import dataclass
from pathlib import Path

import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ImportHelper
from occlux.blender.material import box_mask

from ..material import Rgb

# Blender's suffix for a name already taken ("Camera.001").
_SUFFIX = re.compile(r"\.\d{3,}$")


def _pxr():
    """USD's Python modules: part of Blender's Python; the bpy wheel bundles them in a folder
    that is not on sys.path."""
    names = ("Usd", "UsdGeom", "UsdRender", "UsdVol")
    try:
        return [importlib.import_module(f"pxr.{n}") for n in names]
    except ImportError:
        for root in site.getsitepackages():
            bundled = Path(root) / "bpy/5.0/python/lib/python3.11/site-packages"
            if bundled.is_dir() and str(bundled) not in sys.path:
                sys.path.append(str(bundled))
        return [importlib.import_module(f"pxr.{n}") for n in names]


@dataclass(frozen=True)
class StageCamera:
    """A `UsdGeom.Camera`'s projection: apertures and focal length in tenths of a scene unit."""

    name: str
    projection: str
    focal_length: float
    horizontal_aperture: float
    vertical_aperture: float
    clipping_range: tuple[float, float]


@dataclass(frozen=True)
class StageSettings:
    """What Blender's USD import does not apply: the render settings' image size and camera,
    and the names of the prims it wrongly makes empties of (the field prims and the render
    settings' parent, in stages from Occlux versions that left them visible and typed)."""

    resolution: tuple[int, int]
    camera: StageCamera
    helper_names: frozenset[str]
    # The volume's extent (its cells' bounds), where its medium ends; None if it has none.
    volume_box: tuple[Rgb, Rgb] | None


def read_stage(path: Path) -> StageSettings:
    """The stage's render settings (the `renderSettingsPrimPath` metadata, else the first
    `RenderSettings` prim) and the camera they name; ValueError if it has none."""
    usd, usd_geom, usd_render, usd_vol = _pxr()
    stage = usd.Stage.Open(str(path))
    if stage is None:
        raise ValueError(f"'{path}' is not a USD stage")
    prim = None
    metadata = stage.GetMetadata("renderSettingsPrimPath")
    if metadata:
        prim = stage.GetPrimAtPath(metadata)
    if prim is None or not prim.IsA(usd_render.Settings):
        prim = next((p for p in stage.Traverse() if p.IsA(usd_render.Settings)), None)
    if prim is None:
        raise ValueError(f"'{path.name}' has no RenderSettings prim (not an Occlux stage?)")
    settings = usd_render.Settings(prim)
    resolution = settings.GetResolutionAttr().Get()
    if resolution is None or min(resolution) < 1:
        raise ValueError(f"{prim.GetPath()} has no valid resolution")
    targets = settings.GetCameraRel().GetForwardedTargets()
    camera_prim = stage.GetPrimAtPath(targets[0]) if targets else None
    if camera_prim is None or not camera_prim.IsA(usd_geom.Camera):
        raise ValueError(f"{prim.GetPath()} names no camera")
    camera = usd_geom.Camera(camera_prim)
    near, far = camera.GetClippingRangeAttr().Get()
    helpers = {p.GetName() for p in stage.Traverse() if p.IsA(usd_vol.FieldBase)}
    helpers.add(prim.GetParent().GetName())
    volume = next((p for p in stage.Traverse() if p.IsA(usd_vol.Volume)), None)
    extent = usd_vol.Volume(volume).GetExtentAttr().Get() if volume is not None else None
    box = None if extent is None else tuple(tuple(float(c) for c in corner) for corner in extent)
    return StageSettings(
        resolution=(int(resolution[0]), int(resolution[1])),
        camera=StageCamera(
            name=camera_prim.GetName(),
            projection=str(camera.GetProjectionAttr().Get()),
            focal_length=float(camera.GetFocalLengthAttr().Get()),
            horizontal_aperture=float(camera.GetHorizontalApertureAttr().Get()),
            vertical_aperture=float(camera.GetVerticalApertureAttr().Get()),
            clipping_range=(float(near), float(far)),
        ),
        helper_names=frozenset(helpers),
        volume_box=box,
    )


def _base_name(obj: bpy.types.Object) -> str:
    return _SUFFIX.sub("", obj.name)


def apply_camera(data: bpy.types.Camera, camera: StageCamera) -> None:
    """Blender's lens for the USD camera. Occlux keeps the vertical field of view whatever the
    image's aspect, so the sensor fits vertically; lens and sensor are the USD numbers read as
    millimetres (only their ratio, the field of view, matters: Blender's import scales both by
    100, a 24 mm sensor becoming 2400 mm)."""
    data.sensor_fit = "VERTICAL"
    data.sensor_height = camera.vertical_aperture
    data.sensor_width = camera.horizontal_aperture
    data.shift_x = data.shift_y = 0.0
    data.lens_unit = "MILLIMETERS"
    data.lens = camera.focal_length
    if camera.projection == "orthographic":
        data.type = "ORTHO"
        data.ortho_scale = camera.vertical_aperture / 10.0  # tenths of a scene unit
    else:
        data.type = "PERSP"
    data.clip_start, data.clip_end = camera.clipping_range


def default_volume_material(name: str, box: tuple[Rgb, Rgb] | None) -> bpy.types.Material:
    """A Principled Volume whose density is the `density` grid as it is, Occlux's extinction
    sigma_t per scene unit (the albedo is not in the stage: a neutral grey), within the
    volume's `box` (the stage's extent: Occlux's grids are padded by one voxel repeating the
    border, and its medium ends at the box's faces)."""
    material = bpy.data.materials.new(name)
    tree = material.node_tree
    if tree is None:  # Blender < 5 needs use_nodes
        material.use_nodes = True
        tree = material.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    principled = tree.nodes.new("ShaderNodeVolumePrincipled")
    principled.inputs["Density"].default_value = 1.0
    principled.inputs["Density Attribute"].default_value = "density"
    if box is not None:
        tree.links.new(box_mask(tree, box), principled.inputs["Density"])
    tree.links.new(principled.outputs["Volume"], output.inputs["Volume"])
    return material


class OCCLUX_OT_import_stage(bpy.types.Operator, ImportHelper):
    """Import a USD stage written by Occlux with its render size and camera: the scene renders
    the volume framed as Occlux rendered it"""

    bl_idname = "occlux.import_stage"
    bl_label = "Import Occlux Stage"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".usda"
    filter_glob: StringProperty(default="*.usd;*.usda;*.usdc", options={"HIDDEN"})

    def execute(self, context: bpy.types.Context) -> set[str]:
        path = Path(bpy.path.abspath(self.filepath))
        if not path.is_file():
            self.report({"ERROR"}, f"no USD stage at '{path}'")
            return {"CANCELLED"}
        try:
            settings = read_stage(path)
        except Exception as e:  # pxr raises Tf.ErrorException for unreadable files
            self.report({"ERROR"}, f"cannot read {path.name}: {e}")
            return {"CANCELLED"}
        before = set(bpy.data.objects)
        result = bpy.ops.wm.usd_import(filepath=str(path), import_visible_only=True)
        if "FINISHED" not in result:
            self.report({"ERROR"}, f"Blender's USD import of {path.name} failed")
            return {"CANCELLED"}
        new = [o for o in bpy.data.objects if o not in before]
        for obj in [o for o in new if o.type == "EMPTY" and not o.children]:
            if _base_name(obj) in settings.helper_names:
                new.remove(obj)
                bpy.data.objects.remove(obj)
        cameras = [o for o in new if o.type == "CAMERA"]
        camera = next((o for o in cameras if _base_name(o) == settings.camera.name), None)
        if camera is None:
            self.report({"ERROR"}, f"the import made no camera '{settings.camera.name}'")
            return {"CANCELLED"}
        apply_camera(camera.data, settings.camera)
        scene = context.scene
        scene.camera = camera
        render = scene.render
        render.resolution_x, render.resolution_y = settings.resolution
        render.resolution_percentage = 100
        render.pixel_aspect_x = render.pixel_aspect_y = 1.0
        volumes = [o for o in new if o.type == "VOLUME"]
        for obj in volumes:
            if not obj.data.materials:
                obj.data.materials.append(
                    default_volume_material(f"Occlux {obj.name}", settings.volume_box)
                )
        w, h = settings.resolution
        names = ", ".join(o.name for o in volumes) or "no volume"
        self.report({"INFO"}, f"imported {path.name}: {w} x {h}, camera '{camera.name}', {names}")
        return {"FINISHED"}


def menu_import(self, context: bpy.types.Context) -> None:
    self.layout.operator(OCCLUX_OT_import_stage.bl_idname, text="Occlux Stage (.usd*)")


CLASSES = (OCCLUX_OT_import_stage,)
