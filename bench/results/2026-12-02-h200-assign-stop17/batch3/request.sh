#!/usr/bin/env bash
# binaries: /work/wt/bins/assign/myriad-bench-a5 /work/wt/bins/main/myriad-bench
# Issue 16 assignment (branch assign), stop 17 batch 3. main = main's bench; a5 = branch assign
# "WIP assign a5": the candidate to ship (binned passes walk per subgroup in groups of 1,024, the
# old walks removed) against main, two rounds incl. raster G-buffer and validation; plus switches:
# MYRIAD_ASSIGN_FILL_BATCH=2/4/8 (fill issues N pairs' reads at once), MYRIAD_ASSIGN_TEST_FIRST=1
# (cluster number read only for reached candidates).
set -u
O=$R; MAIN=$BIN/assign-myriad-bench; NEW=$BIN/assign-myriad-bench-a5
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 114 - ($(date +%s) - t0) )); }
C="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
CR="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer raster"
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
round() {
  local r=$1
  bench main-1080-$r "X=0" $MAIN $S1080 $C
  bench a5-1080-$r "X=0" $NEW $S1080 $C
  bench a5fb2-1080-$r "MYRIAD_ASSIGN_FILL_BATCH=2" $NEW $S1080 $C
  bench a5fb4-1080-$r "MYRIAD_ASSIGN_FILL_BATCH=4" $NEW $S1080 $C
  bench a5fb8-1080-$r "MYRIAD_ASSIGN_FILL_BATCH=8" $NEW $S1080 $C
  bench a5tf-1080-$r "MYRIAD_ASSIGN_TEST_FIRST=1" $NEW $S1080 $C
  bench main-2160-$r "X=0" $MAIN $S2160 $C
  bench a5-2160-$r "X=0" $NEW $S2160 $C
  bench a5fb4-2160-$r "MYRIAD_ASSIGN_FILL_BATCH=4" $NEW $S2160 $C
  bench a5tf-2160-$r "MYRIAD_ASSIGN_TEST_FIRST=1" $NEW $S2160 $C
  bench main-large-$r "X=0" $MAIN $LARGE
  bench a5-large-$r "X=0" $NEW $LARGE
  bench main-raster-1080-$r "X=0" $MAIN $S1080 $CR
  bench a5-raster-1080-$r "X=0" $NEW $S1080 $CR
}
round r1
bench a5-steps-1080 "$ST" $NEW $S1080 $C
bench a5-steps-2160 "$ST" $NEW $S2160 $C
bench a5-steps-large "$ST" $NEW $LARGE
bench a5fb4-steps-1080 "$ST MYRIAD_ASSIGN_FILL_BATCH=4" $NEW $S1080 $C
bench a5fb4-steps-2160 "$ST MYRIAD_ASSIGN_FILL_BATCH=4" $NEW $S2160 $C
validate a5-1m-1080 "X=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate a5-1m-2160 "X=0" $S2160 --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate a5-large "X=0" $LARGE --frames 3 --warmup 1
validate a5-all-10k "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer auto
validate a5-all-10k-raster "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer raster
validate a5fb8tf-1m-1080 "MYRIAD_ASSIGN_FILL_BATCH=8 MYRIAD_ASSIGN_TEST_FIRST=1" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
round r2
log done
grep -E "^===|^floor|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
