#!/usr/bin/env bash
# Packs the add-on in one command: dist/occlux-0.1.0.zip (the Blender extension, its `occlux`
# wheel linked against glibc 2.28, so it loads on every Linux distribution Blender 5 runs on)
# and dist/occlux-legacy-addon.zip. Needs Rust (cargo) and Python 3.11 or newer; maturin and
# zig (the linker that targets the old glibc) go into a venv of their own, .pack-venv.
#
#     bash blender_addon/pack.sh [--out DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
command -v cargo >/dev/null || { echo "pack.sh needs Rust: https://rustup.rs" >&2; exit 1; }
[ -x .pack-venv/bin/python ] || python3 -m venv .pack-venv
.pack-venv/bin/pip install -q --disable-pip-version-check "maturin[zig]==1.16.0"
# maturin finds zig through the Python on PATH (python -m ziglang): the venv's.
PATH="$PWD/.pack-venv/bin:$PATH" .pack-venv/bin/python blender_addon/build.py "$@"
