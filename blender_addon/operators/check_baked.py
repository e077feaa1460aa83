"""The check of a baked scene (Check Against Cycles, subject BAKED): the user's scene as it
stands, with Bake Light's grids and material, rendered by the engine the user chose (EEVEE, or
Cycles at a few samples) against Cycles' path-traced truth of the same scene without the bake.

The truth renders the volume with its plain material (Load Volume's classification, no grid
but `value`) lit by the world, the suns and the point lamps the bake holds, with the bake's
phase asymmetry and, when the bake holds multiple scattering, the multiple reference's volume
bounces (`occlux.blender.DEFAULT_BOUNCES`; otherwise none: the bake holds single scattering
only). The engine's render is a linked copy of the user's scene (same objects, materials, world
and lamps; named with `occlux.blender.PREFIX` so that `remove_built` removes it) at the check's
size, its film linear as the truth's is.
EEVEE's froxels keep their size relative to the image: the check's image is smaller than the
user's, so its tile is the user's scaled by the ratio of the widths (`check_tile`), and the
check measures the blur the user's render has."""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np

from .. import material, scenes, truth
from .bake import BAKED, EEVEE_TILES, baked_lamps, outdated
from .jobs import JobProgress, Step, Steps

ENGINES = {"EEVEE": "BLENDER_EEVEE", "CYCLES": "CYCLES"}


@dataclass(frozen=True)
class BakedCheck:
    """What the main-thread part needs: the baked object's name, the plain material's control
    points and box (from the volume the job loaded), the bake's phase asymmetry, the truth's
    volume bounces (none unless the bake holds multiple scattering), the check's image size and
    the grey the background shows (which pixels are the volume's, `occlux.image_error`)."""

    stem: str
    volume_object: str
    points: Sequence[material.Point] | None
    box: tuple[material.Rgb, material.Rgb]
    g: float
    bounces: int
    size: tuple[int, int]
    background: float


def prepare(
    context: bpy.types.Context, size: tuple[int, int]
) -> Callable[[JobProgress], BakedCheck]:
    """Checks that the active Occlux volume is baked and its bake current, and returns the work
    that loads its volume (for the truth's plain material)."""
    import occlux.blender as ob

    obj = scenes.volume_object(context)
    if obj is None or BAKED not in obj:
        raise ValueError("checking the baked scene needs a baked Occlux volume: Bake Light first")
    why = outdated(context, obj)
    if why:
        raise ValueError(f"the bake is out of date ({why}): Bake Light again first")
    baked = json.loads(obj[BAKED])
    source = scenes.selected_source(context)
    scene = scenes.build(scenes.volume_tree(source, context.scene.occlux))
    background = float(np.mean(scenes.world_radiance(context.scene)))
    name, g = obj.name, baked["scattering"]["g"]
    bounces = ob.DEFAULT_BOUNCES if baked["scattering"]["multiple"] else 0

    def work(progress: JobProgress) -> BakedCheck:
        volume = scenes.load_volume(scene, source)
        points = scene.classification.raw_points(volume)
        return BakedCheck(source.stem, name, points, volume.bounds, g, bounces, size, background)

    return work


def check_tile(user_tile: str, user_width: int, width: int) -> str:
    """EEVEE's froxel tile for an image `width` pixels wide that covers the same share of the
    image as `user_tile` does of the user's `user_width`: the nearest available, at least 1."""
    wanted = int(user_tile) * width / max(user_width, 1)
    return min(EEVEE_TILES, key=lambda tile: abs(int(tile) - wanted))


