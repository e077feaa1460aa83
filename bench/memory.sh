#!/usr/bin/env bash
# Benchmark: peak memory (max RSS) of `occlux render`, `export` and `ao` on an N^3 float volume
# (the CT phantom, N = 512 by default: 512 MiB of f32), as a multiple of the dense volume.
# Each command runs once under GNU time (`/usr/bin/time -v`); wall times are printed for
# orientation only (they are not side-by-side measurements).
#
#     bash bench/memory.sh [N] [path/to/occlux]
#
# Needs /usr/bin/time (Debian/Ubuntu: apt-get install time) and about 2.1 N^3 * 4 bytes of RAM
# (the sweep's AO: extinction and visibility, each dense). Prints one line per command: max RSS
# in MiB and its ratio to N^3 * 4.
set -euo pipefail

size=${1:-512}
occlux=${2:-target/release/occlux}
repo=$(cd "$(dirname "$0")/.." && pwd)
[[ -x $occlux ]] || { echo "no occlux binary at $occlux: cargo build --release" >&2; exit 1; }
[[ -x /usr/bin/time ]] || { echo "needs /usr/bin/time (apt-get install time)" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The demo scene (CT phantom, soft tissue) at N^3 and a 256^2 image.
sed -e "s/^size = .*/size = $size/" -e "s/^width = .*/width = 256/" \
    -e "s/^height = .*/height = 256/" "$repo/examples/demo.toml" > "$work/scene.toml"
dense_mib=$(( size * size * size * 4 / 1048576 ))
echo "N = $size: dense f32 volume $dense_mib MiB"
printf '%-40s %10s %7s %9s\n' command "max RSS" ratio wall
for args in "render --device cpu" "export --device cpu" "ao --method cdf --radius 10 --device cpu" \
    "ao --method sweep-physical --device cpu"; do
    read -r verb rest <<< "$args"
    # shellcheck disable=SC2086 # the options split into words on purpose
    /usr/bin/time -v "$occlux" $verb "$work/scene.toml" -o "$work/out" $rest \
        > "$work/log" 2>&1 || { cat "$work/log" >&2; exit 1; }
    rss_kib=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$work/log")
    wall=$(sed -n 's/.*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$work/log")
    awk -v a="$args" -v k="$rss_kib" -v d="$dense_mib" -v w="$wall" \
        'BEGIN { printf "%-40s %6.0f MiB %6.2fx %9s\n", a, k / 1024, k / 1024 / d, w }'
    rm -rf "$work/out"
done
