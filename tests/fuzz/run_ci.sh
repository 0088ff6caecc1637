#!/usr/bin/env bash
# The CTest `fuzz` (label fuzz): builds nothing; runs every harness of the fuzz build for
# MYRIAD_FUZZ_SECONDS (default 30) on a fresh seed corpus (make_corpus.py) and fails on any crash,
# leak, sanitizer report or timeout, printing the input's path and the report.
# Skips (77) only when clang is absent; fails when clang is there but the fuzz build is not
# (cmake --preset fuzz && cmake --build --preset fuzz, as scripts/test.sh does).
# Usage: run_ci.sh FUZZ_BUILD_DIR WORK_DIR
set -uo pipefail
build=$1 work=$2
source "$(dirname "$0")/harnesses.sh"

if ! command -v clang++ >/dev/null 2>&1; then
  echo "fuzz: skipped: no clang++ (scripts/install-deps.sh --with-test-tools installs it)"
  exit 77
fi
bin=$build/tests/fuzz
for h in "${fuzz_harnesses[@]}" fuzz_wire_seeds; do
  if [[ ! -x $bin/$h ]]; then
    echo "fuzz: $bin/$h is missing: cmake --preset fuzz && cmake --build --preset fuzz"
    exit 1
  fi
done

seconds=${MYRIAD_FUZZ_SECONDS:-30}
rm -rf "$work"
mkdir -p "$work"
python3 "$fuzz_dir/make_corpus.py" "$build" "$work/corpus" || exit 1
failed=()
for h in "${fuzz_harnesses[@]}"; do
  log=$work/$h.log
  # A fixed seed: the same mutations on every CI run (MYRIAD_FUZZ_SEED to vary them).
  if fuzz_run "$bin/$h" "$work/corpus/$h" "$work/artifacts/$h" "$log" -max_total_time="$seconds" \
       -seed="${MYRIAD_FUZZ_SEED:-1}"; then
    fuzz_summary "$h" "$log"
  else
    failed+=("$h")
    echo "fuzz: $h FAILED; input(s) in $work/artifacts/$h; the end of its log:"
    grep -vE '^#[0-9]+' "$log" | tail -40
  fi
done
if [[ ${#failed[@]} -gt 0 ]]; then
  echo "fuzz: failed: ${failed[*]}"
  exit 1
fi
echo "fuzz: ${#fuzz_harnesses[@]} harnesses, ${seconds} s each, no crash, leak or report"
