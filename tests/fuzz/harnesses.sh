# Sourced by tests/fuzz/run_ci.sh and scripts/fuzz.sh: the harnesses and how each one is run.
# shellcheck shell=bash

fuzz_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)

# Fast ones first; fuzz_model (Assimp on every input) last.
fuzz_harnesses=(fuzz_json_body fuzz_frame_query fuzz_http_request fuzz_scene_wire
                fuzz_cli_multipart fuzz_upload_files fuzz_hdr fuzz_texture fuzz_model)

# libFuzzer options of one harness beyond the common ones: its dictionary, and the largest input
# it generates (bodies and queries are small; models and archives are not).
fuzz_options() {
  case $1 in
    fuzz_json_body) echo "-dict=$fuzz_dir/json.dict -max_len=8192" ;;
    fuzz_frame_query) echo "-dict=$fuzz_dir/frame_query.dict -max_len=4096" ;;
    fuzz_http_request) echo "-dict=$fuzz_dir/http.dict -max_len=4096" ;;
    fuzz_scene_wire) echo "-dict=$fuzz_dir/scene_wire.dict -max_len=262144" ;;
    fuzz_cli_multipart) echo "-dict=$fuzz_dir/multipart.dict -max_len=8192" ;;
    fuzz_upload_files) echo "-dict=$fuzz_dir/upload_files.dict -max_len=262144" ;;
    fuzz_hdr) echo "-dict=$fuzz_dir/hdr.dict -max_len=65536" ;;
    fuzz_texture) echo "-dict=$fuzz_dir/texture.dict -max_len=262144" ;;
    # Up to DamagedHelmet.glb (3.7 MB), the largest seed of the long run. Fork mode: what the
    # loader child exists to contain does not end the run but is recorded (artifacts) and judged
    # after it (fuzz_triage_model): an input for which Assimp asks for more than 2 GiB (the child's
    # RLIMIT_AS: a "memory" rejection), a crash inside Debian's Assimp ("crash") and an input
    # Assimp spends more than 25 s on (beyond the child's 20 s CPU limit: "timeout").
    fuzz_model) echo "-dict=$fuzz_dir/model.dict -max_len=4194304 -fork=1 -ignore_ooms=1" \
                     "-ignore_crashes=1 -ignore_timeouts=1 -timeout=25" ;;
  esac
}

