"""The add-on's settings, stored on each scene as `scene.occlux`."""

from __future__ import annotations

import bpy
import occlux
from bpy.props import (
    EnumProperty,
    FloatProperty,
    IntProperty,
    IntVectorProperty,
    PointerProperty,
    StringProperty,
)

from . import material, scenes, transfer

# Limits, defaults and choices that the core's method registry (`occlux.methods()`) knows come
# from it, read when the add-on is registered: the extension installs its `occlux` wheel before
# Blender imports this module.
DOS = {p["key"]: p for p in scenes.method("dos")["params"]}
AO = {p["key"]: p for p in scenes.method("ao")["params"]}
IPSVI = {p["key"]: p for p in scenes.method("ipsvi")["params"]}
PRESETS = tuple(occlux.PRESETS)
# Labels for the registry's choice names; the rest are capitalised.
LABELS = {"cdf": "CDF", "gauss-exact": "Gauss (exact erf)", "solid-angle": "Solid angle"}


def _items(param: dict) -> list[tuple[str, str, str]]:
    """Enum items for a registry parameter of type "choice": its options and their docs."""
    return [
        (o["name"], LABELS.get(o["name"], o["name"].capitalize()), o["doc"])
        for o in param["options"]
    ]


def _limits(param: dict, precision: int | None = None) -> dict:
    """`min` and `max` of a registry parameter's range. Blender's properties have closed bounds
    only: an open bound (exclusive) becomes the closest value inside it that the panel shows at
    `precision` decimals (e.g. [0, 90) with precision 1 gives max = 89.9)."""
    limits = {}
    bounds = param["range"]
    step = 10.0 ** -(precision or 0) if param["type"] == "float" else 1
    cast = float if param["type"] == "float" else int
    if bounds["min"] is not None:
        low = bounds["min"] if bounds["min_inclusive"] else bounds["min"] + step
        limits["min"] = cast(low)
    if bounds["max"] is not None:
        high = bounds["max"] if bounds["max_inclusive"] else bounds["max"] - step
        limits["max"] = cast(high)
    return limits


def _range_text(param: dict) -> str:
    """The registry's range as the description says it, e.g. "in [0, 90)"."""
    bounds = param["range"]
    low = "[" if bounds["min_inclusive"] else "("
    high = "]" if bounds["max_inclusive"] else ")"
    lo = "-inf" if bounds["min"] is None else f"{bounds['min']:g}"
    hi = "inf" if bounds["max"] is None else f"{bounds['max']:g}"
    return f"in {low}{lo}, {hi}{high}"


def _registry_float(name: str, param: dict, precision: int):
    """A float property for a registry parameter: its doc and range as the description, its
    limits (open bounds closed at `precision` decimals) and its default."""
    return FloatProperty(
        name=name,
        description=f"{param['doc']}, {_range_text(param)}",
        **_limits(param, precision=precision),
        precision=precision,
        default=param["default"],
    )


RAW_TYPES = ("uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64")


def _update_transfer(settings: OccluxSettings, context: bpy.types.Context) -> None:
    """Choosing Ramp makes the editable ramp if there is none yet, suggested on the active
    Occlux volume's file when it keeps its robust window (as Load Volume leaves it)."""
    if settings.transfer != transfer.RAMP or transfer.ramp_node(settings):
        return
    held = transfer.kept_by(scenes.volume_object(context))
    if held is None:
        transfer.ensure_ramp(settings)
    else:
        transfer.suggest(settings, held["robust"])


def _update_ao_factor(settings: OccluxSettings, context: bpy.types.Context) -> None:
    """Moves the AO factor node of every Occlux material to the new value."""
    for shading in bpy.data.materials:
        if shading.node_tree and material.AO_FACTOR in shading.node_tree.nodes:
            node = shading.node_tree.nodes[material.AO_FACTOR]
            node.outputs[0].default_value = settings.ao_factor


