#!/usr/bin/env bash
# binaries: /work/wt/bins/assign/myriad-bench-p1 /work/wt/bins/main/myriad-bench
# Issue 16 assignment (branch assign), stop 18 batch 1: lights tested in count/fill against the
# world bounds of each cluster's own surface points (gathered by the resolve / mark pass, reduced
# per subgroup), binary p1, against main, two rounds. Variants from the same binary:
# MYRIAD_CLUSTER_POINT_TEST=0 (view box only: shows what gathering the bounds costs),
# =2 (points' bounds only, no view-box test). Per-step times and validation.
set -u
O=$R; MAIN=$BIN/assign-myriad-bench; NEW=$BIN/assign-myriad-bench-p1
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 95 - ($(date +%s) - t0) )); }
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
  bench p1-1080-$r "X=0" $NEW $S1080 $C
  bench p1t2-1080-$r "MYRIAD_CLUSTER_POINT_TEST=2" $NEW $S1080 $C
  bench p1t0-1080-$r "MYRIAD_CLUSTER_POINT_TEST=0" $NEW $S1080 $C
  bench main-2160-$r "X=0" $MAIN $S2160 $C
  bench p1-2160-$r "X=0" $NEW $S2160 $C
  bench p1t2-2160-$r "MYRIAD_CLUSTER_POINT_TEST=2" $NEW $S2160 $C
  bench main-large-$r "X=0" $MAIN $LARGE
  bench p1-large-$r "X=0" $NEW $LARGE
  bench main-raster-1080-$r "X=0" $MAIN $S1080 $CR
  bench p1-raster-1080-$r "X=0" $NEW $S1080 $CR
}
round r1
bench main-steps-1080 "$ST" $MAIN $S1080 $C
bench p1-steps-1080 "$ST" $NEW $S1080 $C
bench p1-steps-2160 "$ST" $NEW $S2160 $C
bench p1-steps-large "$ST" $NEW $LARGE
validate p1-1m-1080 "X=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate p1-1m-2160-markers "X=0" $S2160 --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto --markers
validate p1-large "X=0" $LARGE --frames 3 --warmup 1
validate p1-all-10k "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer auto
validate p1-all-10k-raster "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer raster
validate p1-builtin "X=0" --scene builtin --lights 10000 --frames 3 --warmup 1 --gbuffer auto
round r2
log done
grep -E "^===|^floor|^builtin|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