# Every harness: a crash, an uncaught exception, a leak, any ASan/UBSan report (UBSan is built
# not to recover), an input slower than 10 s or a process over 2 GiB (the loader child's own
# memory limit) is a failure. libFuzzer's own error code (77) would read as a CTest skip, hence 1.
fuzz_common_options=(-timeout=10 -rss_limit_mb=2048 -error_exitcode=1 -timeout_exitcode=1
                     -print_final_stats=1)
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# fuzz_run HARNESS_BINARY CORPUS_DIR ARTIFACT_DIR LOG [libFuzzer options...]
# Runs one harness on (and growing) CORPUS_DIR; crash inputs go to ARTIFACT_DIR. Returns non-zero
# when libFuzzer did or when the log holds a sanitizer report.
fuzz_run() {
  local binary=$1 corpus=$2 artifacts=$3 log=$4
  shift 4
  local name status=0
  name=$(basename "$binary")
  mkdir -p "$corpus" "$artifacts"
  # shellcheck disable=SC2046
  # The harness's own options last: they override the common ones (fuzz_model's -timeout).
  "$binary" "$corpus" "${fuzz_common_options[@]}" $(fuzz_options "$name") \
      -artifact_prefix="$artifacts/" "$@" >"$log" 2>&1 || status=$?
  # A report in the log fails the run even if libFuzzer's exit status missed it (fork mode prints
  # the ignored out-of-memory inputs' reports too: those alone do not count).
  if grep -E 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error:|fuzz: broken promise' "$log" |
       grep -qv 'ERROR: libFuzzer: out-of-memory'; then
    status=${status/#0/1}
  fi
  if [[ $name == fuzz_model && ( $status -ne 0 || -n $(ls "$artifacts") ) ]]; then
    fuzz_triage_model "$binary" "$artifacts" && status=0
  fi
  return "$status"
}

# fuzz_triage_model BINARY ARTIFACT_DIR: replays every crash and timeout input of fuzz_model and
# succeeds only if each one faults or spins inside libassimp (a crash: the first stack frame that
# is not the sanitizer runtime's, its allocator's and string interceptors', or libc's is Assimp's;
# a timeout: Assimp is on the stack): what
# the loader child contains as a "crash" or "timeout" rejection, and no bug of ours (Debian's
# Assimp cannot be fixed here). Such inputs move to ARTIFACT_DIR/assimp/. Any other artifact (a
# crash or timeout in our code, a leak) fails.
fuzz_triage_model() {
  local binary=$1 artifacts=$2 input frame status=0
  mkdir -p "$artifacts/assimp"
  for input in "$artifacts"/*; do
    [[ -f $input ]] || continue
    case $(basename "$input") in
      oom-*) continue ;;
      crash-* | timeout-*) ;;
      *) echo "fuzz_model: $input is not a crash inside Assimp"; status=1; continue ;;
    esac
    local replay
    replay=$("$binary" -runs=1 -timeout=25 "$input" 2>&1)
    # A replay starved by a busy machine can end without a stack: once more before judging it.
    if ! grep -qE '^ +#0 ' <<<"$replay"; then
      replay=$("$binary" -runs=1 -timeout=25 "$input" 2>&1)
    fi
    # A timeout's alarm lands wherever the loop is. Landing in code built without frame pointers
    # (libstdc++'s string growth, called by Assimp's SMD importer), the fast unwinder stops there
    # and the stack shows no Assimp frame (seen in CI-like runs: "crashes outside Assimp: #4 ...
    # _M_replace", "#6 ... __do_dyncast").
    # Each replay's alarm lands elsewhere in the loop: up to three more (12 s each, the slow
    # unwinder) until one shows the Assimp frames.
    for _ in 1 2 3; do
      if [[ $input != */timeout-* ]] || grep -q 'libassimp\.so' <<<"$replay"; then break; fi
      replay=$(ASAN_OPTIONS="$ASAN_OPTIONS:fast_unwind_on_fatal=0" "$binary" -runs=1 -timeout=12 "$input" 2>&1)
    done
    if [[ $input == */timeout-* ]] && ! grep -q 'ERROR: libFuzzer: timeout' <<<"$replay"; then
      # Under 25 s when run alone: the machine was busy (the timeout is wall-clock time).
      echo "fuzz_model: $input does not time out when replayed; set aside in $artifacts/slow"
      mkdir -p "$artifacts/slow" && mv "$input" "$artifacts/slow/"
      continue
    fi
    frame=$(grep -E '^ +#[0-9]+ ' <<<"$replay" |
            grep -vE ' in (__asan|__interceptor|__sanitizer|__ubsan|fuzzer::|__GI_|__pthread_kill)' |
            grep -vE ' in (abort|raise|gsignal|operator new|operator delete|malloc|calloc|realloc|free|mem(cpy|move|set|cmp)|str[a-z]*)\b|/libc\.so|sanitizer_common|compiler-rt' |
            # glibc's own optimized routines (__memset_avx512_unaligned_erms in sysdeps/...)
            grep -vE ' in __(mem|str|wmem)[a-z0-9_]*|/sysdeps/|sysdeps/x86_64' |
            head -1)
    # A timeout's stack is wherever the alarm found the loop (a std::string or glibc routine Assimp
    # called, as often as not): it is Assimp's when Assimp is anywhere on the stack, i.e. the time
    # went inside an Assimp call. A crash must fault in Assimp itself.
    if [[ $input == */timeout-* ]] && grep -E '^ +#[0-9]+ ' <<<"$replay" | grep -q 'libassimp\.so'; then
      mv "$input" "$artifacts/assimp/"
    elif [[ $input == */timeout-* ]] &&
         ! grep -E '^ +#[0-9]+ ' <<<"$replay" | grep -qE 'myriad::|LLVMFuzzerTestOneInput'; then
      # A stack cut short inside libstdc++ (no frame of ours or Assimp's under the alarm, after
      # the replays above): our code, built with frame pointers, would show its frames on top of
      # any loop of its own. Set aside and named, not counted as ours.
      echo "fuzz_model: $input times out with a cut stack (no frame of ours); set aside in $artifacts/unattributed"
      mkdir -p "$artifacts/unattributed" && mv "$input" "$artifacts/unattributed/"
    elif [[ $frame == *libassimp.so* ]]; then
      mv "$input" "$artifacts/assimp/"
    else
      echo "fuzz_model: $input crashes outside Assimp: $frame"
      status=1
    fi
  done
  local contained
  contained=$(find "$artifacts/assimp" -type f | wc -l)
  [[ $contained -eq 0 ]] || echo "fuzz_model: $contained input(s) crash inside Debian's Assimp (contained by the loader child: crash or timeout): $artifacts/assimp"
  return "$status"
}

# One line per run: executions, coverage and features from the final stats (-print_final_stats).
fuzz_summary() {
  local name=$1 log=$2
  local runs cov ft corpus
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  # Fork mode prints no final stats; its status lines start with "#RUNS:".
  [[ -n $runs ]] || runs=$(grep -oE '^#[0-9]+:' "$log" | tail -1 | tr -d '#:')
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -oE 'ft: [0-9]+' "$log" | tail -1 | cut -d' ' -f2)
  corpus=$(grep -oE 'corp: [0-9]+(/[0-9]+[a-zA-Z]*)?' "$log" | tail -1 | cut -d' ' -f2)
  printf '%-20s runs %-10s cov %-6s ft %-7s corpus %s\n' "$name" "${runs:-?}" "${cov:-?}" \
    "${ft:-?}" "${corpus:-?}"
}
