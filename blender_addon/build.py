"""Packs the add-on: the Blender extension zip (with the `occlux` wheel inside) and a legacy
add-on zip (for Blender Pythons that already have `occlux` installed).

    python blender_addon/build.py [--wheel dist/occlux-*.whl] [--out dist]

Without --wheel it builds one with maturin (release). The extension is packed by Blender's own
extension tool (the same as `blender --command extension build`), found in the bpy wheel or
given with --blender-ext.
"""

from __future__ import annotations

import argparse
import re
import shutil
import site
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
SOURCES = (
    "__init__.py",
    "properties.py",
    "material.py",
    "nodes.py",
    "panel.py",
    "scenes.py",
    "eevee.py",
    "operators/__init__.py",
    "operators/jobs.py",
    "operators/volume.py",
    "operators/bake.py",
    "operators/series.py",
    "operators/render.py",
    "truth.py",
    "operators/check.py",
    "operators/check_baked.py",
    "operators/composite.py",
    "operators/stage.py",
)


def blender_ext() -> Path:
    for root in site.getsitepackages():
        tool = Path(root) / "bpy/5.0/scripts/addons_core/bl_pkg/cli/blender_ext.py"
        if tool.is_file():
            return tool
    sys.exit("Blender's extension tool was not found: install bpy==5.0.1 or pass --blender-ext")


def build_wheel(out: Path) -> Path:
    subprocess.run(
        [
            sys.executable,
            "-m",
            "maturin",
            "build",
            "--release",
            "-m",
            str(REPO / "plugin" / "Cargo.toml"),
            "-o",
            str(out),
        ],
        check=True,
    )
    return next(out.glob("occlux-*.whl"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--wheel", type=Path, help="the occlux wheel (default: build one)")
    parser.add_argument("--out", type=Path, default=REPO / "dist")
    parser.add_argument("--blender-ext", type=Path, help="Blender's blender_ext.py")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        wheel = args.wheel or build_wheel(Path(tmp) / "wheel")
        stage = Path(tmp) / "occlux"
        (stage / "wheels").mkdir(parents=True)
        for name in SOURCES:
            (stage / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(HERE / name, stage / name)
        shutil.copy(wheel, stage / "wheels" / wheel.name)
        manifest = (HERE / "blender_manifest.toml").read_text()
        manifest = re.sub(
            r"^wheels = \[\]$", f'wheels = ["./wheels/{wheel.name}"]', manifest, flags=re.M
        )
        (stage / "blender_manifest.toml").write_text(manifest)
        tool = args.blender_ext or blender_ext()
        subprocess.run(
            [
                sys.executable,
                str(tool),
                "build",
                "--source-dir",
                str(stage),
                "--output-dir",
                str(args.out),
            ],
            check=True,
        )
    legacy = args.out / "occlux-legacy-addon.zip"
    with zipfile.ZipFile(legacy, "w", zipfile.ZIP_DEFLATED) as z:
        for name in SOURCES:
            z.write(HERE / name, f"occlux_addon/{name}")
    print(f"wrote {args.out / 'occlux-0.1.0.zip'} and {legacy}")


if __name__ == "__main__":
    main()
