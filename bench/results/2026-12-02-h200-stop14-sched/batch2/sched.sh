#!/usr/bin/env bash
# binaries: /work/wt/sched/build/gpu/myriad-server /work/wt/sched/build/gpu/myriad-stream-bench
# Issue 18 (sched worktree), batch 2. Batch 1 showed: main's 4K regression is the render-thread copy
# (fif2: GPU idle 12.4 ms before each 4K frame, copy 12.1 ms); encoded in place + YCbCr: 4K 107 fps,
# 8 streams 310 frames/s, GPU-bound (3.2 ms a frame, 0.02 ms idle), --overlap-frames with two
# timestamps a frame gained nothing. This batch: validation, the default at --seconds 5, and whether
# no timestamps at all lets frames of different sessions overlap (--gpu-timestamps none).
# Binaries: branch sched at 1a14113 (= main at 05:56 UTC). Output in $OUT/sched/; < 120 s.
set -u
O=${OUT:-/tmp/out}/sched; mkdir -p "$O"
R="bash .devpack/run.sh"; B=.devpack/bin
SB=$B/myriad-stream-bench-sched; SV=$B/myriad-server-sched
[[ -x $SB ]] || SB=$B/myriad-stream-bench; [[ -x $SV ]] || SV=$B/myriad-server
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 114 - ($(date +%s) - t0) )); }
# run NAME BENCH-ARGS -- SERVER-ARGS
run() {
  local name=$1; shift
  local t; t=$(left); if (( t < 10 )); then log "skip $name (time)"; return; fi
  (( t > 25 )) && t=25
  log "$name: $*"
  timeout $t $R $SB --server $SV --lights 100000 --radius 0.5,2 --size 1920x1080 --requests 20 \
    --json "$O/$name.json" "$@" > "$O/$name.txt" 2>&1
  echo "exit $?" >> "$O/$name.txt"
}
# validation first (the lead's runner exports VK_LAYER_PATH and LD_LIBRARY_PATH in batch 2)
if [[ -z ${VK_LAYER_PATH:-} ]] && ls .devpack/data/*alidation*.json >/dev/null 2>&1; then
  export VK_LAYER_PATH=$PWD/.devpack/data
fi
run validate --streams 2 --seconds 2 --large 1280x720 -- --validate
run validate-none-overlap --streams 2 --seconds 1 --large none --requests 3 -- --validate --gpu-timestamps none --overlap-frames
run fif2-new --large 3840x2160 --streams 8 --seconds 5 -- --frames-in-flight 2
S8="--large none --streams 8 --seconds 3"
run fif2-none-overlap $S8 -- --frames-in-flight 2 --gpu-timestamps none --overlap-frames
run fif2-none $S8 -- --frames-in-flight 2 --gpu-timestamps none
run fif3-none-overlap $S8 -- --frames-in-flight 3 --gpu-timestamps none --overlap-frames
run fif4-none-overlap $S8 -- --frames-in-flight 4 --gpu-timestamps none --overlap-frames
run fif3-frame-overlap $S8 -- --frames-in-flight 3 --gpu-timestamps frame --overlap-frames
log done
grep -h "readback memory\|rendering on" "$O"/fif2-new.txt | head -2 | tee -a "$O/log.txt"
grep -h '"messages"' "$O"/validate*.json | tee -a "$O/log.txt"
