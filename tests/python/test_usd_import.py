"""The USD round trip: `occlux export` writes a stage, the extension's Import Occlux Stage (what
a user runs, File > Import or the Occlux panel) brings it into Blender with the scene's render
size and camera, one Volume object with the VDB's grids and no empties for the grids, and Cycles
then frames the volume as Occlux did: the silhouettes of the two renders overlap.

Blender runs in a subprocess with the extension installed, as in test_addon.py (whose fixture
builds the extension zip and whose `blender` runs the script)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from occlux_testing import oiio_read, run_occlux
from test_addon import blender

WIDTH, HEIGHT = 128, 80
# A sphere off the camera's axis (centred away from the target) in a wide image: a wrong image
# size, aspect, field of view or camera transform moves or scales its silhouette.
SCENE = f"""
background = 0.2
[volume]
phantom = "sphere"
size = 32
centre = [0.35, 0.0, 0.2]
[classification]
points = [{{ value = 0.0, sigma_t = 0 }}, {{ value = 1.0, sigma_t = 16, albedo = [0.8, 0.8, 0.8] }}]
[camera]
position = [0.5, -4.0, 1.2]
target = [0, 0, 0]
fov_deg = 30
width = {WIDTH}
height = {HEIGHT}
[[lights]]
type = "ambient"
radiance = 0.5
[[lights]]
type = "directional"
direction = [-0.3, -1.0, 1.2]
irradiance = 2.0
"""
# A stage without render settings: the operator refuses it and adds nothing.
NOT_OCCLUX = '#usda 1.0\ndef Xform "Thing"\n{\n}\n'

# The pixels where a render is at least half opaque (alpha = 1 - transmittance in both).
SILHOUETTE_ALPHA = 0.5
MIN_IOU = 0.98


# Run in Blender after STAGE, PLAIN and OUT are set.
IMPORT_AND_RENDER = """
scene = bpy.context.scene
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
result["factory_size"] = [scene.render.resolution_x, scene.render.resolution_y]
result["refused"] = attempt(bpy.ops.occlux.import_stage, filepath=PLAIN)
result["after_refusal"] = len(bpy.data.objects)
result["import"] = attempt(bpy.ops.occlux.import_stage, filepath=STAGE)
r = scene.render
result["size"] = [r.resolution_x, r.resolution_y, r.resolution_percentage]
result["camera"] = scene.camera.name if scene.camera else None
result["objects"] = sorted([o.type, o.name] for o in bpy.data.objects)
volume = next(o for o in bpy.data.objects if o.type == "VOLUME")
assert volume.data.grids.load(), volume.data.grids.error_message
result["grids"] = sorted(g.name for g in volume.data.grids)
result["vdb"] = bpy.path.abspath(volume.data.filepath)

# Only the silhouette is compared: the material keeps its density (the `density` grid,
# Occlux's extinction) and absorbs only (black albedo), so Cycles' alpha is the
# transmittance with no scattering noise.
nodes = volume.active_material.node_tree.nodes
principled = next(n for n in nodes if n.bl_idname == "ShaderNodeVolumePrincipled")
principled.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
r.engine = "CYCLES"
r.film_transparent = True
c = scene.cycles
c.device, c.samples, c.seed = "CPU", 16, 0
c.use_adaptive_sampling = c.use_denoising = False
c.volume_biased = True  # ray-marched transmittance: alpha with little noise
# Occlux samples pixel centres: the narrowest filter puts Cycles' samples there too.
c.pixel_filter_type, c.filter_width = "BLACKMAN_HARRIS", 0.01
r.image_settings.media_type = "IMAGE"
r.image_settings.file_format = "OPEN_EXR"
r.image_settings.color_mode = "RGBA"
r.image_settings.color_depth = "32"
r.filepath = OUT
bpy.ops.render.render(write_still=True)
"""


def silhouette_iou(a: np.ndarray, b: np.ndarray) -> float:
    inside_a, inside_b = a > SILHOUETTE_ALPHA, b > SILHOUETTE_ALPHA
    return float((inside_a & inside_b).sum() / (inside_a | inside_b).sum())


def test_the_imported_stage_renders_with_occluxs_size_and_framing(
    extension: Path,
    tmp_path: Path,
) -> None:
    scene = tmp_path / "sphere.toml"
    scene.write_text(SCENE)
    out = tmp_path / "out"
    run_occlux("export", str(scene), "-o", str(out), "--device", "cpu", "--quiet")
    (tmp_path / "plain.usda").write_text(NOT_OCCLUX)
    cycles = tmp_path / "cycles.exr"
    paths = (out / "sphere.usda", tmp_path / "plain.usda", cycles)
    script = "STAGE, PLAIN, OUT = {!r}, {!r}, {!r}\n".format(*map(str, paths)) + IMPORT_AND_RENDER
    result, output = blender(extension, tmp_path / "user", script)
    assert result["factory_size"] == [1920, 1080], "the factory size the stage must replace"
    assert "no RenderSettings" in result["refused"] and result["after_refusal"] == 0, output
    assert result["import"] == ["FINISHED"], output
    assert result["size"] == [WIDTH, HEIGHT, 100]
    assert result["camera"] == "Camera"
    # The stage's root is the one empty: none for the grids (field prims) or the render settings.
    assert result["objects"] == [
        ["CAMERA", "Camera"],
        ["EMPTY", "World"],
        ["LIGHT", "Sun1"],
        ["VOLUME", "Volume"],
    ]
    assert result["grids"] == ["density", "value"]
    assert Path(result["vdb"]) == out / "sphere.vdb"

    occlux_alpha = oiio_read(out / "sphere.exr")["beauty.A"]
    cycles_alpha = oiio_read(cycles)["A"]
    assert cycles_alpha.shape == occlux_alpha.shape == (HEIGHT, WIDTH)
    inside = occlux_alpha > SILHOUETTE_ALPHA
    assert 0.1 < inside.mean() < 0.5, "the volume covers part of the image"
    assert not inside[:, 0].any() and not inside[:, -1].any(), "and lies within it"
    iou = silhouette_iou(occlux_alpha, cycles_alpha)
    assert iou >= MIN_IOU, f"silhouette IoU {iou:.4f}"
    # The bar resolves framing errors under a pixel: Occlux's own silhouette moved by one
    # pixel either way falls below it.
    for shift in ((0, 1), (1, 0)):
        moved = np.roll(occlux_alpha, shift, axis=(0, 1))
        assert silhouette_iou(occlux_alpha, moved) < MIN_IOU
