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
# FDV_FUZZ_PROCESSES=N runs a target as N libFuzzer processes sharing its corpus folder (each
# reloads what the others add), each for RUNS/N executions; the row sums their runs and takes the
# largest cov, ft and RSS. One process per free core: N on a shared core only splits it.
# A finding stops that target (its input under BUILD_DIR/fuzz/findings/TARGET/) and the script
# goes on with the next; the exit status is 1 if any target found something.
set -euo pipefail
cd "$(dirname "$0")/.."
build=$(realpath "$1")
shift
/usr/bin/python3 fuzz/make_seeds.py "$build" > /dev/null
export ASAN_OPTIONS=${ASAN_OPTIONS:-malloc_context_size=4}

# A process ended by another's finding may not have printed its statistics.
stat() { { grep -E "^stat::$2:" "$1" || true; } | awk '{print $2}'; }
status=0
echo "| target | runs | runs/s (wall) | cov | ft | corpus | peak RSS | findings |"
echo "|---|---|---|---|---|---|---|---|"
for spec in "$@"; do
  target=${spec%%:*} runs=${spec##*:}
  corpus=$build/fuzz/corpus/$target findings=$build/fuzz/findings/$target log=$build/fuzz/$target.campaign.log
  mkdir -p "$corpus" "$findings"
  start=$(date +%s)
  found=none
  processes=${FDV_FUZZ_PROCESSES:-1}
  logs=() pids=()
  for ((p = 0; p < processes; ++p)); do
    if ((processes == 1)); then logs+=("$log"); else logs+=("${log%.log}.$p.log"); fi
    # A long run's RSS grows with ASan's quarantine and the corpus (FORMATS.md "Fuzzing").
    "$build/fuzz/$target" -runs=$(( runs / processes )) -timeout="${FDV_FUZZ_TIMEOUT:-10}" -rss_limit_mb=2048 \
      -max_len="${FDV_FUZZ_MAX_LEN:-65536}" -print_final_stats=1 -artifact_prefix="$findings/" \
      "$corpus" "$build/fuzz/seeds/$target" > "${logs[p]}" 2>&1 &
    pids+=($!)
  done
  failed=0
  for pid in "${pids[@]}"; do
    if ! wait "$pid"; then
      failed=1
      kill "${pids[@]}" 2> /dev/null || true  # a finding ends the target's other processes
    fi
  done
  if ((failed)); then
    found="$(cat "${logs[@]}" | grep -m1 -oE 'ERROR: [^ ]+: [a-z-]+|contract broken: .*' || echo 'stopped: see log')"
    status=1
  fi
  seconds=$(( $(date +%s) - start ))
  done_runs=$(for l in "${logs[@]}"; do stat "$l" number_of_executed_units; done | awk '{n += $1} END {print n + 0}')
  rss=$(for l in "${logs[@]}"; do stat "$l" peak_rss_mb; done | sort -n | tail -1)
  cov=$(cat "${logs[@]}" | { grep -oE 'cov: [0-9]+' || true; } | awk '{print $2}' | sort -n | tail -1)
  ft=$(cat "${logs[@]}" | { grep -oE 'ft: [0-9]+' || true; } | awk '{print $2}' | sort -n | tail -1)
  files=$(find "$corpus" -type f | wc -l)
  size=$(du -sh "$corpus" | cut -f1)
  echo "| \`$target\` | $done_runs | $(( done_runs / (seconds > 0 ? seconds : 1) )) | $cov | $ft | $files ($size) |" \
       "$rss MB | $found |"
done
exit $status
