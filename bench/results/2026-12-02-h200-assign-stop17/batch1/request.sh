#!/usr/bin/env bash
# binaries: /work/wt/bins/assign/myriad-bench-a2 /work/wt/bins/main/myriad-bench
# Issue 16 assignment (branch assign), stop 17 batch 1. main = main's bench; a2 = branch assign
# "WIP assign a2" (default = main's code path). What I want to learn: where count and fill time
# go (MYRIAD_ASSIGN_STEPS=1), whether they respond to occupancy (GROUPS 264/528 in main;
# BIN_GROUP_SIZE 512/1024 in a2 = more invocations per SM, same table flushes), and a2's switches:
# COMPACT (regions hold only found pairs), FILL_TABLE (fill's list starts per number in shared),
# PREFETCH (next step's lights read early), SUBGROUP_WALK (each subgroup walks its own lights,
# no group barriers; compacts too).
set -u
O=$R; MAIN=$BIN/assign-myriad-bench; NEW=$BIN/assign-myriad-bench-a2
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 114 - ($(date +%s) - t0) )); }
C="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
S1080="--width 1920 --height 1080"; S2160="--width 3840 --height 2160"
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
ST="MYRIAD_ASSIGN_STEPS=1"
ALL="MYRIAD_ASSIGN_COMPACT=1 MYRIAD_ASSIGN_FILL_TABLE=1 MYRIAD_ASSIGN_PREFETCH=1"
SW="MYRIAD_ASSIGN_SUBGROUP_WALK=1 MYRIAD_ASSIGN_FILL_TABLE=1 MYRIAD_ASSIGN_PREFETCH=1"
G512="MYRIAD_ASSIGN_BIN_GROUP_SIZE=512"
G1024="MYRIAD_ASSIGN_BIN_GROUP_SIZE=1024 MYRIAD_ASSIGN_BINS_OVERRIDE=2048"
# round 1, plain timings
bench main-1080-r1 "X=0" $MAIN $S1080 $C
bench a2-1080-r1 "X=0" $NEW $S1080 $C
bench a2all-1080-r1 "$ALL" $NEW $S1080 $C
bench a2all512-1080-r1 "$ALL $G512" $NEW $S1080 $C
bench a2sw-1080-r1 "$SW" $NEW $S1080 $C
bench a2sw512-1080-r1 "$SW $G512" $NEW $S1080 $C
bench a2sw1024-1080-r1 "$SW $G1024" $NEW $S1080 $C
bench main-2160-r1 "X=0" $MAIN $S2160 $C
bench a2all-2160-r1 "$ALL" $NEW $S2160 $C
bench a2all512-2160-r1 "$ALL $G512" $NEW $S2160 $C
bench a2sw-2160-r1 "$SW" $NEW $S2160 $C
bench a2sw512-2160-r1 "$SW $G512" $NEW $S2160 $C
bench main-large-r1 "X=0" $MAIN $LARGE
bench a2all-large-r1 "$ALL" $NEW $LARGE
bench a2sw-large-r1 "$SW" $NEW $LARGE
bench a2sw512-large-r1 "$SW $G512" $NEW $LARGE
# per-step timestamps
bench main-steps-1080 "$ST" $MAIN $S1080 $C
bench main-steps-2160 "$ST" $MAIN $S2160 $C
bench a2-steps-compact-1080 "$ST MYRIAD_ASSIGN_COMPACT=1" $NEW $S1080 $C
bench a2-steps-filltable-1080 "$ST MYRIAD_ASSIGN_FILL_TABLE=1" $NEW $S1080 $C
bench a2-steps-prefetch-1080 "$ST MYRIAD_ASSIGN_PREFETCH=1" $NEW $S1080 $C
bench a2-steps-all-1080 "$ST $ALL" $NEW $S1080 $C
bench a2-steps-512-1080 "$ST $G512" $NEW $S1080 $C
bench a2-steps-all512-1080 "$ST $ALL $G512" $NEW $S1080 $C
bench a2-steps-all1024-1080 "$ST $ALL $G1024" $NEW $S1080 $C
bench a2-steps-sw-1080 "$ST $SW" $NEW $S1080 $C
bench a2-steps-sw512-1080 "$ST $SW $G512" $NEW $S1080 $C
bench a2-steps-sw1024-1080 "$ST $SW $G1024" $NEW $S1080 $C
bench a2-steps-all-2160 "$ST $ALL" $NEW $S2160 $C
bench a2-steps-sw-2160 "$ST $SW" $NEW $S2160 $C
bench a2-steps-sw512-2160 "$ST $SW $G512" $NEW $S2160 $C
bench main-steps-g264-1080 "$ST MYRIAD_ASSIGN_GROUPS=264" $MAIN $S1080 $C
bench main-steps-g528-1080 "$ST MYRIAD_ASSIGN_GROUPS=528" $MAIN $S1080 $C
bench main-steps-sep-1080 "$ST MYRIAD_ANIMATE_SEPARATE=1" $MAIN $S1080 $C
bench a2-steps-sw-g264-1080 "$ST $SW MYRIAD_ASSIGN_GROUPS=264" $NEW $S1080 $C
validate all-1m-1080 "$ALL" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate sw512-1m-2160 "$SW $G512" $S2160 --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate sw1024-1m-1080 "$SW $G1024" --techniques clustered --lights 10000,1000000 --frames 3 --warmup 1 --gbuffer auto
validate sw-large "$SW" $LARGE --frames 3 --warmup 1
# round 2
bench main-1080-r2 "X=0" $MAIN $S1080 $C
bench a2-1080-r2 "X=0" $NEW $S1080 $C
bench a2all-1080-r2 "$ALL" $NEW $S1080 $C
bench a2all512-1080-r2 "$ALL $G512" $NEW $S1080 $C
bench a2sw-1080-r2 "$SW" $NEW $S1080 $C
bench a2sw512-1080-r2 "$SW $G512" $NEW $S1080 $C
bench a2sw1024-1080-r2 "$SW $G1024" $NEW $S1080 $C
bench main-2160-r2 "X=0" $MAIN $S2160 $C
bench a2all-2160-r2 "$ALL" $NEW $S2160 $C
bench a2sw-2160-r2 "$SW" $NEW $S2160 $C
bench a2sw512-2160-r2 "$SW $G512" $NEW $S2160 $C
bench main-large-r2 "X=0" $MAIN $LARGE
bench a2sw-large-r2 "$SW" $NEW $LARGE
log done
grep -E "^===|^floor|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
