#!/usr/bin/env bash
# A recorded fuzz campaign: each target in turn until a number of executions, from its grown
# corpus and its seeds, then one row of docs/FORMATS.md's campaign table per target.
#   fuzz/campaign.sh BUILD_DIR TARGET:RUNS...
# BUILD_DIR is the fuzz build of fuzz/run.sh, with its fdv and fuzz_ros1_seed_writer (the seed
# script runs both), not only the fuzz targets. Meant to run on an otherwise idle core, or under
# `nice -n 19` beside other work (the rate is then a share of a core, and the table says so).
# FDV_FUZZ_TIMEOUT is libFuzzer's wall-clock limit per input, 10 s by default; a campaign that gets
# a small share of a core needs more, or its slow inputs end it as timeouts. FDV_FUZZ_MAX_LEN is
# the largest input in bytes, 65536 by default; a smaller one fuzzes shorter inputs (a corpus
# input above it is cut), so a table row run with it says so. ASAN_OPTIONS defaults to
# malloc_context_size=4: allocation stacks of 4 frames, not 30. Over hours of deeply nested YAML
# the sanitizer's store of distinct stacks grew until saving one was 25 % of fuzz_options' time;
# a finding's report then names 4 frames, and its kept input replays in full.
# A finding stops that target (its input under BUILD_DIR/fuzz/findings/TARGET/) and the script
# goes on with the next; the exit status is 1 if any target found something.
set -euo pipefail
cd "$(dirname "$0")/.."
build=$(realpath "$1")
shift
/usr/bin/python3 fuzz/make_seeds.py "$build" > /dev/null
export ASAN_OPTIONS=${ASAN_OPTIONS:-malloc_context_size=4}

stat() { grep -E "^stat::$2:" "$1" | awk '{print $2}'; }
status=0
echo "| target | runs | runs/s (wall) | cov | ft | corpus | peak RSS | findings |"
echo "|---|---|---|---|---|---|---|---|"
for spec in "$@"; do
  target=${spec%%:*} runs=${spec##*:}
  corpus=$build/fuzz/corpus/$target findings=$build/fuzz/findings/$target log=$build/fuzz/$target.campaign.log
  mkdir -p "$corpus" "$findings"
  start=$(date +%s)
  found=none
  # A long run's RSS grows with ASan's quarantine and the corpus (FORMATS.md "Fuzzing").
  if ! "$build/fuzz/$target" -runs="$runs" -timeout="${FDV_FUZZ_TIMEOUT:-10}" -rss_limit_mb=2048 -max_len="${FDV_FUZZ_MAX_LEN:-65536}" \
      -print_final_stats=1 -artifact_prefix="$findings/" "$corpus" "$build/fuzz/seeds/$target" > "$log" 2>&1; then
    found="$(grep -m1 -oE 'ERROR: [^ ]+: [a-z-]+|contract broken: .*' "$log" || echo 'stopped: see log')"
    status=1
  fi
  seconds=$(( $(date +%s) - start ))
  done_runs=$(stat "$log" number_of_executed_units)
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1 | awk '{print $2}')
  ft=$(grep -oE 'ft: [0-9]+' "$log" | tail -1 | awk '{print $2}')
  files=$(find "$corpus" -type f | wc -l)
  size=$(du -sh "$corpus" | cut -f1)
  echo "| \`$target\` | $done_runs | $(( done_runs / (seconds > 0 ? seconds : 1) )) | $cov | $ft | $files ($size) |" \
       "$(stat "$log" peak_rss_mb) MB | $found |"
done
exit $status
