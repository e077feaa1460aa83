#!/usr/bin/env bash
# A long fuzzing campaign: every target in turn, each until ten million executions or SECONDS
# (default 600) have passed, at the lowest CPU priority, so that it can run in the background
# beside other work:
#
#   nohup bash fuzz/campaign.sh 600 > /tmp/campaign.out 2>&1 &
#
# Each target's corpus lives in fuzz/campaign/corpus/<target> and grows from one campaign to
# the next; the first campaign starts it from run.sh's seeds (fuzz/corpus/<target>) where they
# are. Appends one line per target to fuzz/campaign/results.txt (executions, seconds, coverage,
# crashes: libFuzzer stops at the first); its log and any crashing input stay in
# fuzz/campaign/logs/ and fuzz/campaign/artifacts/<target>/. Limits as run.sh's: 2 GiB of
# memory and 10 s per input, beyond which an input is a finding.
set -uo pipefail
cd "$(dirname "$0")"
seconds="${1:-600}"
targets=(nrrd nifti npy raw vdb scene settle roundtrip render)
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked --version 0.13.2
mkdir -p campaign/logs
results=campaign/results.txt
stamp=$(date +%Y%m%d-%H%M%S)
for target in "${targets[@]}"; do
  corpus="campaign/corpus/$target"
  artifacts="campaign/artifacts/$target"
  log="campaign/logs/$stamp-$target.log"
  mkdir -p "$corpus" "$artifacts"
  # A target that does not build is a line in the results, not the end of the campaign.
  if ! nice -n 19 cargo fuzz build --sanitizer none -O "$target" >"$log" 2>&1; then
    echo "$(date -Is) $target: does not build, see fuzz/$log" >>"$results"
    continue
  fi
  seeds=()
  [ -d "corpus/$target" ] && seeds=("corpus/$target")
  before=$(find "$artifacts" -type f | wc -l)
  start=$SECONDS
  nice -n 19 cargo fuzz run --sanitizer none -O "$target" "$corpus" "${seeds[@]}" -- \
    -runs=10000000 -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 \
    -max_len=65536 -artifact_prefix="$artifacts/" -print_final_stats=1 >>"$log" 2>&1
  elapsed=$((SECONDS - start))
  # The final statistics when libFuzzer got to print them, else its last progress line.
  runs=$(grep -oE 'stat::number_of_executed_units: *[0-9]+' "$log" | grep -oE '[0-9]+$' ||
    grep -oE '^#[0-9]+' "$log" | tail -1 | tr -d '#')
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1)
  crashes=$(($(find "$artifacts" -type f | wc -l) - before))
  where=""
  [ "$crashes" -gt 0 ] && where="; inputs in fuzz/$artifacts/"
  echo "$(date -Is) $target: ${runs:-?} executions in $elapsed s (${cov:-cov: ?}), $crashes crashes$where, log fuzz/$log" >>"$results"
done
