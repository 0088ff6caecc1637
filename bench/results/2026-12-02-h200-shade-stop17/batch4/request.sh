#!/usr/bin/env bash
# binaries: /work/wt/bins/shade/myriad-bench-b4 /work/wt/bins/main/myriad-bench
# shade, stop 17 batch 4 (issue 16, clustered shade pass; last experiments). main = main's bench.
# b4 = branch shade's candidate to ship: batch 3's v2235 made the default code (ballot words by
#   selects: no local memory; the tile narrowing loads 4 list entries an invocation before testing);
#   the per-cluster pre-narrowing pass removed (batches 2-3: a loss at 1080p and at 10k).
#   v123 = 59 + REACH_SHUFFLED (64): the walk's loosened reach worked out by the lane holding the light.
#   diags on the default (image wrong): 315 narrowing + fixed work only, 571 no BRDF,
#     4155 segments walked per pixel skipped, 8251 lights holding the box skipped,
#     16443 the other lights skipped (no near masks), 32827 near masks made but not shaded.
# Want: confirm b4 against main (both sizes, 10k and 1M), validation, and where the time goes now.
set -u
MAIN=$BIN/shade-myriad-bench; NEW=$BIN/shade-myriad-bench-b4
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*"; }
left() { echo $(( 112 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
run() {  # name binary variant(-|N) args...
  local name=$1 bin=$2 v=$3; shift 3
  local t; t=$(left); if (( t < 8 )); then log "skip $name (time)"; return; fi
  (( t > 14 )) && t=14
  log "$name [v=$v] $*"
  echo "=== $name [v=$v] $*" >> "$R/bench.txt"
  if [[ $v == - ]]; then
    timeout $t $bin $COMMON "$@" --json "$R/$name.json" >> "$R/bench.txt" 2>&1
  else
    MYRIAD_CLUSTER_SHADE_VARIANT=$v timeout $t $bin $COMMON "$@" --json "$R/$name.json" >> "$R/bench.txt" 2>&1
  fi
  echo "exit $?" >> "$R/bench.txt"
}
val() {  # name args...
  local name=$1; shift
  local t; t=$(left); if (( t < 10 )); then log "skip validate $name (time)"; return; fi
  (( t > 20 )) && t=20
  log "validate $name $*"
  echo "=== $name $*" >> "$R/validate.txt"
  timeout $t $NEW --validate --frames 3 --warmup 1 --techniques clustered --gbuffer auto "$@" >> "$R/validate.txt" 2>&1
  echo "exit $?" >> "$R/validate.txt"
}
HD="--width 1920 --height 1080 --lights 10000,1000000"; UHD="--width 3840 --height 2160 --lights 10000,1000000"
HD1M="--width 1920 --height 1080 --lights 1000000"; UHD1M="--width 3840 --height 2160 --lights 1000000"
MYRIAD_PIPELINE_STATS=1 timeout 10 $NEW --techniques clustered --frames 2 --warmup 1 --width 640 --height 360 --lights 10000 --gbuffer auto 2>&1 | grep "pipeline stats" | grep " 9=" >> "$R/stats.txt"
for size in HD UHD; do
  S=${!size}
  run main-$size-1 $MAIN - $S
  run b4-$size-1 $NEW - $S
  run v123-$size-1 $NEW 123 $S
done
val b4-HD1M $HD1M
val b4-UHD1M $UHD1M
for v in 315 571 4155 8251 16443 32827; do run d$v-HD1M $NEW $v $HD1M; done
run d315-HD10k $NEW 315 --width 1920 --height 1080 --lights 10000
run builtin-main $MAIN - --scene builtin --width 1920 --height 1080 --lights 10000
run builtin-b4 $NEW - --scene builtin --width 1920 --height 1080 --lights 10000
run main-HD-2 $MAIN - $HD
run b4-HD-2 $NEW - $HD
run v123-HD-2 $NEW 123 $HD
awk '/^=== /{name=$2} /^(floor|builtin)/{lights=$3; light=$8; pp=$10; ceil=$13} /passes:/{a="";s="";for(i=1;i<=NF;i++){if($i=="assign")a=$(i+1);if($i=="shade")s=$(i+1)}; printf "%-16s %8s pairs/px %s lighting %s (%s) assign %s shade %s\n", name, lights, pp, light, ceil, a, s}' "$R/bench.txt" > "$R/summary.txt"
grep -h "validation messages\|exit" "$R/validate.txt" >> "$R/summary.txt" 2>/dev/null
log done
