#!/usr/bin/env bash
# binaries: /work/wt/bins/shade/myriad-bench-b2 /work/wt/bins/main/myriad-bench
# shade, stop 17 batch 2 (issue 16, clustered shade pass). main = main's bench (3c10dbe).
# b2 = branch shade: a new pass before shading (cluster_narrow.comp, MYRIAD_CLUSTER_NARROW=1, a
#   workgroup per 64x64 cluster tile) cuts each cluster's list in place to the lights reaching the
#   world bounds of its own points; and variant bit 64 (PREFETCH): the mask walk loads the next
#   chunk's lights while walking this one. v59 = default walk, v123 = 59 + prefetch.
#   diags (image wrong): 315 narrowing + fixed per-pixel work only, 571 no BRDF.
# Want: how much the per-cluster narrowing saves at 1M (1080p / 4K) and costs at 10k; prefetch.
# Batch 1 said: part boxes (v123/v251 of b1) 1.8x slower (dropped); 1080p 1M split: fixed+narrowing
#   0.213, BRDF 0.155, apart loop ~0.16, near loop ~0.11; shade pipeline 60 registers.
set -u
MAIN=$BIN/shade-myriad-bench; NEW=$BIN/shade-myriad-bench-b2
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*"; }
left() { echo $(( 112 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
run() {  # name binary narrow(-|0|1) variant(-|N) args...
  local name=$1 bin=$2 n=$3 v=$4; shift 4
  local t; t=$(left); if (( t < 8 )); then log "skip $name (time)"; return; fi
  (( t > 14 )) && t=14
  log "$name [n=$n v=$v] $*"
  echo "=== $name [n=$n v=$v] $*" >> "$R/bench.txt"
  local e=()
  [[ $n != - ]] && e+=(MYRIAD_CLUSTER_NARROW=$n)
  [[ $v != - ]] && e+=(MYRIAD_CLUSTER_SHADE_VARIANT=$v)
  env ${e[@]+"${e[@]}"} timeout $t $bin $COMMON "$@" --json "$R/$name.json" >> "$R/bench.txt" 2>&1
  echo "exit $?" >> "$R/bench.txt"
}
HD="--width 1920 --height 1080 --lights 10000,1000000"; UHD="--width 3840 --height 2160 --lights 10000,1000000"
HD1M="--width 1920 --height 1080 --lights 1000000"
for v in 59 123; do
  MYRIAD_PIPELINE_STATS=1 MYRIAD_CLUSTER_NARROW=1 MYRIAD_CLUSTER_SHADE_VARIANT=$v timeout 10 $NEW --techniques clustered --frames 2 --warmup 1 --width 640 --height 360 --lights 10000 --gbuffer auto 2>&1 | grep "pipeline stats" | grep -v "words \[CS\]; Register Count \(1\|2\)" | sed "s/^/v$v /" >> "$R/stats.txt"
done
for size in HD UHD; do
  S=${!size}
  run main-$size-1 $MAIN - - $S
  run n0v59-$size-1 $NEW 0 59 $S
  run n1v59-$size-1 $NEW 1 59 $S
  run n1v123-$size-1 $NEW 1 123 $S
done
run n0v123-HD-1 $NEW 0 123 $HD
run d315-n1-HD1M $NEW 1 315 $HD1M
run d571-n1-HD1M $NEW 1 571 $HD1M
run main-HD-2 $MAIN - - $HD
run n1v59-HD-2 $NEW 1 59 $HD
run n1v123-HD-2 $NEW 1 123 $HD
run n0v59-HD-2 $NEW 0 59 $HD
for size in HD1M UHD; do
  t=$(left); if (( t > 12 )); then
    log "validate n1 $size"
    (( t > 20 )) && t=20
    MYRIAD_CLUSTER_NARROW=1 timeout $t $NEW --validate --frames 3 --warmup 1 --techniques clustered --gbuffer auto ${!size} >> "$R/validate.txt" 2>&1
    echo "exit $?" >> "$R/validate.txt"
  fi
done
awk '/^=== /{name=$2} /^(floor|builtin)/{lights=$3; light=$8; pp=$10; ceil=$13} /passes:/{a="";s="";for(i=1;i<=NF;i++){if($i=="assign")a=$(i+1);if($i=="shade")s=$(i+1)}; printf "%-16s %8s pairs/px %s lighting %s (%s) assign %s shade %s\n", name, lights, pp, light, ceil, a, s}' "$R/bench.txt" > "$R/summary.txt"
grep -h "validation messages\|exit" "$R/validate.txt" >> "$R/summary.txt" 2>/dev/null
log done
