#!/usr/bin/env bash
# Benchmark: peak memory (max RSS) of `occlux info`, `render`, `export` and every `ao` method on
# scans as a new user has them, as multiples of the input's dense float32 size: an N^3 float32
# NRRD and an M^3 uint16 NRRD (CT-like, mostly air; bench/make_scan.py writes them slice by
# slice). Each command runs once under GNU time (`/usr/bin/time -v`) on the CPU; wall times are
# for orientation only (not side-by-side measurements). Writes one JSON with every row.
#
#     bash bench/memory.sh [--float N] [--uint16 M] [--json FILE] [--occlux PATH] [--python PY]
#
# Defaults: --float 512 (512 MiB as f32), --uint16 1024 (4 GiB as f32: about 10 GiB of RAM for
# the AO methods and 25 minutes on 2 cores), --json bench/memory.json. --float 0 or --uint16 0
# leaves that scan out. The goals (issue 40): render <= 1.2x, export <= 1.5x, every ao <= 2.5x.
# Needs /usr/bin/time (apt-get install time), python3 with numpy (the project's .venv has it),
# and disk for the scans in $TMPDIR (N^3 * 4 + M^3 * 2 bytes).
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
float_size=512
uint16_size=1024
json=$repo/bench/memory.json
occlux=$repo/target/release/occlux
python=$repo/.venv/bin/python
while [[ $# -gt 0 ]]; do
    case $1 in
        --float) float_size=$2; shift 2 ;;
        --uint16) uint16_size=$2; shift 2 ;;
        --json) json=$2; shift 2 ;;
        --occlux) occlux=$2; shift 2 ;;
        --python) python=$2; shift 2 ;;
        *) echo "unknown argument $1 (see the header of $0)" >&2; exit 2 ;;
    esac
done
[[ -x $occlux ]] || { echo "no occlux binary at $occlux: cargo build --release" >&2; exit 1; }
[[ -x /usr/bin/time ]] || { echo "needs /usr/bin/time (apt-get install time)" >&2; exit 1; }
[[ -x $python ]] || python=python3

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
rows=$work/rows.tsv
: > "$rows"

# One scene per scan: IPSVI under a low sun at 1024^2, the camera framing the content.
scene_for() {
    cat > "$2" <<EOF
[volume]
path = "$1"
[classification]
preset = "ct-bone"
[camera]
position = [3.2, -3.2, 2.6]
target = [0, 0, 0]
fov_deg = 36
width = 1024
height = 1024
frame = "content"
[[lights]]
type = "directional"
direction = [-0.3, -1.0, 1.2]
irradiance = 2.0
[render]
method = "ipsvi"
EOF
}

# measure LABEL DENSE_MIB ARGS...: runs occlux ARGS under GNU time, appends a row, prints it.
measure() {
    local label=$1 dense=$2
    shift 2
    if ! /usr/bin/time -v "$occlux" "$@" > "$work/log" 2>&1; then
        cat "$work/log" >&2
        echo "failed: occlux $*" >&2
        exit 1
    fi
    local rss wall
    rss=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$work/log")
    wall=$(sed -n 's/.*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$work/log")
    printf '%s\t%s\t%s\t%s\t%s\n' "$label" "$*" "$rss" "$dense" "$wall" >> "$rows"
    awk -v a="$label" -v k="$rss" -v d="$dense" -v w="$wall" \
        'BEGIN { printf "%-44s %7.0f MiB %6.2fx %9s\n", a, k / 1024, k / 1024 / d, w }'
    rm -rf "$work/out"
}

# run_scan TYPE N COMMANDS...: makes the scan, then measures each command (info, render,
# export, or an ao method).
run_scan() {
    local type=$1 size=$2
    shift 2
    local file=$work/scan-$type-$size.nrrd scene=$work/scan-$type-$size.toml
    "$python" "$repo/bench/make_scan.py" --size "$size" --type "$type" --out "$file"
    scene_for "$file" "$scene"
    local dense
    dense=$(awk -v n="$size" 'BEGIN { printf "%.3f", n * n * n * 4 / 1048576 }')
    echo "$type $size^3: dense f32 $dense MiB"
    for command in "$@"; do
        local label="$type $size^3 $command"
        case $command in
            info) measure "$label" "$dense" info "$file" ;;
            render | export) measure "$label" "$dense" "$command" "$scene" -o "$work/out" --device cpu ;;
            ao-default) measure "$label" "$dense" ao "$scene" -o "$work/out" --device cpu ;;
            ao-*) measure "$label" "$dense" ao "$scene" -o "$work/out" --device cpu \
                --method "${command#ao-}" ;;
        esac
    done
    rm -f "$file"
}

printf '%-44s %11s %7s %9s\n' command "max RSS" ratio wall
every_ao=(ao-default ao-cdf ao-gauss ao-penner ao-sweep ao-sweep-physical)
if (( float_size > 0 )); then
    run_scan float32 "$float_size" info render export "${every_ao[@]}"
fi
if (( uint16_size > 0 )); then
    run_scan uint16 "$uint16_size" info render ao-default ao-sweep-physical export
fi

python3 - "$rows" "$json" "$("$occlux" --version 2>/dev/null || echo occlux)" "$(nproc)" <<'EOF'
import json, os, sys
rows_path, out, version, cpus = sys.argv[1:5]
rows = []
for line in open(rows_path):
    label, args, rss_kib, dense_mib, wall = line.rstrip("\n").split("\t")
    rows.append({
        "case": label,
        "command": "occlux " + args,
        "max_rss_mib": round(int(rss_kib) / 1024, 1),
        "dense_f32_mib": float(dense_mib),
        "ratio": round(int(rss_kib) / 1024 / float(dense_mib), 3),
        "wall": wall,
    })
with open("/proc/meminfo") as f:
    total = next(int(l.split()[1]) for l in f if l.startswith("MemTotal:"))
record = {"occlux": version, "cpus": int(cpus), "mem_total_gib": round(total / 2**20, 1),
          "goals": {"render": 1.2, "export": 1.5, "ao": 2.5}, "rows": rows}
partial = out + ".partial"
with open(partial, "w") as f:
    json.dump(record, f, indent=1)
os.replace(partial, out)
print(f"wrote {out}")
EOF
