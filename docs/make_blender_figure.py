"""Renders docs/blender-first-figure.png headless: the guide's five steps (docs/blender.md) run
by the add-on's own operators in Blender as a Python module (bpy), then Cycles.

    .venv/bin/python docs/make_blender_figure.py [--scene examples/tooth.toml] [--out PNG]

The scene file gives the volume (fit, preset, density scale), the camera, the ambient light (as
the world's colour) and directional lights (as suns); Occlux's AO volume then darkens the
albedo. The add-on is imported from this checkout (blender_addon/) with the `occlux` package of
this Python.
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
import tempfile
import time
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", type=Path, default=REPO / "examples" / "tooth.toml")
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "blender-first-figure.png")
    parser.add_argument("--size", type=int, nargs=2, default=(320, 320), metavar=("W", "H"))
    parser.add_argument("--samples", type=int, default=32)
    args = parser.parse_args()
    toml = tomllib.loads(args.scene.read_text())

    import bpy
    from mathutils import Vector

    sys.path.insert(0, str(REPO))
    import blender_addon

    blender_addon.register()
    work = Path(tempfile.mkdtemp(prefix="occlux-figure-"))
    scene = bpy.context.scene
    for obj in list(bpy.data.objects):  # the factory cube, light and camera
        bpy.data.objects.remove(obj)

    # Steps 1-2: the volume file, its classification and where Occlux writes its grids.
    settings = scene.occlux
    volume = toml["volume"]
    settings.volume_path = str((args.scene.parent / volume["path"]).resolve())
    settings.fit = volume.get("fit", 2.0)
    classification = toml.get("classification", {})
    settings.preset = classification.get("preset", "ct-bone")
    settings.density_scale = classification.get("density_scale", 1.0)
    settings.output_dir = str(work / "out") + "/"
    settings.device = "cpu"
    # Step 3: the AO volume, darkening the albedo.
    settings.ao_method, settings.ao_radius, settings.ao_shading = "cdf", 8, "ALBEDO"
    started = time.perf_counter()
    assert bpy.ops.occlux.compute_ao() == {"FINISHED"}, settings.status
    print(f"{settings.status} in {time.perf_counter() - started:.1f} s")

    # Step 4: the scene file's camera (vertical field of view) and lights.
    cam = toml["camera"]
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    camera.location = cam["position"]
    camera.rotation_mode = "QUATERNION"
    forward = Vector(cam.get("target", (0, 0, 0))) - camera.location
    camera.rotation_quaternion = forward.to_track_quat("-Z", "Y")
    camera.data.sensor_fit = "VERTICAL"
    camera.data.angle_y = math.radians(cam.get("fov_deg", 40.0))
    scene.camera = camera
    ambient = [0.0, 0.0, 0.0]
    for i, light in enumerate(toml.get("lights", [])):
        if light["type"] == "ambient":
            radiance = light["radiance"]
            ambient = [radiance] * 3 if isinstance(radiance, int | float) else radiance
        elif light["type"] == "directional":
            sun = bpy.data.objects.new(f"Sun{i}", bpy.data.lights.new(f"Sun{i}", "SUN"))
            scene.collection.objects.link(sun)
            sun.data.energy, sun.data.angle = light["irradiance"], 0.0
            sun.rotation_mode = "QUATERNION"
            sun.rotation_quaternion = Vector(light["direction"]).to_track_quat("Z", "Y")
    scene.world = scene.world or bpy.data.worlds.new("World")
    background = next(
        n for n in scene.world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground"
    )
    background.inputs["Color"].default_value = (*ambient, 1.0)
    background.inputs["Strength"].default_value = 1.0

    # Step 5: render with Cycles.
    render = scene.render
    render.engine = "CYCLES"
    render.resolution_x, render.resolution_y = args.size
    render.resolution_percentage = 100
    scene.cycles.device = "CPU"
    scene.cycles.samples = args.samples
    scene.cycles.use_denoising = True  # OpenImageDenoise: a clean picture from few samples
    scene.cycles.volume_bounces = 1
    scene.view_settings.view_transform = "Standard"
    render.image_settings.media_type = "IMAGE"
    render.image_settings.file_format = "PNG"
    render.filepath = str(args.out.resolve())
    started = time.perf_counter()
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    print(f"wrote {args.out} in {time.perf_counter() - started:.1f} s")
    shutil.rmtree(work)  # the grids Occlux wrote for this render


if __name__ == "__main__":
    main()
