#!/usr/bin/env bash
# The GPU check, in one command for anyone with a GPU (docs/usage.md, "Benchmarks and the GPU check"):
#   bash bench/gpu-check.sh [--allow-software] [--quick] [--repeats N] [-o PATH]
# builds the release binary and the test binaries if needed, refuses a software adapter
# (lavapipe/llvmpipe, WARP: its "GPU" timings would be the CPU's) unless --allow-software, runs
# the CPU/GPU twin tests and the other GPU tests on the adapter, then `occlux bench` for every
# method on the GPU and the CPU (images 512^2 and 1024^2, the CT phantom at 256^3 and 512^3,
# each case's warm-up render excluded, medians of up to --repeats timed runs, fewer once a
# case's runs add up to 2 s), and writes one JSON (default bench/gpu-check.json): the adapter
# (name, driver, backend, device type), the tests' counts, the bench's table and each phase's
# seconds. The tests and the bench are meant to take under 5 minutes on a 16-core machine with
# a hardware GPU (the JSON says whether they did; the build is not counted): the CPU's renders
# at 512^3 dominate (about 330 s a round of the methods at 1024^2 on 2 cores, measured at
# 256^3 and scaled), hence the per-case budget. --quick times images of 64^2 and 128^2 on 32^3
# and 64^3 phantoms, so that the whole check runs in minutes on lavapipe. Any failure: a
# message naming the phase, and exit status 1 (2 for bad options).
set -euo pipefail
cd "$(dirname "$0")/.."

out=bench/gpu-check.json
allow_software=0
quick=0
repeats=3

usage() {
  sed -n '2,3p' "$0" | sed 's/^# \{0,1\}//'
}

while [ $# -gt 0 ]; do
  case "$1" in
    --allow-software) allow_software=1 ;;
    --quick) quick=1 ;;
    --repeats)
      [ $# -ge 2 ] || { echo "gpu-check: --repeats needs a count" >&2; exit 2; }
      repeats="$2"
      shift
      ;;
    -o | --out)
      [ $# -ge 2 ] || { echo "gpu-check: $1 needs a path" >&2; exit 2; }
      out="$2"
      shift
      ;;
    -h | --help) usage; exit 0 ;;
    *) echo "gpu-check: unknown option '$1'" >&2; usage >&2; exit 2 ;;
  esac
  shift
done

if [ "$quick" = 1 ]; then
  mode=quick image_sizes=64,128 volume_sizes=32,64
else
  mode=full image_sizes=512,1024 volume_sizes=256,512
fi
# Tests and bench together, on a real GPU (the build excluded).
budget_s=300
# A case's timed runs end once they add up to this (after one): slow CPU cases at 512^3 get one
# timed run after their warm-up, fast ones --repeats.
case_seconds=2
# The twin tests (tests/*_twins.rs, and the VAO twins in tests/vao.rs), the GPU layer's
# (tests/gpu_volume.rs) and every test naming the GPU (the bake's twins, the kernels' layouts).
tests_filter='binary(/_twins$/) | binary(gpu_volume) | binary(vao) | test(/gpu|twins/)'

export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
# The GPU tests fail rather than skip without an adapter (the Python ones too with this set).
export OCCLUX_REQUIRE_GPU=1
# The workspace's one feature set (as .ci/run builds it), so nothing is built twice.
export PYO3_BUILD_EXTENSION_MODULE=1
export CARGO_TERM_COLOR=never
target_dir="${CARGO_TARGET_DIR:-target}"
bin="$target_dir/release/occlux"

fail() {
  echo "gpu-check: FAILED: $*" >&2
  exit 1
}
now() { date +%s.%N; }
seconds_since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

echo "== build: the occlux binary and the test binaries (release, if needed)"
t=$(now)
cargo build --release --locked -p occlux-cli || fail "the release build of occlux"
cargo test --no-run --release --locked --workspace || fail "the release build of the tests"
build_s=$(seconds_since "$t")

