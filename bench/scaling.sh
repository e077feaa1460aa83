#!/usr/bin/env bash
# Benchmark: how the time of IPSVI, DOS (n = 5) and AO-shaded DVR grows with the image's pixels
# and the volume's voxels, on the CPU: `occlux bench` on the CT phantom at two sides and two
# image sides (the median of the timed renders after a warm-up), then the fitted exponents
# t ~ pixels^a and t ~ voxels^b between them, as a markdown table and a JSON.
#
#     bash bench/scaling.sh [--volume-sizes 256,512] [--sizes 1024,2048] [--repeats 3]
#                           [--json bench/scaling.json] [--occlux PATH]
#
# The defaults are the issue's figures: 1024^2 and 2048^2 on 512^3, and 256^3 beside it for
# the voxels' exponent (about 30 minutes on 2 cores). a = log(t2 / t1) / log(p2 / p1) at the
# larger volume; b the same over voxels at the smaller image.
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
volume_sizes=256,512
sizes=1024,2048
repeats=3
json=$repo/bench/scaling.json
occlux=$repo/target/release/occlux
while [[ $# -gt 0 ]]; do
    case $1 in
        --volume-sizes) volume_sizes=$2; shift 2 ;;
        --sizes) sizes=$2; shift 2 ;;
        --repeats) repeats=$2; shift 2 ;;
        --json) json=$2; shift 2 ;;
        --occlux) occlux=$2; shift 2 ;;
        *) echo "unknown argument $1 (see the header of $0)" >&2; exit 2 ;;
    esac
done
[[ -x $occlux ]] || { echo "no occlux binary at $occlux: cargo build --release" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$occlux" bench --volume-sizes "$volume_sizes" --sizes "$sizes" --repeats "$repeats" \
    --device cpu --methods ipsvi,dos-n5,ao --json "$work/bench.json"

python3 - "$work/bench.json" "$json" <<'EOF'
import json, math, os, sys
bench_path, out = sys.argv[1:3]
bench = json.load(open(bench_path))
rows = bench["rows"]
times = {(r["method"], r["volume_dims"][0], r["size"]): r["median_ms"] for r in rows}
sides = sorted({r["volume_dims"][0] for r in rows})
images = sorted({r["size"] for r in rows})
fits = []
for method in dict.fromkeys(r["method"] for r in rows):
    fit = {"method": method, "median_ms": {}}
    for (m, side, size), ms in times.items():
        if m == method:
            fit["median_ms"][f"{size}^2 on {side}^3"] = ms
    if len(images) >= 2:
        side, (p1, p2) = sides[-1], (images[0], images[-1])
        t1, t2 = times[(method, side, p1)], times[(method, side, p2)]
        fit["pixels_exponent"] = math.log(t2 / t1) / math.log((p2 / p1) ** 2)
    if len(sides) >= 2:
        size, (s1, s2) = images[0], (sides[0], sides[-1])
        t1, t2 = times[(method, s1, size)], times[(method, s2, size)]
        fit["voxels_exponent"] = math.log(t2 / t1) / math.log((s2 / s1) ** 3)
    fits.append(fit)
cases = sorted({(size, side) for (_, side, size) in times})
head = " | ".join(f"{size}^2, {side}^3 (ms)" for size, side in cases)
print(f"| method | {head} | pixels exponent | voxels exponent |")
print("|---" * (len(cases) + 3) + "|")
for fit in fits:
    cells = " | ".join(f"{fit['median_ms'][f'{size}^2 on {side}^3']:.0f}" for size, side in cases)
    a, b = fit.get("pixels_exponent", float("nan")), fit.get("voxels_exponent", float("nan"))
    print(f"| {fit['method']} | {cells} | {a:.2f} | {b:.2f} |")
record = {"cpu_threads": bench["cpu_threads"], "repeats": bench["repeats"], "fits": fits,
          "bench": bench}
partial = out + ".partial"
with open(partial, "w") as f:
    json.dump(record, f, indent=1)
os.replace(partial, out)
print(f"wrote {out}")
EOF
