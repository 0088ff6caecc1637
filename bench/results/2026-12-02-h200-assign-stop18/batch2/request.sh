#!/usr/bin/env bash
# binaries: /work/wt/bins/assign/myriad-bench-p2 /work/wt/bins/main/myriad-bench
# Issue 16 assignment (branch assign), stop 18 batch 2 (the last experiment batch, one round,
# ~45 s): p2 = p1 + the resolve reducing the clusters' point bounds as ordered words (unsigned
# subgroup maxima) instead of floats, the points-only test by default (batch 1's p1t2), and the
# shade pass's subgroup bounds reduced as words too (variant bit 0x40). What decides: does the
# resolve's +0.024 ms (1080p) / +0.075 (4K) come down; does the shade change pay.
#   p2f: MYRIAD_RESOLVE_BOUNDS_FLOATS=1 (the resolve as p1)
#   p2v: MYRIAD_CLUSTER_SHADE_VARIANT=59 (shade as main: float reductions)
#   p2t32: MYRIAD_CLUSTER_TILE=32 (clusters of 32 px, now that lists are cut to the points)
set -u
O=$R; MAIN=$BIN/assign-myriad-bench; NEW=$BIN/assign-myriad-bench-p2
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 58 - ($(date +%s) - t0) )); }
C="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
CR="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer raster"
S1080="--width 1920 --height 1080"; S2160="--width 3840 --height 2160"
LARGE="--width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
bench() {
  local name=$1 env=$2 bin=$3; shift 3
  local t; t=$(left); if (( t < 4 )); then log "skip $name (time)"; return; fi
  (( t > 12 )) && t=12
  log "$name [$env] $*"
  echo "=== $name [$env] $*" >> "$O/bench.txt"
  env $env timeout $t $bin "$@" --json "$O/$name.json" >> "$O/bench.txt" 2>&1
  echo "exit $?" >> "$O/bench.txt"
}
validate() {
  local name=$1 env=$2; shift 2
  local t; t=$(left); if (( t < 4 )); then log "skip validate $name (time)"; return; fi
  (( t > 12 )) && t=12
  log "validate $name [$env] $*"
  echo "=== validate $name [$env] $*" >> "$O/validate.txt"
  env $env timeout $t $NEW --validate "$@" >> "$O/validate.txt" 2>&1; echo "exit $?" >> "$O/validate.txt"
}
bench main-1080-r1 "X=0" $MAIN $S1080 $C
bench p2-1080-r1 "X=0" $NEW $S1080 $C
bench p2f-1080 "MYRIAD_RESOLVE_BOUNDS_FLOATS=1" $NEW $S1080 $C
bench p2v-1080 "MYRIAD_CLUSTER_SHADE_VARIANT=59" $NEW $S1080 $C
bench main-2160 "X=0" $MAIN $S2160 $C
bench p2-2160 "X=0" $NEW $S2160 $C
bench main-large "X=0" $MAIN $LARGE
bench p2-large "X=0" $NEW $LARGE
bench p2-steps-1080 "MYRIAD_ASSIGN_STEPS=1" $NEW $S1080 $C
bench main-1080-r2 "X=0" $MAIN $S1080 $C
bench p2-1080-r2 "X=0" $NEW $S1080 $C
validate p2-1m-1080 "X=0" --techniques clustered --lights 1000000 --frames 3 --warmup 1 --gbuffer auto
validate p2-all-10k "X=0" --lights 10000 --frames 3 --warmup 1 --gbuffer auto
bench main-raster-1080 "X=0" $MAIN $S1080 $CR
bench p2-raster-1080 "X=0" $NEW $S1080 $CR
bench p2t32-1080 "MYRIAD_CLUSTER_TILE=32" $NEW $S1080 $C
log done
grep -E "^===|^floor|^builtin|passes|^exit" "$O/bench.txt" > "$O/summary.txt"
grep -E "^===|exit|messages" "$O/validate.txt" >> "$O/log.txt" 2>/dev/null
