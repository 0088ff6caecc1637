#!/usr/bin/env bash
# binaries: /work/wt/bins/assign/myriad-bench-b2 /work/wt/bins/main/myriad-bench
# Issue 16 assignment (branch assign), batch 1. main = main's bench; b2 = branch assign (git log: WIP assign b2):
# active clusters numbered by the mark pass (shared table indexed by number, 4,096, no hashing),
# the counting walk flattened over the workgroup (MYRIAD_ASSIGN_FLAT=0: per thread as before),
# switches MYRIAD_ASSIGN_GROUPS (most groups, 1024), MYRIAD_ASSIGN_GROUP_LIGHTS (least lights a
# group, 256), MYRIAD_ASSIGN_MOST_CLUSTERS (larger boxes to the large passes, 64), MYRIAD_ASSIGN_STEPS=1;
# the compute G-buffer's resolve marks the clusters (MYRIAD_MARK_IN_GBUFFER=0: the pixel mark pass as before).
set -u
O=$R; MAIN=$BIN/assign-myriad-bench; NEW=$BIN/assign-myriad-bench-b2
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 114 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
LARGE="--width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
bench() {
  local name=$1 env=$2 bin=$3; shift 3
  local t; t=$(left); if (( t < 6 )); then log "skip $name (time)"; return; fi
  (( t > 20 )) && t=20
  log "$name [$env] $*"
  echo "=== $name [$env] $*" >> "$O/bench.txt"
  env $env timeout $t $bin "$@" --json "$O/$name.json" >> "$O/bench.txt" 2>&1
  echo "exit $?" >> "$O/bench.txt"
}
validate() {
  local name=$1 env=$2; shift 2
  local t; t=$(left); if (( t < 6 )); then log "skip validate $name (time)"; return; fi
  (( t > 20 )) && t=20
  log "validate $name [$env] $*"
  echo "=== validate $name [$env] $*" >> "$O/validate.txt"
  env $env timeout $t $NEW --validate "$@" >> "$O/validate.txt" 2>&1; echo "exit $?" >> "$O/validate.txt"
}
S1080="--width 1920 --height 1080"; S2160="--width 3840 --height 2160"
bench main-1080-r1 "X=0" $MAIN $S1080 $COMMON
bench b2-1080-r1 "X=0" $NEW $S1080 $COMMON
bench main-2160-r1 "X=0" $MAIN $S2160 $COMMON
bench b2-2160-r1 "X=0" $NEW $S2160 $COMMON
bench main-large "X=0" $MAIN $LARGE
bench b2-large "X=0" $NEW $LARGE
bench b2-steps-1080 "MYRIAD_ASSIGN_STEPS=1" $NEW $S1080 $COMMON
bench b2-steps-2160 "MYRIAD_ASSIGN_STEPS=1" $NEW $S2160 $COMMON
bench b2-steps-large "MYRIAD_ASSIGN_STEPS=1" $NEW $LARGE
validate 1m-1080 "X=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate 1m-2160 "X=0" $S2160 --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate large-2160 "X=0" $LARGE --frames 3 --warmup 1
validate all-10k-1080 "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer auto
validate mark0-10k-1080 "MYRIAD_MARK_IN_GBUFFER=0" --techniques clustered --lights 10000 --frames 3 --warmup 1 --gbuffer auto
validate slots1-flat0-1m-1080 "MYRIAD_ASSIGN_PAIR_SLOTS=1 MYRIAD_ASSIGN_FLAT=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
bench main-1080-r2 "X=0" $MAIN $S1080 $COMMON
bench b2-1080-r2 "X=0" $NEW $S1080 $COMMON
bench main-2160-r2 "X=0" $MAIN $S2160 $COMMON
bench b2-2160-r2 "X=0" $NEW $S2160 $COMMON
bench main-large-r2 "X=0" $MAIN $LARGE
bench b2-large-r2 "X=0" $NEW $LARGE
bench b2-mark0-1080 "MYRIAD_MARK_IN_GBUFFER=0" $NEW $S1080 $COMMON
bench b2-mark0-2160 "MYRIAD_MARK_IN_GBUFFER=0" $NEW $S2160 $COMMON
bench b2-flat0-1080 "MYRIAD_ASSIGN_FLAT=0" $NEW $S1080 $COMMON
bench b2-flat0-2160 "MYRIAD_ASSIGN_FLAT=0" $NEW $S2160 $COMMON
bench b2-g512-1080 "MYRIAD_ASSIGN_GROUPS=512" $NEW $S1080 $COMMON
bench b2-g512-2160 "MYRIAD_ASSIGN_GROUPS=512" $NEW $S2160 $COMMON
bench b2-gl64-1080 "MYRIAD_ASSIGN_GROUP_LIGHTS=64" $NEW $S1080 $COMMON
bench b2-gl64-2160 "MYRIAD_ASSIGN_GROUP_LIGHTS=64" $NEW $S2160 $COMMON
bench b2-g256-1080 "MYRIAD_ASSIGN_GROUPS=256" $NEW $S1080 $COMMON
bench b2-g256-2160 "MYRIAD_ASSIGN_GROUPS=256" $NEW $S2160 $COMMON
bench b2-mc256-large "MYRIAD_ASSIGN_MOST_CLUSTERS=256" $NEW $LARGE
bench b2-mc1024gl32-large "MYRIAD_ASSIGN_MOST_CLUSTERS=1024 MYRIAD_ASSIGN_GROUP_LIGHTS=32" $NEW $LARGE
bench b2-g512gl64-1080 "MYRIAD_ASSIGN_GROUPS=512 MYRIAD_ASSIGN_GROUP_LIGHTS=64" $NEW $S1080 $COMMON
bench b2-g512gl64-2160 "MYRIAD_ASSIGN_GROUPS=512 MYRIAD_ASSIGN_GROUP_LIGHTS=64" $NEW $S2160 $COMMON
bench b2-gl32-1080 "MYRIAD_ASSIGN_GROUP_LIGHTS=32" $NEW $S1080 $COMMON
bench b2-mc256-1080 "MYRIAD_ASSIGN_MOST_CLUSTERS=256" $NEW $S1080 $COMMON
bench b2-g2048-1080 "MYRIAD_ASSIGN_GROUPS=2048" $NEW $S1080 $COMMON
log done
grep -E "^===|^floor|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
