"""Packs the add-on: the Blender extension zip (with the `occlux` wheel inside) and a legacy
add-on zip (for Blender Pythons that already have `occlux` installed).

    python blender_addon/build.py [--wheel dist/occlux-*.whl] [--native] [--out dist]

`bash blender_addon/pack.sh` runs it with what it needs (Rust and Python 3.11 on the machine;
maturin and zig in a venv of its own).

Without --wheel it builds one with maturin (release): by default linked with zig against glibc
2.28 (`manylinux_2_28`), the oldest glibc Blender 5's Linux builds run on, so that the wheel
loads on every distribution Blender 5 supports; with --native, against this machine's glibc
(faster: no second build of the dependencies; the tests use it). The extension is packed by
Blender's own extension tool (the same as `blender --command extension build`) when it is
found in the bpy wheel or given with --blender-ext, which validates the manifest; without it,
by zipping the staged folder as that tool does (the manifest at the zip's root), and Blender
validates the manifest when it installs the zip.
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
    "transfer.py",
    "eevee.py",
    "operators/__init__.py",
    "operators/jobs.py",
    "operators/volume.py",
    "operators/bake.py",
    "operators/classify.py",
    "operators/series.py",
    "operators/render.py",
    "truth.py",
    "operators/check.py",
    "operators/check_baked.py",
    "operators/composite.py",
    "operators/stage.py",
)


# The oldest glibc Blender 5's official Linux builds need (they are built on Rocky Linux 8).
PORTABLE = "manylinux_2_28"


def blender_ext() -> Path | None:
    """Blender's extension tool from the bpy wheel, if installed."""
    for root in site.getsitepackages():
        tool = Path(root) / "bpy/5.0/scripts/addons_core/bl_pkg/cli/blender_ext.py"
        if tool.is_file():
            return tool
    return None


def build_wheel(out: Path, native: bool) -> Path:
    portable = [] if native else ["--zig", "--compatibility", PORTABLE]
    manifest = str(REPO / "plugin" / "Cargo.toml")
    command = ["maturin", "build", "--release", *portable, "-m", manifest, "-o", str(out)]
    subprocess.run([sys.executable, "-m", *command], check=True)
    return next(out.glob("occlux-*.whl"))


def zip_extension(stage: Path, out: Path) -> Path:
    """The staged extension folder zipped as Blender's tool zips it: its files at the root,
    named ID-VERSION.zip from the manifest."""
    manifest = (stage / "blender_manifest.toml").read_text()
    fields = dict(re.findall(r'^(id|version) = "([^"]+)"$', manifest, flags=re.M))
    target = out / f"{fields['id']}-{fields['version']}.zip"
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as z:
        for path in sorted(stage.rglob("*")):
            if path.is_file():
                z.write(path, path.relative_to(stage).as_posix())
    return target


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--wheel", type=Path, help="the occlux wheel (default: build one)")
    parser.add_argument("--out", type=Path, default=REPO / "dist")
    parser.add_argument("--blender-ext", type=Path, help="Blender's blender_ext.py")
    parser.add_argument(
        "--native", action="store_true", help=f"the wheel for this machine's glibc ({PORTABLE})"
    )
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        wheel = args.wheel or build_wheel(Path(tmp) / "wheel", args.native)
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
        if tool is None:
            zip_extension(stage, args.out)
        else:
            build = ["build", "--source-dir", str(stage), "--output-dir", str(args.out)]
            subprocess.run([sys.executable, str(tool), *build], check=True)
    legacy = args.out / "occlux-legacy-addon.zip"
    with zipfile.ZipFile(legacy, "w", zipfile.ZIP_DEFLATED) as z:
        for name in SOURCES:
            z.write(HERE / name, f"occlux_addon/{name}")
    print(f"wrote {args.out / 'occlux-0.1.0.zip'} and {legacy}")


if __name__ == "__main__":
    main()
