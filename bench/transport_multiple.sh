#!/usr/bin/env bash
# Multiple scattering (8 bounces) against Occlux's `multiple` reference: IPSVI's diffusion
# term (scattering = "multiple") beside the transport solve (scattering = "transport") and
# single scattering, at g = 0 and 0.6, on the engine at albedo 0.5, 0.8 and 0.95 and on the
# bonsai, the tooth and the CT phantom at their presets' albedos.
# Usage: bash bench/transport_multiple.sh [OUT_DIR]   (about 10 minutes on 2 cores)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-$root/target/transport-multiple}
occlux=${OCCLUX:-$root/target/release/occlux}
mkdir -p "$out/scenes"
shared=$(cd "$root/../shared" && pwd)
for albedo in 0.5 0.95; do
    sed -e "s|\.\./\.\./shared|$shared|" -e "s|albedo = \[0.8, 0.8, 0.8\]|albedo = [$albedo, $albedo, $albedo]|" \
        "$root/examples/engine-sun.toml" > "$out/scenes/engine-albedo-$albedo.toml"
done
scenes="$root/examples/engine-sun.toml,$out/scenes/engine-albedo-0.5.toml,$out/scenes/engine-albedo-0.95.toml"
scenes="$scenes,$root/examples/bonsai.toml,$root/examples/tooth.toml,$root/examples/demo.toml"
for g in 0 0.6; do
    "$occlux" ipsvi-accuracy --scenes "$scenes" --size 128 --spp 512 --scattering multiple \
        --g "$g" --repeats 3 -o "$out/g$g.json" | tee "$out/g$g.log"
done
