"""Measures the Blender workflow on a real CT against Cycles' path-traced truth: the guide's
scene (docs/blender.md, "From a script": the tooth, `ct-bone`, a grey sky and the factory lamp
as a sun), at the check's default size and samples, in Blender as a Python module with this
checkout's add-on.

    .venv/bin/python docs/measure_blender_check.py [--volume PATH] [--size 256] [--json OUT]

It prints one line per figure: relative RMSE and bias over the volume's pixels
(docs/architecture.md#error-measure's measure, `occlux.image_error`) against the truth of the sky's
light (the world scattered once, which Check Against Cycles renders from the scene), and Cycles' own
noise:
- Check Against Cycles' reports for the AO-shaded render (sweep-physical) and DOS, and for
  IPSVI under the sun (against the sun's truth);
- Cycles' render of the scene with the AO wired into the material, AMBIENT shading (the
  add-on's default) and ALBEDO shading (the darkened albedo, the only wiring before);
- the Cycles render shaded by DOS's `occlusion` layer as Composite Occlux Layer does (strength
  1): its mean over the render's (the share of the light it keeps).
With --json, the figures also go to a JSON file (for tests/python/test_addon.py).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
# Each printed figure by its label, for --json.
MEASURED: dict[str, dict] = {}


def setup(volume: Path, size: int):
    """The guide's scene, square at `size` pixels, its volume loaded with AO (sweep-physical)."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=False)
    sys.path.insert(0, str(REPO))
    import blender_addon

    blender_addon.register()
    scene = bpy.context.scene
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    s = scene.occlux
    s.volume_path, s.preset, s.device = str(volume), "ct-bone", "cpu"
    s.output_dir = tempfile.mkdtemp(prefix="occlux-measure-") + "/"
    world = scene.world.node_tree.nodes["Background"]
    world.inputs["Color"].default_value = (0.6, 0.6, 0.6, 1.0)
    key = bpy.data.objects["Light"].data
    key.type, key.energy = "SUN", 3.0
    scene.camera.data.lens = 150
    scene.render.resolution_x = scene.render.resolution_y = size
    s.check_size = size
    assert bpy.ops.occlux.import_volume() == {"FINISHED"}, s.status
    s.ao_method = "sweep-physical"
    assert bpy.ops.occlux.compute_ao() == {"FINISHED"}, s.status
    return bpy, scene, s


def check(bpy, s, method: str) -> dict:
    """Check Against Cycles of `method`'s figure; its report."""
    s.check_subject, s.check_method = "FIGURE", method
    assert bpy.ops.occlux.check_cycles() == {"FINISHED"}, s.status
    return json.loads(Path(s.check_report).read_text())


def line(label: str, figures: dict, seconds: str = "") -> None:
    MEASURED[label] = {k: figures[k] for k in ("rel_rmse", "bias", "noise", "pixels")}
    print(
        f"{label:<44} rel RMSE {figures['rel_rmse']:.3f}  bias {figures['bias']:+7.1%}  "
        f"(Cycles' noise {figures['noise']:.3f}, {figures['pixels']} px){seconds}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--volume", type=Path, default=REPO.parent / "shared" / "data" / "scivis" / "tooth.nrrd"
    )
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    if not args.volume.is_file():
        raise SystemExit(f"no volume at {args.volume} (../shared beside the checkout)")
    bpy, scene, s = setup(args.volume, args.size)
    try:
        measure(bpy, scene, s)
    finally:
        shutil.rmtree(s.output_dir)
    if args.json:
        args.json.write_text(json.dumps(MEASURED, indent=2) + "\n")


def measure(bpy, scene, s) -> None:
    """The figures (see the module's docstring), printed."""
    import occlux
    import occlux.blender as ob

    from blender_addon import scenes

    for method in ("ao", "dos", "ipsvi"):
        report = check(bpy, s, method)
        occlux_s, cycles_s = report["occlux_seconds"], report["cycles_seconds"]
        times = f"; Occlux {occlux_s:.2f} s, Cycles {cycles_s:.1f} s"
        line(f"check: {method} vs Cycles ({report['truth']['estimator']})", report, times)
        if method == "ao":  # the sky's truth, as Cycles rendered it from the scene
            exr = Path(s.check_report[: -len("-report.json")] + ".exr")
            layers = ob.read_channels(exr)[0]
            truth = np.stack([layers[f"cycles.{c}"] for c in "RGB"], axis=-1)
            noise = np.stack([layers[f"cycles_stderr.{c}"] for c in "RGB"], axis=-1)
    background = float(np.mean(scenes.world_radiance(scene)))

    # Cycles' render of the scene itself, the AO in its material, lit by the sky alone.
    bpy.data.objects["Light"].hide_render = True
    renders = {}
    for shading in ("AMBIENT", "ALBEDO"):
        s.ao_shading = shading
        assert bpy.ops.occlux.compute_ao() == {"FINISHED"}, s.status
        ob.cycles_settings(scene, 0)
        renders[shading] = ob.render_scene(scene, s.check_spp, s.check_seeds).mean
        figures = occlux.image_error(renders[shading], truth, background, noise)
        line(f"Cycles render, AO wired as {shading}", figures)
    wired = renders["AMBIENT"]

    # The AMBIENT render shaded by DOS's occlusion layer: render x (1 - (A - V)).
    assert bpy.ops.occlux.render_dos() == {"FINISHED"}, s.status
    dos = ob.read_channels(Path(s.output_dir) / "tooth-dos.exr")[0]
    shade = 1.0 - (dos["occlusion.A"] - dos["occlusion.V"])
    inside = dos["occlusion.A"] > 0.005
    kept = float((wired * shade[..., None])[inside].mean() / wired[inside].mean())
    label = "composite (DOS occlusion, strength 1)"
    MEASURED[label] = {"kept": kept}
    print(f"{label:<44} keeps {kept:.2f} of the render's light")


if __name__ == "__main__":
    main()
