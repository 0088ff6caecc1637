#!/usr/bin/env bash
# binaries: /work/wt/lights/build/gpu/myriad-bench-main /work/wt/lights/build/gpu/myriad-bench-final
# Issue 16 (lights worktree), batch 2: main at fca682d against what landed (final = main 7ceb20f, with the
# binned cluster assignment, the parallel cluster scan and positions-only light animation).
# final's benchmark switches: MYRIAD_CLUSTER_ASSIGN=atomic (one global atomic per light-cluster
# pair, as before, with the new scan), MYRIAD_CLUSTER_TILE=32 (32-pixel cluster tiles).
# Runs from the repo root; output in $OUT/lights/ (bench.txt, summary.txt, validate.txt, *.json).
# Finishes in < 120 s: each step checks the time left and is skipped when short.
set -u
O=${OUT:-/tmp/out}/lights; mkdir -p "$O"
R="bash .devpack/run.sh"; B=.devpack/bin
MAIN=$B/myriad-bench-main-lights; NEW=$B/myriad-bench-final-lights
[[ -x $MAIN ]] || MAIN=$B/myriad-bench-main; [[ -x $NEW ]] || NEW=$B/myriad-bench-final
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 112 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4"
LARGE="--width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --frames 30 --warmup 5 --max-seconds 4"
bench() {
  local name=$1 env=$2 bin=$3; shift 3
  local t; t=$(left); if (( t < 8 )); then log "skip $name (time)"; return; fi
  (( t > 30 )) && t=30
  log "$name [$env] $*"
  echo "=== $name [$env] $*" >> "$O/bench.txt"
  env $env timeout $t $R $bin "$@" --json "$O/$name.json" >> "$O/bench.txt" 2>&1
  echo "exit $?" >> "$O/bench.txt"
}
validate() {
  local name=$1 env=$2; shift 2
  local t; t=$(left); if (( t < 10 )); then log "skip validate $name (time)"; return; fi
  (( t > 30 )) && t=30
  log "validate $name [$env] $*"
  echo "=== validate $name [$env] $*" >> "$O/validate.txt"
  env $env timeout $t $R $NEW --validate "$@" >> "$O/validate.txt" 2>&1; echo "exit $?" >> "$O/validate.txt"
}
size() { case $1 in 1080) echo "--width 1920 --height 1080";; 2160) echo "--width 3840 --height 2160";; esac; }
for round in 1 2; do
  for tag in 1080 2160; do
    bench main-$tag-r$round "X=0" $MAIN $(size $tag) $COMMON
    bench final-$tag-r$round "X=0" $NEW $(size $tag) $COMMON
    bench final-atomic-$tag-r$round "MYRIAD_CLUSTER_ASSIGN=atomic" $NEW $(size $tag) $COMMON
  done
  if (( round == 1 )); then
    bench main-large "X=0" $MAIN $LARGE
    bench final-large "X=0" $NEW $LARGE
    validate 1m-1080 "X=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1
    validate 1m-2160 "X=0" --width 3840 --height 2160 --techniques clustered --lights 1000000 --frames 3 --warmup 1
    validate large-2160 "X=0" $LARGE --frames 3 --warmup 1
    validate all-10k-1080 "X=0" --lights 10000 --frames 3 --warmup 1
  fi
done
bench final-t32-1080 "MYRIAD_CLUSTER_TILE=32" $NEW $(size 1080) $COMMON
bench final-t32-atomic-1080 "MYRIAD_CLUSTER_TILE=32 MYRIAD_CLUSTER_ASSIGN=atomic" $NEW $(size 1080) $COMMON
bench final-t32-atomic-2160 "MYRIAD_CLUSTER_TILE=32 MYRIAD_CLUSTER_ASSIGN=atomic" $NEW $(size 2160) $COMMON
validate atomic-1m-1080 "MYRIAD_CLUSTER_ASSIGN=atomic" --techniques clustered --lights 1000000 --frames 3 --warmup 1
log done
grep -E "^===|^floor|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
