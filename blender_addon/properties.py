"""The add-on's settings, stored on each scene as `scene.occlux`."""

from __future__ import annotations

import bpy
from bpy.props import (
    EnumProperty,
    FloatProperty,
    IntVectorProperty,
    PointerProperty,
    StringProperty,
)

PRESETS = ("ct-bone", "ct-soft-tissue", "mri", "simulation", "boundary-2d")
RAW_TYPES = ("uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64")


def _update_ao_factor(settings: OccluxSettings, context: bpy.types.Context) -> None:
    """Moves the AO factor node of every Occlux material to the new value."""
    for material in bpy.data.materials:
        if material.node_tree and "Occlux AO factor" in material.node_tree.nodes:
            node = material.node_tree.nodes["Occlux AO factor"]
            node.outputs[0].default_value = settings.ao_factor


class OccluxSettings(bpy.types.PropertyGroup):
    volume_path: StringProperty(
        name="Volume",
        description="Volume file: NRRD (.nrrd, .nhdr), NIfTI (.nii, .nii.gz), OpenVDB or raw",
        subtype="FILE_PATH",
    )
    raw_dims: IntVectorProperty(
        name="Raw dims",
        description="For .raw files: voxels along x, y, z",
        size=3,
        min=1,
        default=(64, 64, 64),
    )
    raw_type: EnumProperty(
        name="Raw type",
        items=[(t, t, f"{t} samples, little endian") for t in RAW_TYPES],
        default="uint8",
    )
    raw_spacing: bpy.props.FloatVectorProperty(
        name="Raw spacing",
        description="For .raw files: voxel size along x, y, z",
        size=3,
        min=1e-6,
        default=(1.0, 1.0, 1.0),
    )
    preset: EnumProperty(
        name="Preset",
        description="Transfer function: value to extinction, albedo and emission",
        items=[(p, p, f"The {p} transfer-function preset") for p in PRESETS],
        default="ct-bone",
    )
    density_scale: FloatProperty(
        name="Density scale",
        description="Multiplies the extinction everywhere",
        min=0.0,
        soft_max=100.0,
        default=1.0,
    )
    fit: FloatProperty(
        name="Size",
        description="The volume's largest side, in scene units",
        min=1e-4,
        default=2.0,
    )
    output_dir: StringProperty(
        name="Output",
        description="Folder for Occlux's files (// is the .blend file's folder)",
        subtype="DIR_PATH",
        default="//occlux/",
    )
    ao_factor: FloatProperty(
        name="AO strength",
        description="How much the `ao` grid darkens the albedo (0: not at all, 1: fully)",
        min=0.0,
        max=1.0,
        default=1.0,
        update=_update_ao_factor,
    )


def register() -> None:
    bpy.utils.register_class(OccluxSettings)
    bpy.types.Scene.occlux = PointerProperty(type=OccluxSettings)


def unregister() -> None:
    del bpy.types.Scene.occlux
    bpy.utils.unregister_class(OccluxSettings)
