#!/usr/bin/env bash
# binaries: /work/wt/bins/shade/myriad-bench-b1 /work/wt/bins/main/myriad-bench
# shade, stop 17 batch 1 (issue 16, the clustered shade pass). main = main's bench (3c10dbe);
# b1 = branch shade: main + variant bits (MYRIAD_CLUSTER_SHADE_VARIANT) + MYRIAD_PIPELINE_STATS=1.
#   v59   = the default walk (same code as main)
#   v123  = 59 + PARTS (64): near masks from 4 part boxes of 4x2 px instead of the subgroup's union
#   v251  = 59 + PARTS + PARTS_4 (128): 8 part boxes of 2x2 px
#   diags (1080p 1M, image wrong): 315 narrow only, 571 no BRDF, 1083 near masks not shaded,
#          2107 non-covering lights skipped, 1147/2171 the same two with PARTS
# Want: where the walk's time goes now; whether part boxes cut it; NVIDIA's register counts.
set -u
MAIN=$BIN/shade-myriad-bench; NEW=$BIN/shade-myriad-bench-b1
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
HD="--width 1920 --height 1080 --lights 10000,1000000"; UHD="--width 3840 --height 2160 --lights 10000,1000000"
HD1M="--width 1920 --height 1080 --lights 1000000"
for v in 59 123; do
  MYRIAD_PIPELINE_STATS=1 MYRIAD_CLUSTER_SHADE_VARIANT=$v timeout 10 $NEW --techniques clustered --frames 2 --warmup 1 --width 640 --height 360 --lights 10000 --gbuffer auto 2>&1 | grep "pipeline stats" | sed "s/^/v$v /" >> "$R/stats.txt"
done
log stats done
for size in HD UHD; do
  S=${!size}
  run main-$size-1 $MAIN - $S
  run v59-$size-1 $NEW 59 $S
  run v123-$size-1 $NEW 123 $S
  run v251-$size-1 $NEW 251 $S
done
for v in 315 571 1083 2107 1147 2171; do run d$v-HD1M $NEW $v $HD1M; done
run main-HD-2 $MAIN - $HD
run v59-HD-2 $NEW 59 $HD
run v123-HD-2 $NEW 123 $HD
run v251-HD-2 $NEW 251 $HD
t=$(left); if (( t > 10 )); then
  log "validate v123"
  (( t > 20 )) && t=20
  MYRIAD_CLUSTER_SHADE_VARIANT=123 timeout $t $NEW --validate --frames 3 --warmup 1 --techniques clustered --gbuffer auto $HD1M >> "$R/validate.txt" 2>&1
  echo "exit $?" >> "$R/validate.txt"
fi
awk '/^=== /{name=$2} /^(floor|builtin)/{lights=$3; light=$8; pp=$10; ceil=$13} /passes:/{a="";s="";for(i=1;i<=NF;i++){if($i=="assign")a=$(i+1);if($i=="shade")s=$(i+1)}; printf "%-16s %8s pairs/px %s lighting %s (%s) assign %s shade %s\n", name, lights, pp, light, ceil, a, s}' "$R/bench.txt" > "$R/summary.txt"
grep -h "validation messages\|exit" "$R/validate.txt" >> "$R/summary.txt" 2>/dev/null
log done
