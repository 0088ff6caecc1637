#!/usr/bin/env bash
# binaries: /work/wt/bins/assign/myriad-bench-a3 /work/wt/bins/main/myriad-bench
# Issue 16 assignment (branch assign), stop 17 batch 2. main = main's bench; a3 = branch assign
# "WIP assign a3" (default = main's path). Batch 1 found count and fill latency-bound (one
# 256-invocation group per SM): 512/1024 invocations a group cut assign 0.242 -> 0.13-0.16 ms.
# Now: the subgroup walk with each group's share split evenly among its subgroups (fixes 10k),
# at 1024/512 invocations and 4,096 bins, against the flat walk at 1024; which of fill table /
# prefetch / compaction pay; 264 groups of 512.
set -u
O=$R; MAIN=$BIN/assign-myriad-bench; NEW=$BIN/assign-myriad-bench-a3
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
SW1024="MYRIAD_ASSIGN_SUBGROUP_WALK=1 MYRIAD_ASSIGN_FILL_TABLE=1 MYRIAD_ASSIGN_PREFETCH=1 MYRIAD_ASSIGN_BIN_GROUP_SIZE=1024"
SW1024noFT="MYRIAD_ASSIGN_SUBGROUP_WALK=1 MYRIAD_ASSIGN_PREFETCH=1 MYRIAD_ASSIGN_BIN_GROUP_SIZE=1024"
SW1024noPF="MYRIAD_ASSIGN_SUBGROUP_WALK=1 MYRIAD_ASSIGN_FILL_TABLE=1 MYRIAD_ASSIGN_BIN_GROUP_SIZE=1024"
SW512="MYRIAD_ASSIGN_SUBGROUP_WALK=1 MYRIAD_ASSIGN_FILL_TABLE=1 MYRIAD_ASSIGN_PREFETCH=1 MYRIAD_ASSIGN_BIN_GROUP_SIZE=512"
FL1024="MYRIAD_ASSIGN_COMPACT=1 MYRIAD_ASSIGN_FILL_TABLE=1 MYRIAD_ASSIGN_PREFETCH=1 MYRIAD_ASSIGN_BIN_GROUP_SIZE=1024"
FL1024nc="MYRIAD_ASSIGN_FILL_TABLE=1 MYRIAD_ASSIGN_PREFETCH=1 MYRIAD_ASSIGN_BIN_GROUP_SIZE=1024"
round() {
  local r=$1
  bench main-1080-$r "X=0" $MAIN $S1080 $C
  bench sw1024-1080-$r "$SW1024" $NEW $S1080 $C
  bench sw1024noFT-1080-$r "$SW1024noFT" $NEW $S1080 $C
  bench sw1024noPF-1080-$r "$SW1024noPF" $NEW $S1080 $C
  bench sw512-1080-$r "$SW512" $NEW $S1080 $C
  bench sw512g264-1080-$r "$SW512 MYRIAD_ASSIGN_GROUPS=264" $NEW $S1080 $C
  bench fl1024-1080-$r "$FL1024" $NEW $S1080 $C
  bench fl1024nc-1080-$r "$FL1024nc" $NEW $S1080 $C
  bench main-2160-$r "X=0" $MAIN $S2160 $C
  bench sw1024-2160-$r "$SW1024" $NEW $S2160 $C
  bench sw512-2160-$r "$SW512" $NEW $S2160 $C
  bench fl1024-2160-$r "$FL1024" $NEW $S2160 $C
  bench main-large-$r "X=0" $MAIN $LARGE
  bench sw1024-large-$r "$SW1024" $NEW $LARGE
  bench fl1024-large-$r "$FL1024" $NEW $LARGE
}
round r1
bench sw1024-steps-1080 "$ST $SW1024" $NEW $S1080 $C
bench sw1024-steps-2160 "$ST $SW1024" $NEW $S2160 $C
bench sw1024-steps-large "$ST $SW1024" $NEW $LARGE
bench fl1024-steps-1080 "$ST $FL1024" $NEW $S1080 $C
bench sw512g264-steps-1080 "$ST $SW512 MYRIAD_ASSIGN_GROUPS=264" $NEW $S1080 $C
validate sw1024-1m-1080 "$SW1024" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate sw1024-1m-2160 "$SW1024" $S2160 --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate sw1024-large "$SW1024" $LARGE --frames 3 --warmup 1
validate sw1024-all-10k "$SW1024" --lights 10000 --frames 3 --warmup 1 --gbuffer auto
round r2
log done
grep -E "^===|^floor|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
