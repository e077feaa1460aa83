"""Load Volume framing the scene camera on the visible content when asked (Frame camera), in
the Blender extension, headless (bpy in a subprocess, the extension built, installed and
enabled as in test_addon.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from test_addon import CAMERA_AND_WORLD, blender, phantom_npy

FRAMING = """
import numpy as np
import occlux
scenes = sys.modules["bl_ext.user_default.occlux.scenes"]
# Far off and looking past the volume's centre: the phantom is a speck off-centre.
camera.location = (9.0, -7.0, 5.0)
camera.rotation_quaternion = (Vector((0.6, 0.2, 0.0)) - camera.location).to_track_quat("-Z", "Y")
scene.render.resolution_x, scene.render.resolution_y = 80, 60
s = scene.occlux
s.volume_path = {npy!r}
s.preset, s.device, s.output_dir = "ct-soft-tissue", "cpu", {out!r}
s.frame_camera = {frame}
bpy.context.view_layer.update()
forward_before = list(-camera.matrix_world.col[2].xyz)
result["position_before"] = list(camera.matrix_world.translation)
# The core's framing of the same camera, as `occlux render` frames it (frame = "content").
tree = scenes.volume_tree(scenes.VolumeInput.from_settings(s), s)
tree["camera"] = scenes.framed_camera(scene)
core = scenes.build(tree)
core.settle()
result["core_position"] = core.describe()["camera"]["position"]
result["load"] = list(bpy.ops.occlux.import_volume())
result["status"] = s.status
bpy.context.view_layer.update()
result["forward"] = [forward_before, list(-camera.matrix_world.col[2].xyz)]
result["position"] = list(camera.matrix_world.translation)
# Where the volume shows in the camera's image: Occlux's render of the scene, its alpha.
described = scenes.scene_tree(bpy.context, scenes.selected_source(bpy.context), 80, 60,
                              render={{"method": "unshaded"}})
alpha = np.asarray(occlux.render(scenes.build(described.tree), device="cpu").beauty)[..., 3]
np.save({alpha_path!r}, alpha)
"""


def framed(extension: Path, tmp_path: Path, frame: bool) -> tuple[dict, np.ndarray]:
    tmp_path.mkdir()
    alpha_path = tmp_path / "alpha.npy"
    script = CAMERA_AND_WORLD + FRAMING.format(
        npy=str(phantom_npy(tmp_path)),
        out=str(tmp_path / "out") + "/",
        frame=frame,
        alpha_path=str(alpha_path),
    )
    result, output = blender(extension, tmp_path / "user", script)
    assert result["load"] == ["FINISHED"], output
    return result, np.load(alpha_path)


def test_load_volume_frames_the_camera_on_the_content_when_asked(
    extension: Path, tmp_path: Path
) -> None:
    """With Frame camera, the camera keeps its view direction and moves where the core frames
    the visible content (`occlux render`'s frame = "content": the content's box within a 5 %
    margin), and the volume then shows in the middle of the image, larger than from the far
    camera; without it, the camera stays."""
    result, alpha = framed(extension, tmp_path / "framed", True)
    before, after = (np.asarray(v) for v in result["forward"])
    assert np.allclose(before, after, atol=1e-5), result
    assert np.allclose(result["position"], result["core_position"], atol=1e-4), result
    assert "framed camera 'Camera'" in result["status"], result["status"]
    spans, centre = coverage(alpha)
    # The box's corners stick out of the rounded phantom seen along a diagonal: the phantom
    # spans about half of the frame (0.49 x 0.55 measured).
    assert max(spans) >= 0.45, spans
    assert np.allclose(centre, 0.5, atol=0.08), centre

    result, alpha = framed(extension, tmp_path / "unframed", False)
    assert "framed camera" not in result["status"], result
    assert np.allclose(result["position"], result["position_before"], atol=1e-6), result
    spans, centre = coverage(alpha)
    assert max(spans) < 0.35 and not np.allclose(centre, 0.5, atol=0.08), (spans, centre)


def coverage(alpha: np.ndarray) -> tuple[tuple[float, float], tuple[float, float]]:
    """The shares of the image's width and height the content's box spans, and its centre in
    image coordinates (0..1)."""
    rows, cols = np.nonzero(alpha > 0.02)
    height, width = alpha.shape
    spans = ((cols.max() + 1 - cols.min()) / width, (rows.max() + 1 - rows.min()) / height)
    centre = ((cols.min() + cols.max() + 1) / 2 / width, (rows.min() + rows.max() + 1) / 2 / height)
    return spans, centre