echo "== adapter"
hardware=--hardware
[ "$allow_software" = 1 ] && hardware=
"$bin" adapter $hardware -o "$work/adapter.json" ||
  fail "the adapter (above): none opened, or a software rasterizer without --allow-software"

echo "== CPU/GPU twin tests and GPU tests: $tests_filter"
t=$(now)
tests_status=0
cargo nextest run --release --locked --workspace --profile gpu-check -E "$tests_filter" ||
  tests_status=$?
tests_s=$(seconds_since "$t")
junit="$target_dir/nextest/gpu-check/junit.xml"
[ -s "$junit" ] || fail "the tests wrote no $junit (nextest status $tests_status)"
suites=$(grep -o '<testsuites [^>]*>' "$junit" | head -n 1)
count() { printf '%s' "$suites" | sed -n "s/.* $1=\"\([0-9]*\)\".*/\1/p"; }
tests_run=$(count tests) tests_failed=$(count failures) tests_errors=$(count errors)
[ -n "$tests_run" ] && [ -n "$tests_failed" ] && [ -n "$tests_errors" ] ||
  fail "no test counts in $junit"
tests_failed=$((tests_failed + tests_errors))
tests_passed=$((tests_run - tests_failed))
# A filter that selects nothing checks nothing.
if [ "$tests_status" = 0 ] && [ "$tests_failed" = 0 ] && [ "$tests_run" -gt 0 ]; then
  tests_ok=true
else
  tests_ok=false
fi

echo "== bench: CT phantom $volume_sizes, images $image_sizes, CPU and GPU, up to $repeats repeats"
t=$(now)
bench_ok=true
"$bin" bench --volume-sizes "$volume_sizes" --sizes "$image_sizes" --device both \
  --repeats "$repeats" --case-seconds "$case_seconds" --json "$work/bench.json" || bench_ok=false
bench_s=$(seconds_since "$t")
[ "$bench_ok" = true ] || echo null >"$work/bench.json"

timed_s=$(awk -v a="$tests_s" -v b="$bench_s" 'BEGIN { printf "%.1f", a + b }')
within_budget=$(awk -v t="$timed_s" -v b="$budget_s" 'BEGIN { print (t <= b) ? "true" : "false" }')
passed=false
[ "$tests_ok" = true ] && [ "$bench_ok" = true ] && passed=true
software=false
[ "$allow_software" = 1 ] && software=true

mkdir -p "$(dirname "$out")"
{
  printf '{\n  "check": "bench/gpu-check.sh",\n  "mode": "%s",\n' "$mode"
  printf '  "allow_software": %s,\n  "passed": %s,\n' "$software" "$passed"
  printf '  "adapter": '
  cat "$work/adapter.json"
  printf ',\n  "tests": {"filter": "%s", "run": %s, "passed": %s, "failed": %s, "ok": %s},\n' \
    "$tests_filter" "$tests_run" "$tests_passed" "$tests_failed" "$tests_ok"
  printf '  "seconds": {"build": %s, "tests": %s, "bench": %s, "tests_and_bench": %s},\n' \
    "$build_s" "$tests_s" "$bench_s" "$timed_s"
  printf '  "budget_seconds": %s,\n  "within_budget": %s,\n' "$budget_s" "$within_budget"
  printf '  "bench": '
  cat "$work/bench.json"
  printf '\n}\n'
} >"$out.partial"
mv "$out.partial" "$out"

echo "== $out: tests $tests_passed/$tests_run passed; tests ${tests_s} s, bench ${bench_s} s"
[ "$within_budget" = true ] || [ "$mode" = quick ] ||
  echo "gpu-check: warning: tests and bench took ${timed_s} s, over the ${budget_s} s meant" >&2
[ "$tests_ok" = true ] || fail "the twin/GPU tests: $tests_failed of $tests_run failed (above)"
[ "$bench_ok" = true ] || fail "occlux bench (above)"
echo "gpu-check: passed"
