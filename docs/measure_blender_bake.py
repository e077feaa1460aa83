"""Measures Bake Light on real CTs against Cycles' path-traced truth of the same Blender scene
(Check Against Cycles of the baked scene): per volume and lighting (the sky alone, a sun alone,
both), EEVEE with the bake through the check, and Cycles with the bake at 1, 4 and 16 samples
against the same truth (8 volume bounces: the bake holds the world's and the sun's multiple
scattering). Each scene is the guide's (docs/blender.md, "From a script": a grey sky, the
factory lamp as a sun, the camera at 150 mm), square at --size pixels, in Blender as a Python
module with this checkout's add-on. EEVEE's time with the bake is stated as a ratio to the same
EEVEE scene (the bake's EEVEE settings) with the volume's plain material.

    .venv/bin/python docs/measure_blender_bake.py [--volumes tooth:ct-bone,bonsai:ct-bone,...]
        [--size 128] [--truth-spp 512] [--json OUT]

It prints one line per volume, lighting and engine: relative RMSE and bias over the volume's
pixels (docs/architecture.md#error-measure, `occlux.image_error`), and the truth's own noise.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SCIVIS = REPO.parent / "shared" / "data" / "scivis"
DEFAULT_VOLUMES = "tooth:ct-bone,bonsai:ct-bone,engine:ct-bone"
LIGHTINGS = {"sky": (1.0, False), "sun": (0.0, True), "both": (1.0, True)}


def setup(volume: Path, preset: str, size: int, lighting: str, truth_spp: int):
    """The guide's scene lit by `lighting`, its volume loaded."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=False)
    if not hasattr(bpy.types.Scene, "occlux"):  # the add-on, once per session
        sys.path.insert(0, str(REPO))
        import blender_addon

        blender_addon.register()
    scene = bpy.context.scene
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    s = scene.occlux
    s.volume_path, s.preset, s.device = str(volume), preset, "cpu"
    s.output_dir = tempfile.mkdtemp(prefix="occlux-measure-") + "/"
    sky, sun = LIGHTINGS[lighting]
    world = scene.world.node_tree.nodes["Background"]
    world.inputs["Color"].default_value = (0.6, 0.6, 0.6, 1.0)
    world.inputs["Strength"].default_value = sky
    key = bpy.data.objects["Light"]
    key.data.type, key.data.energy = "SUN", 3.0
    key.hide_render = not sun
    scene.camera.data.lens = 150
    scene.render.resolution_x = scene.render.resolution_y = size
    s.check_size, s.check_spp, s.check_seeds = size, truth_spp, 8
    assert bpy.ops.occlux.import_volume() == {"FINISHED"}, s.status
    return bpy, scene, s


def measure(volume: Path, preset: str, size: int, lighting: str, truth_spp: int) -> dict:
    bpy, scene, s = setup(volume, preset, size, lighting, truth_spp)
    from blender_addon.operators import bake, check_baked

    try:
        obj = bpy.context.view_layer.objects.active
        bake.eevee_for(scene, obj)  # the bake's EEVEE settings, for the plain scene's time
        # Each time is the second render's: the first compiles EEVEE's shaders.
        for _ in range(2):
            _, plain_s = check_baked.render_as_it_stands(scene, obj, "EEVEE", 16, (size, size), 0)
        assert bpy.ops.occlux.bake_light() == {"FINISHED"}, s.status
        obj = bpy.context.view_layer.objects.active
        s.check_subject, s.check_engine, s.check_engine_samples = "BAKED", "EEVEE", 16
        assert bpy.ops.occlux.check_cycles() == {"FINISHED"}, s.status
        report = Path(s.check_report)
        eevee = json.loads(report.read_text())
        figures = {"eevee_16": {k: eevee[k] for k in ("rel_rmse", "bias", "noise", "pixels")}}
        _, baked_s = check_baked.render_as_it_stands(scene, obj, "EEVEE", 16, (size, size), 0)
        figures["eevee_16"]["seconds"] = baked_s
        figures["eevee_16"]["plain_seconds"] = plain_s
        figures["truth_seconds"] = eevee["cycles_seconds"]
        for spp in (1, 4, 16):
            cycles = check_baked.against_checked_truth(scene, obj, report, "CYCLES", spp)
            figures[f"cycles_{spp}"] = cycles
        return figures
    finally:
        shutil.rmtree(s.output_dir)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--volumes", default=DEFAULT_VOLUMES, help="NAME:PRESET,... in scivis")
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--truth-spp", type=int, default=512)
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    measured: dict[str, dict] = {}
    for item in args.volumes.split(","):
        name, preset = item.split(":")
        path = SCIVIS / f"{name}.nrrd"
        if not path.is_file():
            raise SystemExit(f"no volume at {path} (../shared beside the checkout)")
        for lighting in LIGHTINGS:
            figures = measure(path, preset, args.size, lighting, args.truth_spp)
            measured[f"{name} {lighting}"] = figures
            noise = figures["eevee_16"]["noise"]
            for engine in ("eevee_16", "cycles_1", "cycles_4", "cycles_16"):
                f = figures[engine]
                extra = ""
                if engine == "eevee_16":
                    extra = f", {f['seconds'] / f['plain_seconds']:.2f}x the plain EEVEE time"
                print(
                    f"{name:<8} {lighting:<5} {engine:<10} rel RMSE {f['rel_rmse']:.3f}  "
                    f"bias {f['bias']:+6.1%}  (truth's noise {noise:.3f}){extra}",
                    flush=True,
                )
    if args.json:
        args.json.write_text(json.dumps(measured, indent=2) + "\n")


if __name__ == "__main__":
    main()
