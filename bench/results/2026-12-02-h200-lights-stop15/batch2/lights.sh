#!/usr/bin/env bash
# binaries: /work/wt/lights-gpu/myriad-bench-base /work/wt/lights-gpu/myriad-bench-b2
# Issue 16 (lights worktree), batch 2. base = main at 8fcf58c (before this stop); main = main now
# (with batch 1's work, b9a5e19); b2 = branch lights after b9a5e19: the counting pass records only
# the pairs it finds (a bit per cluster of the box first), the mark pass gathers an 8x8 group's
# slices in shared memory (a cursor read per slice, not per pixel), and the large lights' queue
# gets one atomic per workgroup.
# b2's switches: MYRIAD_ASSIGN_STEPS=1 (assign's steps timed apart), MYRIAD_ASSIGN_PAIR_SLOTS=1,
# MYRIAD_ASSIGN_GROUPS (binned workgroups, default 1024). b2 = branch lights at 08:43 (after 7871c8d).
# Runs from the repo root; output in $OUT/ (bench.txt, summary.txt, validate.txt, log.txt, *.json).
set -u
O=${OUT:-/tmp/out}; mkdir -p "$O"
R="bash .devpack/run.sh"; B=.devpack/bin
MAIN=$B/myriad-bench-main
BASE=$B/myriad-bench-base-lights; [[ -x $BASE ]] || BASE=$B/myriad-bench-base
NEW=$B/myriad-bench-b2-lights; [[ -x $NEW ]] || NEW=$B/myriad-bench-b2
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 113 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
LARGE="--width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
bench() {
  local name=$1 env=$2 bin=$3; shift 3
  local t; t=$(left); if (( t < 7 )); then log "skip $name (time)"; return; fi
  (( t > 25 )) && t=25
  log "$name [$env] $*"
  echo "=== $name [$env] $*" >> "$O/bench.txt"
  env $env timeout $t $R $bin "$@" --json "$O/$name.json" >> "$O/bench.txt" 2>&1
  echo "exit $?" >> "$O/bench.txt"
}
validate() {
  local name=$1 env=$2; shift 2
  local t; t=$(left); if (( t < 8 )); then log "skip validate $name (time)"; return; fi
  (( t > 25 )) && t=25
  log "validate $name [$env] $*"
  echo "=== validate $name [$env] $*" >> "$O/validate.txt"
  env $env timeout $t $R $NEW --validate "$@" >> "$O/validate.txt" 2>&1; echo "exit $?" >> "$O/validate.txt"
}
size() { case $1 in 1080) echo "--width 1920 --height 1080";; 2160) echo "--width 3840 --height 2160";; esac; }
for tag in 1080 2160; do
  bench base-$tag-r1 "X=0" $BASE $(size $tag) $COMMON
  bench main-$tag-r1 "X=0" $MAIN $(size $tag) $COMMON
  bench b2-$tag-r1 "X=0" $NEW $(size $tag) $COMMON
done
bench base-large "X=0" $BASE $LARGE
bench main-large "X=0" $MAIN $LARGE
bench b2-large "X=0" $NEW $LARGE
bench b2-steps-1080 "MYRIAD_ASSIGN_STEPS=1" $NEW $(size 1080) $COMMON
bench b2-steps-2160 "MYRIAD_ASSIGN_STEPS=1" $NEW $(size 2160) $COMMON
bench b2-steps-large "MYRIAD_ASSIGN_STEPS=1" $NEW $LARGE
validate 1m-1080 "X=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate 1m-2160 "X=0" --width 3840 --height 2160 --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate large-2160 "X=0" $LARGE --frames 3 --warmup 1
validate all-10k-1080 "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer auto
validate slots1-1m-1080 "MYRIAD_ASSIGN_PAIR_SLOTS=1" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
for tag in 1080 2160; do
  bench base-$tag-r2 "X=0" $BASE $(size $tag) $COMMON
  bench main-$tag-r2 "X=0" $MAIN $(size $tag) $COMMON
  bench b2-$tag-r2 "X=0" $NEW $(size $tag) $COMMON
done
bench main-large-r2 "X=0" $MAIN $LARGE
bench b2-large-r2 "X=0" $NEW $LARGE
bench main-1080-r3 "X=0" $MAIN $(size 1080) $COMMON
bench b2-1080-r3 "X=0" $NEW $(size 1080) $COMMON
bench b2-g512-1080 "MYRIAD_ASSIGN_GROUPS=512" $NEW $(size 1080) $COMMON
bench b2-g2048-1080 "MYRIAD_ASSIGN_GROUPS=2048" $NEW $(size 1080) $COMMON
log done
grep -E "^===|^floor|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
