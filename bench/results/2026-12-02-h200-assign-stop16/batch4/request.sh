#!/usr/bin/env bash
# binaries: /work/wt/bins/assign/myriad-bench-b6 /work/wt/bins/main/myriad-bench
# Issue 16 assignment (branch assign), batch 4. main = main's bench; b6 = branch assign ("WIP
# assign b6"): b5 (batch 3) with at most one binned workgroup per multiprocessor (the H200's 132
# from VK_NV_shader_sm_builtins; the device line says), instead of 128; MYRIAD_ASSIGN_GROUPS
# overrides it.
set -u
O=$R; MAIN=$BIN/assign-myriad-bench; NEW=$BIN/assign-myriad-bench-b6
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
bench b6-1080-r1 "X=0" $NEW $S1080 $COMMON
bench b6g128-1080-r1 "MYRIAD_ASSIGN_GROUPS=128" $NEW $S1080 $COMMON
bench main-2160-r1 "X=0" $MAIN $S2160 $COMMON
bench b6-2160-r1 "X=0" $NEW $S2160 $COMMON
bench b6g128-2160-r1 "MYRIAD_ASSIGN_GROUPS=128" $NEW $S2160 $COMMON
bench main-large "X=0" $MAIN $LARGE
bench b6-large "X=0" $NEW $LARGE
bench b6g128-large "MYRIAD_ASSIGN_GROUPS=128" $NEW $LARGE
bench main-raster-1080 "X=0" $MAIN $S1080 $RASTER
bench b6-raster-1080 "X=0" $NEW $S1080 $RASTER
bench b6-steps-1080 "MYRIAD_ASSIGN_STEPS=1" $NEW $S1080 $COMMON
bench b6-steps-2160 "MYRIAD_ASSIGN_STEPS=1" $NEW $S2160 $COMMON
bench b6-steps-large "MYRIAD_ASSIGN_STEPS=1" $NEW $LARGE
validate 1m-1080 "X=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate 1m-2160 "X=0" $S2160 --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate large-2160 "X=0" $LARGE --frames 3 --warmup 1
validate all-10k-1080 "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer auto
validate all-10k-1080-raster "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer raster
validate mark0-1m-1080 "MYRIAD_MARK_IN_GBUFFER=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
bench main-1080-r2 "X=0" $MAIN $S1080 $COMMON
bench b6-1080-r2 "X=0" $NEW $S1080 $COMMON
bench b6g128-1080-r2 "MYRIAD_ASSIGN_GROUPS=128" $NEW $S1080 $COMMON
bench main-2160-r2 "X=0" $MAIN $S2160 $COMMON
bench b6-2160-r2 "X=0" $NEW $S2160 $COMMON
bench b6g128-2160-r2 "MYRIAD_ASSIGN_GROUPS=128" $NEW $S2160 $COMMON
bench main-large-r2 "X=0" $MAIN $LARGE
bench b6-large-r2 "X=0" $NEW $LARGE
bench main-raster-1080-r2 "X=0" $MAIN $S1080 $RASTER
bench b6-raster-1080-r2 "X=0" $NEW $S1080 $RASTER
bench b6-g264-1080 "MYRIAD_ASSIGN_GROUPS=264" $NEW $S1080 $COMMON
bench b6-g264-2160 "MYRIAD_ASSIGN_GROUPS=264" $NEW $S2160 $COMMON
bench b6-g120-1080 "MYRIAD_ASSIGN_GROUPS=120" $NEW $S1080 $COMMON
log done
grep -E "^===|^floor|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
