#!/usr/bin/env bash
# binaries: /work/wt/lights-gpu/myriad-bench-b1
# Issue 16 (lights worktree), batch 1: main against branch lights (b1): light assignment records each
# light-cluster pair in its one walk (cluster_assign_binned.comp), the fill pass copies the pairs,
# the counting pass moves animated lights, no buffer clears (the scan leaves cursors inactive).
# Branch lights at 08:12 (after e3d8093: packed bins). b1's switches (environment):
#   MYRIAD_ASSIGN_WALK_LARGE=1   large lights walked inside the binned passes (no indirect passes)
#   MYRIAD_ASSIGN_STEPS=1        assign's steps timed apart (assign ~ 0, assign-mark, -count,
#                                -count-large, -scan, -fill, -fill-large); lighting then omits them
#   MYRIAD_CLUSTER_ASSIGN=atomic per-pair path;  MYRIAD_ANIMATE_SEPARATE=1 animate pass kept
#   MYRIAD_ASSIGN_PACKED=1       one-word bins, twice as many in the same shared memory
#   MYRIAD_ASSIGN_BINS_OVERRIDE, MYRIAD_ASSIGN_PAIR_SLOTS (default 8), MYRIAD_ASSIGN_GROUPS (1024)
# Runs from the repo root; output in $OUT/ (bench.txt, summary.txt, validate.txt, log.txt, *.json).
set -u
O=${OUT:-/tmp/out}; mkdir -p "$O"
R="bash .devpack/run.sh"; B=.devpack/bin
MAIN=$B/myriad-bench-main
NEW=$B/myriad-bench-b1-lights; [[ -x $NEW ]] || NEW=$B/myriad-bench-b1
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 113 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
LARGE="--width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
W="MYRIAD_ASSIGN_WALK_LARGE=1"
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
  bench main-$tag-r1 "X=0" $MAIN $(size $tag) $COMMON
  bench b1-$tag-r1 "X=0" $NEW $(size $tag) $COMMON
  bench walk-$tag-r1 "$W" $NEW $(size $tag) $COMMON
done
bench main-large "X=0" $MAIN $LARGE
bench b1-large "X=0" $NEW $LARGE
bench walk-large "$W" $NEW $LARGE
bench b1-steps-1080 "MYRIAD_ASSIGN_STEPS=1" $NEW $(size 1080) $COMMON
bench walk-steps-1080 "MYRIAD_ASSIGN_STEPS=1 $W" $NEW $(size 1080) $COMMON
bench b1-steps-2160 "MYRIAD_ASSIGN_STEPS=1" $NEW $(size 2160) $COMMON
bench b1-steps-large "MYRIAD_ASSIGN_STEPS=1" $NEW $LARGE
validate 1m-1080 "X=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate 1m-2160 "X=0" --width 3840 --height 2160 --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate large-2160 "X=0" $LARGE --frames 3 --warmup 1
validate walk-1m-1080 "$W" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate walk-large-2160 "$W" $LARGE --frames 3 --warmup 1
validate all-10k-1080 "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer auto
validate slots1-1m-1080 "MYRIAD_ASSIGN_PAIR_SLOTS=1" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
bench packed-2160 "MYRIAD_ASSIGN_PACKED=1" $NEW $(size 2160) $COMMON
bench walkpacked-2160 "MYRIAD_ASSIGN_PACKED=1 $W" $NEW $(size 2160) $COMMON
bench packed-1080 "MYRIAD_ASSIGN_PACKED=1" $NEW $(size 1080) $COMMON
bench b1-atomic-1080 "MYRIAD_CLUSTER_ASSIGN=atomic" $NEW $(size 1080) $COMMON
bench b1-sepanim-1080 "MYRIAD_ANIMATE_SEPARATE=1" $NEW $(size 1080) $COMMON
bench b1-b4096-2160 "MYRIAD_ASSIGN_BINS_OVERRIDE=4096" $NEW $(size 2160) $COMMON
bench b1-g2048-1080 "MYRIAD_ASSIGN_GROUPS=2048" $NEW $(size 1080) $COMMON
bench b1-g2048-2160 "MYRIAD_ASSIGN_GROUPS=2048" $NEW $(size 2160) $COMMON
bench b1-slots4-2160 "MYRIAD_ASSIGN_PAIR_SLOTS=4" $NEW $(size 2160) $COMMON
for tag in 1080 2160; do
  bench main-$tag-r2 "X=0" $MAIN $(size $tag) $COMMON
  bench b1-$tag-r2 "X=0" $NEW $(size $tag) $COMMON
  bench walk-$tag-r2 "$W" $NEW $(size $tag) $COMMON
done
log done
grep -E "^===|^floor|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
