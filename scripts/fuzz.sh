#!/usr/bin/env bash
# The long fuzz run (docs/reliability.md): builds the fuzz preset, seeds build/fuzz-corpus/HARNESS
# from the project's test data (tests/fuzz/make_corpus.py --large: bigger models and DamagedHelmet
# too) and runs each harness in turn on that corpus, which it keeps and grows across runs.
# Crash inputs go to build/fuzz-corpus/artifacts/HARNESS, logs to build/fuzz-corpus/logs.
# Runs at nice 19 so that builds and tests on the same machine are not starved.
#
# Usage: scripts/fuzz.sh [--seconds N | --runs N] [HARNESS...]
#   --seconds N   per harness (default 7200: the issue's 2 hours each)
#   --runs N      per harness, instead of a time (fuzz_model, in fork mode, takes time only)
#   HARNESS       some of: fuzz_json_body fuzz_frame_query fuzz_scene_wire fuzz_cli_multipart
#                 fuzz_upload_files fuzz_model (default: all)
# Prints one line per harness: executions, coverage (cov: edges, ft: features) and corpus size.
set -euo pipefail
cd "$(dirname "$0")/.."
source tests/fuzz/harnesses.sh

limit=(-max_total_time=7200)
harnesses=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --seconds) limit=(-max_total_time="$2"); shift 2 ;;
    --runs) limit=(-runs="$2"); shift 2 ;;
    -*) echo "fuzz.sh: unknown option $1 (see the usage lines)" >&2; exit 2 ;;
    *) harnesses+=("$1"); shift ;;
  esac
done
[[ ${#harnesses[@]} -gt 0 ]] || harnesses=("${fuzz_harnesses[@]}")

command -v clang++ >/dev/null || { echo "fuzz.sh: needs clang (scripts/install-deps.sh --with-test-tools)" >&2; exit 1; }
cmake --preset fuzz >/dev/null
nice -n 19 cmake --build --preset fuzz >/dev/null

build=build/fuzz
keep=build/fuzz-corpus
seeds=$(mktemp -d)
trap 'rm -rf "$seeds"' EXIT
nice -n 19 python3 tests/fuzz/make_corpus.py "$build" "$seeds" --large
mkdir -p "$keep/logs"
status=0
for h in "${harnesses[@]}"; do
  mkdir -p "$keep/$h"
  cp -n "$seeds/$h"/* "$keep/$h"/ 2>/dev/null || true  # new seeds join; the grown corpus stays
  log=$keep/logs/$h.log
  if nice -n 19 bash -c "source tests/fuzz/harnesses.sh; fuzz_run $build/tests/fuzz/$h $keep/$h $keep/artifacts/$h $log ${limit[*]}"; then
    fuzz_summary "$h" "$log"
  else
    status=1
    echo "fuzz.sh: $h FAILED: inputs in $keep/artifacts/$h, log $log"
    grep -vE '^#[0-9]+' "$log" | tail -30
  fi
done
exit "$status"
