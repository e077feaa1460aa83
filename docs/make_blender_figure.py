"""Runs the guide's script (the Python block under "From a script" in docs/blender.md) as the
guide says to run it: in Blender as a Python module, on the factory scene, with this checkout's
add-on (blender_addon/) and this Python's `occlux` package, in a folder that holds the volume it
names; then copies the figure it renders to --out.

    .venv/bin/python docs/make_blender_figure.py [--volume PATH] [--out PNG]

It prints the add-on's status after the script and the scene's objects, one line each
(`status: ...`, `objects: ...`), for the test that runs it
(tests/python/test_addon.py::test_the_guides_script_makes_its_figure_on_the_factory_scene).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
GUIDE = REPO / "docs" / "blender.md"
# The file the script reads and the figure it writes, both in its working folder.
VOLUME, FIGURE = "tooth.nrrd", "tooth-figure.png"


def guide_script() -> str:
    """The one Python block of the guide's "From a script" section."""
    section = GUIDE.read_text().split("## From a script", 1)[1]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.DOTALL)
    if len(blocks) != 1:
        raise SystemExit(f"{GUIDE}: expected one python block under 'From a script'")
    return blocks[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--volume", type=Path, default=REPO.parent / "shared" / "data" / "scivis" / VOLUME
    )
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "blender-first-figure.png")
    args = parser.parse_args()
    if not args.volume.is_file():
        raise SystemExit(f"no volume at {args.volume} (../shared beside the checkout)")
    script = guide_script()
    work = Path(tempfile.mkdtemp(prefix="occlux-guide-"))
    try:
        (work / VOLUME).symlink_to(args.volume.resolve())
        os.chdir(work)

        import bpy

        bpy.ops.wm.read_factory_settings(use_empty=False)
        sys.path.insert(0, str(REPO))
        import blender_addon

        blender_addon.register()
        started = time.perf_counter()
        exec(compile(script, str(GUIDE), "exec"), {"__name__": "__main__"})
        print(f"status: {bpy.context.scene.occlux.status}")
        print(f"objects: {', '.join(sorted(o.name for o in bpy.data.objects))}")
        args.out.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(work / FIGURE, args.out)
        print(f"wrote {args.out} in {time.perf_counter() - started:.1f} s")
    finally:
        shutil.rmtree(work)


if __name__ == "__main__":
    main()
