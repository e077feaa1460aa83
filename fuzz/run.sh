#!/usr/bin/env bash
# Coverage-guided fuzzing of the loaders, the scene parser and what a scene runs through after
# it (settling, the writers, the renderers) with libFuzzer through cargo-fuzz.
#
#   bash fuzz/run.sh --seconds 60         every target for 60 s (what CI runs)
#   bash fuzz/run.sh --runs 1000000 nrrd  one target for a million executions
#   bash fuzz/run.sh --build-only         build the targets and seed the corpora, run nothing
#                                         (CI builds first, then fuzzes while pytest runs)
#
# Builds the targets (no sanitizer: safe Rust; coverage instrumentation only, so the stable
# toolchain does), seeds the corpora from ../shared's volumes and the example scenes
# (fuzz/seed.py), then runs each target with a 2 GiB RSS limit (an out-of-memory is a
# finding) and a 10 s limit per input (a hang is a finding). Prints one line per target:
# executions, seconds, and where any crashing input was saved; exits non-zero on a finding.
set -euo pipefail
cd "$(dirname "$0")"
limit=(-max_total_time=60)
build_only=false
case "${1:-}" in
  --seconds) limit=(-max_total_time="$2"); shift 2 ;;
  --runs) limit=(-runs="$2"); shift 2 ;;
  --build-only) build_only=true; shift ;;
esac
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(nrrd nifti npy raw vdb scene settle roundtrip render)
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked --version 0.13.2
for target in "${targets[@]}"; do
  cargo fuzz build --sanitizer none -O "$target"
done
shared="${OCCLUX_SHARED:-$(cd ../.. && pwd)/shared}"
# The seeds are written by the occlux binary: $OCCLUX_BIN when the caller has just built it
# (CI), else this checkout's release build.
occlux="${OCCLUX_BIN:-}"
if [ -z "$occlux" ]; then
  (cd .. && cargo build --release --quiet -p occlux-cli)
  occlux=../target/release/occlux
fi
rm -rf corpus && python3 seed.py "$occlux" corpus "$shared"
if $build_only; then
  exit 0
fi
status=0
for target in "${targets[@]}"; do
  mkdir -p "artifacts/$target"
  log="artifacts/$target/fuzz.log"
  start=$SECONDS
  if cargo fuzz run --sanitizer none -O "$target" "corpus/$target" -- \
      "${limit[@]}" -rss_limit_mb=2048 -timeout=10 -max_len=65536 \
      -artifact_prefix="artifacts/$target/" -print_final_stats=1 >"$log" 2>&1; then
    verdict="0 crashes, hangs or out-of-memory"
  else
    verdict="FOUND: $(grep -m1 -E 'ERROR|Test unit written' "$log" || tail -1 "$log"); inputs in fuzz/artifacts/$target/"
    status=1
  fi
  seconds=$((SECONDS - start))
  runs=$(grep -oE 'stat::number_of_executed_units: *[0-9]+' "$log" | grep -oE '[0-9]+$' || echo "?")
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1 || true)
  echo "fuzz $target: $runs executions in ${seconds} s ($cov), $verdict"
done
exit $status