def render_as_it_stands(
    scene: bpy.types.Scene,
    obj: bpy.types.Object,
    engine: str,
    samples: int,
    size: tuple[int, int],
    bounces: int,
) -> tuple[np.ndarray, float]:
    """The baked volume `obj` in the user's scene rendered by `engine` (EEVEE, CYCLES) at
    `samples` samples and `size`, as a linear RGB image, and the render's seconds. A linked
    copy of the scene renders it, so none of the user's settings change; it shows what the
    truth shows (the volume, the camera and the baked lamps under the world): the scene's
    collections are excluded from the copy's view layers and those objects linked to it."""
    import occlux.blender as ob

    percent = scene.render.resolution_percentage / 100.0
    user_width = round(scene.render.resolution_x * percent)
    copy = scene.copy()
    copy.name = f"{ob.PREFIX}-as-it-stands"
    try:
        for layer in copy.view_layers:
            for child in layer.layer_collection.children:
                child.exclude = True
        for shown in [obj, scene.camera, *baked_lamps(scene)]:
            if shown is not None and shown.name not in copy.collection.objects:
                copy.collection.objects.link(shown)
        copy.render.engine = ENGINES[engine]
        if engine == "EEVEE":
            copy.eevee.taa_render_samples = samples
            tile = check_tile(scene.eevee.volumetric_tile_size, user_width, size[0])
            copy.eevee.volumetric_tile_size = tile
        else:
            # The harness's deterministic CPU settings, with the user's volume marching (the
            # bake sets it) and a plain count of samples, as a user renders.
            ob.cycles_settings(copy, bounces)
            copy.cycles.volume_biased = scene.cycles.volume_biased
            copy.cycles.samples = samples
        ob.linear_exr_output(copy)
        copy.render.resolution_x, copy.render.resolution_y = size
        with tempfile.TemporaryDirectory(prefix="occlux-engine-") as folder:
            path = Path(folder) / "render.exr"
            seconds = ob.render_still(copy, path, f"the {engine} render of the baked scene")
            channels, _ = ob.read_channels(path)
        return np.stack([channels[c] for c in "RGB"], axis=-1).astype(np.float64), seconds
    finally:
        bpy.data.scenes.remove(copy)


def truth_of_bake(
    context: bpy.types.Context, check: BakedCheck, obj: bpy.types.Object
) -> truth.Truth:
    """Cycles' truth of the baked scene: the volume object `obj` with its plain material, lit
    by every light the bake holds."""
    import occlux.blender as ob

    def plain() -> bpy.types.Material:
        name = f"{ob.PREFIX}-plain"
        return material.volume_material(name, check.points, None, 1.0, None, check.box)

    kinds = (scenes.WORLD, scenes.SUN, scenes.POINT)
    return truth.figure_truth(context, obj, kinds, check.bounces, check.g, check.size, plain=plain)


def finish(
    context: bpy.types.Context,
    check: BakedCheck,
    cycles_renders: Callable[..., Steps],
) -> Steps:
    """The main-thread part: the engine's render, then Cycles' truth (`cycles_renders`: one
    step per render). Returns the engine's image and seconds, the truth's scene description and
    Cycles' image."""
    import occlux.blender as ob

    settings = context.scene.occlux
    engine, samples = settings.check_engine, settings.check_engine_samples
    obj = bpy.data.objects.get(check.volume_object)
    if obj is None:
        raise ValueError(f"the baked volume object '{check.volume_object}' is gone")
    yield Step(f"{engine} render", 0, 1)
    image, seconds = render_as_it_stands(
        context.scene, obj, engine, samples, check.size, check.bounces
    )
    try:
        built = truth_of_bake(context, check, obj)
        cycles = yield from cycles_renders(built.scene, settings.check_spp, settings.check_seeds)
    finally:
        ob.remove_built()
    return image, seconds, built, cycles


def against_checked_truth(
    scene: bpy.types.Scene, obj: bpy.types.Object, report: Path, engine: str, samples: int
) -> dict:
    """The baked volume `obj` rendered by `engine` at `samples` samples (`render_as_it_stands`)
    against the truth the check that wrote `report` rendered (its EXR's `cycles` layers, at its
    size and bounces): `occlux.image_error`'s figures and the render's seconds. For measuring an
    engine at several sample counts against one truth."""
    import occlux
    import occlux.blender as ob

    checked = json.loads(report.read_text())
    channels, _ = ob.read_channels(str(report).removesuffix("-report.json") + ".exr")

    def layer(name: str) -> np.ndarray:
        return np.stack([channels[f"{name}.{c}"] for c in "RGB"], axis=-1).astype(np.float64)

    size = tuple(checked["size"])
    bounces = checked["truth"]["bounces"]
    image, seconds = render_as_it_stands(scene, obj, engine, samples, size, bounces)
    truth, stderr = layer("cycles"), layer("cycles_stderr")
    figures = occlux.image_error(image, truth, checked["background"], stderr)
    return {**figures, "seconds": seconds}
