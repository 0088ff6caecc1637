#!/usr/bin/env bash
# binaries: /work/wt/bins/assign/myriad-bench-a7 /work/wt/bins/main/myriad-bench
# Issue 16 assignment (branch assign), stop 17 batch 4. main = main's bench; a7 = branch assign
# "WIP assign a7" = "assign a6" (the commit to ship) + MYRIAD_SCAN_PER_THREAD: binned passes walked per subgroup in groups of 1,024. Two
# rounds against main (1080p, 4K, large lights, raster G-buffer, built-in scene), per-step times,
# validation; experiments on a6: MYRIAD_ASSIGN_MOST_CLUSTERS=128/256 (more lights kept out of the
# large-light passes now that a subgroup walks a big box side by side), MYRIAD_ASSIGN_GROUP_LIGHTS
# 32/256, MYRIAD_ASSIGN_PAIR_SLOTS=4, MYRIAD_ASSIGN_BIN_GROUP_SIZE=512, MYRIAD_SCAN_PER_THREAD=1/2
# (more scan workgroups; the scan is 0.008 ms).
set -u
O=$R; MAIN=$BIN/assign-myriad-bench; NEW=$BIN/assign-myriad-bench-a7
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 114 - ($(date +%s) - t0) )); }
C="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
CR="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer raster"
S1080="--width 1920 --height 1080"; S2160="--width 3840 --height 2160"
LARGE="--width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
BUILTIN="--width 1920 --height 1080 --scene builtin --techniques clustered --lights 10000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
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
round() {
  local r=$1
  bench main-1080-$r "X=0" $MAIN $S1080 $C
  bench a6-1080-$r "X=0" $NEW $S1080 $C
  bench main-2160-$r "X=0" $MAIN $S2160 $C
  bench a6-2160-$r "X=0" $NEW $S2160 $C
  bench main-large-$r "X=0" $MAIN $LARGE
  bench a6-large-$r "X=0" $NEW $LARGE
  bench main-raster-1080-$r "X=0" $MAIN $S1080 $CR
  bench a6-raster-1080-$r "X=0" $NEW $S1080 $CR
  bench main-builtin-$r "X=0" $MAIN $BUILTIN
  bench a6-builtin-$r "X=0" $NEW $BUILTIN
  bench a6mc128-1080-$r "MYRIAD_ASSIGN_MOST_CLUSTERS=128" $NEW $S1080 $C
  bench a6mc128-2160-$r "MYRIAD_ASSIGN_MOST_CLUSTERS=128" $NEW $S2160 $C
  bench a6mc128-large-$r "MYRIAD_ASSIGN_MOST_CLUSTERS=128" $NEW $LARGE
  bench a6mc256-1080-$r "MYRIAD_ASSIGN_MOST_CLUSTERS=256" $NEW $S1080 $C
  bench a6mc256-large-$r "MYRIAD_ASSIGN_MOST_CLUSTERS=256" $NEW $LARGE
}
round r1
bench a6-steps-1080 "$ST" $NEW $S1080 $C
bench a6-steps-2160 "$ST" $NEW $S2160 $C
bench a6-steps-large "$ST" $NEW $LARGE
validate a6-1m-1080 "X=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate a6-1m-2160-markers "X=0" $S2160 --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto --markers
validate a6-large "X=0" $LARGE --frames 3 --warmup 1
validate a6-all-10k "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer auto
validate a6-all-10k-raster "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer raster
validate a6-builtin "X=0" --scene builtin --lights 10000 --frames 3 --warmup 1 --gbuffer auto
validate a6mc256-large "MYRIAD_ASSIGN_MOST_CLUSTERS=256" $LARGE --frames 3 --warmup 1
round r2
bench a6-steps-scan1-1080 "$ST MYRIAD_SCAN_PER_THREAD=1" $NEW $S1080 $C
bench a6-steps-scan2-1080 "$ST MYRIAD_SCAN_PER_THREAD=2" $NEW $S1080 $C
bench a6-steps-scan1-2160 "$ST MYRIAD_SCAN_PER_THREAD=1" $NEW $S2160 $C
bench a6scan1-1080 "MYRIAD_SCAN_PER_THREAD=1" $NEW $S1080 $C
bench a6scan2-1080 "MYRIAD_SCAN_PER_THREAD=2" $NEW $S1080 $C
bench a6gl32-1080 "MYRIAD_ASSIGN_GROUP_LIGHTS=32" $NEW $S1080 $C
bench a6gl256-1080 "MYRIAD_ASSIGN_GROUP_LIGHTS=256" $NEW $S1080 $C
bench a6slots4-1080 "MYRIAD_ASSIGN_PAIR_SLOTS=4" $NEW $S1080 $C
bench a6g512-1080 "MYRIAD_ASSIGN_BIN_GROUP_SIZE=512" $NEW $S1080 $C
log done
grep -E "^===|^floor|^builtin|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