class OccluxSettings(bpy.types.PropertyGroup):
    volume_path: StringProperty(
        name="Volume",
        description="Volume file: NRRD (.nrrd, .nhdr), NIfTI (.nii, .nii.gz), OpenVDB or raw",
        subtype="FILE_PATH",
    )
    series_path: StringProperty(
        name="Series",
        description="A time series from `occlux series`: its manifest NAME.series.json, or one "
        "of its frames NAME_####.vdb beside it",
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
    transfer: EnumProperty(
        name="Transfer function",
        description="How the file's values become extinction and albedo",
        items=[
            (transfer.PRESET, "Preset", "A built-in transfer function on the file's "
             "robust window"),
            (transfer.RAMP, "Ramp", "The ramp below on the window Low..High of the "
             "file's values: RGB the albedo, alpha the extinction over Max density"),
        ],
        default=transfer.PRESET,
        update=_update_transfer,
    )  # fmt: skip
    window_lo: FloatProperty(
        name="Low",
        description="The file's value at the ramp's left end (values below classify as it)",
        default=0.0,
        precision=4,
    )
    window_hi: FloatProperty(
        name="High",
        description="The file's value at the ramp's right end (values above classify as it)",
        default=1.0,
        precision=4,
    )
    use_window_cut: bpy.props.BoolProperty(
        name="Cut",
        description="Classify values above Cut as the ramp's left end: negative numbers "
        "wrapped into an unsigned type (Suggest from File sets it when the file has them)",
        default=False,
    )
    window_cut: FloatProperty(
        name="Cut value",
        description="Values above this classify as the ramp's left end",
        default=0.0,
        precision=4,
    )
    max_density: FloatProperty(
        name="Max density",
        description="Extinction per scene unit where the ramp's alpha is 1",
        min=0.0,
        soft_max=200.0,
        default=20.0,
    )
    ramp: PointerProperty(
        name="Ramp",
        description="The node group holding the editable ramp",
        type=bpy.types.NodeTree,
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
    frame_camera: bpy.props.BoolProperty(
        name="Frame camera",
        description="Load Volume moves the scene camera along its own view direction so that "
        "the classified volume's visible content fills the frame (5 % margin), as `occlux "
        'render` frames a camera with frame = "content"',
        default=False,
    )
    output_dir: StringProperty(
        name="Output",
        description="Folder for Occlux's files (// is the .blend file's folder)",
        subtype="DIR_PATH",
        default="//occlux/",
    )
    memory_budget_mb: IntProperty(
        name="Memory budget (MB)",
        description="Refuse a volume, before loading it, when the work's peak memory (its "
        "float32 copy, voxels x 4 bytes from the file's header, times what the method holds "
        "besides) is larger; the memory the system has is checked too",
        min=1,
        default=2048,
    )
    device: EnumProperty(
        name="Device",
        items=[
            ("auto", "Auto", "A GPU adapter if one opens, else the CPU"),
            ("gpu", "GPU", "The GPU (an error if none opens)"),
            ("cpu", "CPU", "The CPU twin"),
        ],
        default="auto",
    )
    ao_method: EnumProperty(
        name="AO method",
        description=AO["ao_method"]["doc"],
        items=_items(AO["ao_method"]),
        default=AO["ao_method"]["default"],
    )
    ao_radius: IntProperty(
        name="AO radius",
        description=f"{AO['ao_radius']['doc']}, {_range_text(AO['ao_radius'])}",
        **_limits(AO["ao_radius"]),
        soft_max=min(64, AO["ao_radius"]["range"]["max"] or 64),
        default=AO["ao_radius"]["default"],
    )
    ao_gamma: _registry_float("AO gamma", AO["ao_gamma"], precision=2)
    ao_alpha: _registry_float("Surface opacity", AO["ao_alpha"], precision=2)
    ao_light: EnumProperty(
        name="AO light",
        description=AO["ao_light"]["doc"],
        items=_items(AO["ao_light"]),
        default=AO["ao_light"]["default"],
    )
    ao_shading: EnumProperty(
        name="AO shading",
        description="What the `ao` grid drives in the material",
        items=[
            (
                "AMBIENT",
                "Ambient light",
                "Emit the world's light the grid lets reach each point, sigma_t x albedo x "
                "world x mix(1, ao, strength), and light only camera rays by the world: "
                "Occlux's AO-shaded render in Cycles; suns and lamps still scatter",
            ),
            (
                "ALBEDO",
                "Darken albedo",
                "Multiply the albedo by mix(1, ao, strength); the world lights the volume as "
                "well (a stylised look: crevices occluded twice)",
            ),
            (
                material.AO_OFF,
                "Off",
                "No AO: Compute AO gives the volume Load Volume's plain material, and the world "
                "lights every ray again (AO strength 0 under Ambient light still emits the "
                "unoccluded world's light, the world lighting camera rays only)",
            ),
        ],
        default="AMBIENT",
    )
    ao_factor: FloatProperty(
        name="AO strength",
        description="How much the `ao` grid shades (0: not at all, 1: fully; 0 is not AO off "
        "under Ambient light: choose AO shading Off)",
        min=0.0,
        soft_max=1.0,
        default=1.0,
        update=_update_ao_factor,
    )
    bake_multiple: bpy.props.BoolProperty(
        name="Multiple scattering",
        description="Bake Light also bakes the world's and each lamp's multiply scattered light "
        "(8 bounces, solved on the volume's grid; the phase asymmetry is IPSVI's g)",
        default=True,
    )
    dos_theta_deg: _registry_float("Cone angle", DOS["theta_deg"], precision=1)  # max 89.9
    dos_grid: IntProperty(
        name="Cone samples",
        description=f"{DOS['grid']['doc']}, {_range_text(DOS['grid'])}",
        **_limits(DOS["grid"]),
        default=DOS["grid"]["default"],
    )
    # Optional in the core (absent: the smallest voxel spacing) with an open lower bound 0:
    # here 0 stands for absent and only positive values reach the scene.
    dos_slice_distance: FloatProperty(
        name="Slice distance",
        description=f"{DOS['slice_distance']['doc']} (0 here: absent)",
        min=0.0,
        default=0.0,
        precision=4,
    )
    dos_distance: EnumProperty(
        name="Cone distance",
        description=DOS["distance"]["doc"],
        items=_items(DOS["distance"]),
        default=DOS["distance"]["default"],
    )
    dos_sampling: EnumProperty(
        name="Cone sampling",
        description=DOS["sampling"]["doc"],
        items=_items(DOS["sampling"]),
        default=DOS["sampling"]["default"],
    )
    ipsvi_line_width: IntProperty(
        name="Line width",
        description=f"{IPSVI['line_width']['doc']}, {_range_text(IPSVI['line_width'])}",
        **_limits(IPSVI["line_width"]),
        default=IPSVI["line_width"]["default"],
    )
    # Optional in the core (absent: matched to the image and the voxels): 0 here stands for
    # absent and only positive values reach the scene.
    ipsvi_cache_size: IntProperty(
        name="Cache size",
        description=f"{IPSVI['cache_size']['doc']} (0 here: absent)",
        min=0,
        max=int(IPSVI["cache_size"]["range"]["max"]),
        default=0,
    )
    ipsvi_g: _registry_float("Anisotropy", IPSVI["g"], precision=2)
    ipsvi_scattering: EnumProperty(
        name="Scattering",
        description=IPSVI["scattering"]["doc"],
        items=_items(IPSVI["scattering"]),
        default=IPSVI["scattering"]["default"],
    )
    last_exr: StringProperty(
        name="Occlux EXR",
        description="The EXR the last Occlux render wrote (what Composite reads)",
        subtype="FILE_PATH",
    )
    check_subject: EnumProperty(
        name="Check",
        description="What Check Against Cycles checks",
        items=[
            (
                "FIGURE",
                "The figure",
                "The chosen Occlux method against Cycles' path-traced truth of the same scene: "
                "relative RMSE and bias over the volume's pixels, times, error map",
            ),
            (
                "BAKED",
                "The baked scene",
                "The scene as it stands, with Bake Light's grids, rendered by the chosen engine "
                "against Cycles' path-traced truth of the same scene without the bake",
            ),
            (
                "REFERENCE",
                "Validate the reference",
                "Occlux's Monte Carlo reference against Cycles, within noise (z scores)",
            ),
        ],
        default="FIGURE",
    )
    check_engine: EnumProperty(
        name="Engine",
        description="The engine that renders the baked scene for the check",
        items=[
            ("EEVEE", "EEVEE", "EEVEE with the scene's settings (Bake Light's froxels, scaled "
             "to the check's image)"),
            ("CYCLES", "Cycles", "Cycles at the engine samples, with the bake's ray marching"),
        ],
        default="EEVEE",
    )  # fmt: skip
    check_engine_samples: IntProperty(
        name="Engine samples",
        description="Samples per pixel of the engine's render of the baked scene",
        min=1,
        soft_max=1024,
        default=16,
    )
    check_method: EnumProperty(
        name="Method",
        description="The Occlux method whose figure is checked, with the panel's settings",
        items=[
            ("ao", "AO-shaded", "Ambient light times the AO method's openness; truth: the "
             "world scattered once"),
            ("dos", "DOS", "Directional occlusion shading; truth: the world scattered once"),
            ("ipsvi", "IPSVI", "Image plane sweep volume illumination; truth: the suns and "
             "point lamps scattered once (or 8 times, for its multiple scattering)"),
        ],
        default="ao",
    )  # fmt: skip
    check_estimator: EnumProperty(
        name="Check lighting",
        description="What the Cycles check renders (both renderers, same scene)",
        items=[
            ("ambient", "Ambient", "The world's uniform light, no bounces: volumetric AO"),
            ("single", "Single scattering", "The sun lights, with shadows, one bounce"),
        ],
        default="ambient",
    )
    check_size: IntProperty(
        name="Check size",
        description="Longest side of the check's images in pixels (the render's aspect)",
        min=8,
        soft_max=512,
        default=256,
    )
    check_spp: IntProperty(
        name="Check samples",
        description="Samples per pixel, for Occlux and for Cycles (Cycles' truth, for the "
        "baked scene)",
        min=2,
        soft_max=4096,
        default=128,
    )
    check_seeds: IntProperty(
        name="Cycles renders",
        description="Cycles renders with distinct seeds (samples / renders each): their "
        "spread is Cycles' standard error",
        min=2,
        soft_max=64,
        default=32,
    )
    # The last check's figures, shown in the panel.
    check_rmse: FloatProperty(name="RMSE", options={"SKIP_SAVE"})
    check_rmse_over_noise: FloatProperty(name="RMSE / noise", options={"SKIP_SAVE"})
    check_z_scale: FloatProperty(name="Scale of z", options={"SKIP_SAVE"})
    check_agrees: bpy.props.BoolProperty(name="Agree", options={"SKIP_SAVE"})
    check_rel_rmse: FloatProperty(name="Relative RMSE", options={"SKIP_SAVE"})
    check_bias: FloatProperty(name="Bias", options={"SKIP_SAVE"})
    check_checked: StringProperty(name="Checked render", options={"SKIP_SAVE"})
    check_occlux_seconds: FloatProperty(name="Checked render's time", options={"SKIP_SAVE"})
    check_cycles_seconds: FloatProperty(name="Cycles time", options={"SKIP_SAVE"})
    check_report: StringProperty(name="Check report", subtype="FILE_PATH", options={"SKIP_SAVE"})

    # What the running or last job says, shown in the panel (written on the main thread).
    status: StringProperty(name="Status", options={"SKIP_SAVE"})
    progress: FloatProperty(
        name="Progress", subtype="FACTOR", min=0.0, max=1.0, options={"SKIP_SAVE"}
    )


def register() -> None:
    bpy.utils.register_class(OccluxSettings)
    bpy.types.Scene.occlux = PointerProperty(type=OccluxSettings)


def unregister() -> None:
    del bpy.types.Scene.occlux
    bpy.utils.unregister_class(OccluxSettings)
