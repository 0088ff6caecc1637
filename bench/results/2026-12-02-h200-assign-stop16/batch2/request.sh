#!/usr/bin/env bash
# binaries: /work/wt/bins/assign/myriad-bench-b4 /work/wt/bins/main/myriad-bench
# Issue 16 assignment (branch assign), batch 2. main = main's bench; b4 = branch assign ("WIP
# assign b4"): active clusters numbered (shared table indexed by number, 4,096), the counting walk
# flattened over the workgroup, cluster marks written by the compute G-buffer's resolve (plain
# stores of a per-frame mark; MYRIAD_MARK_IN_GBUFFER=0: the pixel pass writes them), at most 256
# binned groups (MYRIAD_ASSIGN_GROUPS), at least 64 lights a group (MYRIAD_ASSIGN_GROUP_LIGHTS), the fill
# pass 4 workgroups per counting group (MYRIAD_ASSIGN_FILL_SPLIT), MYRIAD_ASSIGN_TABLE_CLUSTERS=1 (tables hold clusters).
set -u
O=$R; MAIN=$BIN/assign-myriad-bench; NEW=$BIN/assign-myriad-bench-b4
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 114 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
RASTER="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer raster"
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
bench b4-1080-r1 "X=0" $NEW $S1080 $COMMON
bench main-2160-r1 "X=0" $MAIN $S2160 $COMMON
bench b4-2160-r1 "X=0" $NEW $S2160 $COMMON
bench main-large "X=0" $MAIN $LARGE
bench b4-large "X=0" $NEW $LARGE
bench main-raster-1080 "X=0" $MAIN $S1080 $RASTER
bench b4-raster-1080 "X=0" $NEW $S1080 $RASTER
bench b4-steps-1080 "MYRIAD_ASSIGN_STEPS=1" $NEW $S1080 $COMMON
bench b4-steps-2160 "MYRIAD_ASSIGN_STEPS=1" $NEW $S2160 $COMMON
bench b4-steps-large "MYRIAD_ASSIGN_STEPS=1" $NEW $LARGE
bench b4-steps-raster-1080 "MYRIAD_ASSIGN_STEPS=1" $NEW $S1080 $RASTER
validate 1m-1080 "X=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate 1m-2160 "X=0" $S2160 --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate large-2160 "X=0" $LARGE --frames 3 --warmup 1
validate all-10k-1080 "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer auto
validate all-10k-1080-raster "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer raster
validate mark0-1m-1080 "MYRIAD_MARK_IN_GBUFFER=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
bench main-1080-r2 "X=0" $MAIN $S1080 $COMMON
bench b4-1080-r2 "X=0" $NEW $S1080 $COMMON
bench main-2160-r2 "X=0" $MAIN $S2160 $COMMON
bench b4-2160-r2 "X=0" $NEW $S2160 $COMMON
bench main-large-r2 "X=0" $MAIN $LARGE
bench b4-large-r2 "X=0" $NEW $LARGE
bench main-raster-1080-r2 "X=0" $MAIN $S1080 $RASTER
bench b4-raster-1080-r2 "X=0" $NEW $S1080 $RASTER
bench b4-split1-1080 "MYRIAD_ASSIGN_FILL_SPLIT=1" $NEW $S1080 $COMMON
bench b4-split1-2160 "MYRIAD_ASSIGN_FILL_SPLIT=1" $NEW $S2160 $COMMON
bench b4-split8-1080 "MYRIAD_ASSIGN_FILL_SPLIT=8" $NEW $S1080 $COMMON
bench b4-split8-2160 "MYRIAD_ASSIGN_FILL_SPLIT=8" $NEW $S2160 $COMMON
bench b4-tcl-1080 "MYRIAD_ASSIGN_TABLE_CLUSTERS=1" $NEW $S1080 $COMMON
bench b4-tcl-2160 "MYRIAD_ASSIGN_TABLE_CLUSTERS=1" $NEW $S2160 $COMMON
bench b4-mark0-1080 "MYRIAD_MARK_IN_GBUFFER=0" $NEW $S1080 $COMMON
bench b4-mark0-2160 "MYRIAD_MARK_IN_GBUFFER=0" $NEW $S2160 $COMMON
bench b4-g128-1080 "MYRIAD_ASSIGN_GROUPS=128" $NEW $S1080 $COMMON
bench b4-g128-2160 "MYRIAD_ASSIGN_GROUPS=128" $NEW $S2160 $COMMON
bench b4-g512-1080 "MYRIAD_ASSIGN_GROUPS=512" $NEW $S1080 $COMMON
bench b4-g512-2160 "MYRIAD_ASSIGN_GROUPS=512" $NEW $S2160 $COMMON
bench b4-gl32-1080 "MYRIAD_ASSIGN_GROUP_LIGHTS=32" $NEW $S1080 $COMMON
bench b4-gl128-1080 "MYRIAD_ASSIGN_GROUP_LIGHTS=128" $NEW $S1080 $COMMON
bench b4-gl32-2160 "MYRIAD_ASSIGN_GROUP_LIGHTS=32" $NEW $S2160 $COMMON
bench b4-flat0-1080 "MYRIAD_ASSIGN_FLAT=0" $NEW $S1080 $COMMON
log done
grep -E "^===|^floor|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
