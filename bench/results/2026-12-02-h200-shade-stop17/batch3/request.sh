#!/usr/bin/env bash
# binaries: /work/wt/bins/shade/myriad-bench-b3 /work/wt/bins/main/myriad-bench
# shade, stop 17 batch 3 (issue 16, clustered shade pass). main = main's bench (3c10dbe).
# b3 = branch shade, variant bits (MYRIAD_CLUSTER_SHADE_VARIANT) on the default walk 59:
#   187  = 59 + WORD_SELECT (128): ballot words picked by selects (batch 1: 64 B local memory)
#   1083 = 59 + NARROW_LOADS_2 (1024): the tile narrowing loads 2 entries+lights before testing
#   2107 = 59 + NARROW_LOADS_4 (2048): ... 4
#   2235 = 59 + 128 + 2048
#   diags (image wrong): 315 narrowing + fixed work only; 2363 the same with loads 4
#   n1   = MYRIAD_CLUSTER_NARROW=1: the per-cluster pre-narrowing pass, now 4 entries (and 4
#          depths) an invocation a step instead of 1 (batch 2's was latency-bound: 510 groups)
# Batch 2 said: per-cluster pre-narrowing pass +0.086 ms at 1080p 1M, -0.043 at 4K (off now);
#   prefetching the walk's chunks +0.006 (dropped).
set -u
MAIN=$BIN/shade-myriad-bench; NEW=$BIN/shade-myriad-bench-b3
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*"; }
left() { echo $(( 112 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
run() {  # name binary variant(-|N) args...  (N1=1 in the environment: pre-narrowing)
  local name=$1 bin=$2 v=$3; shift 3
  local t; t=$(left); if (( t < 8 )); then log "skip $name (time)"; return; fi
  (( t > 14 )) && t=14
  log "$name [v=$v] $*"
  echo "=== $name [v=$v] $*" >> "$R/bench.txt"
  if [[ $v == - ]]; then
    timeout $t $bin $COMMON "$@" --json "$R/$name.json" >> "$R/bench.txt" 2>&1
  else
    MYRIAD_CLUSTER_NARROW=${N1:-0} MYRIAD_CLUSTER_SHADE_VARIANT=$v timeout $t $bin $COMMON "$@" --json "$R/$name.json" >> "$R/bench.txt" 2>&1
  fi
  echo "exit $?" >> "$R/bench.txt"
}
HD="--width 1920 --height 1080 --lights 10000,1000000"; UHD="--width 3840 --height 2160 --lights 10000,1000000"
HD1M="--width 1920 --height 1080 --lights 1000000"
for v in 59 187 2235; do
  MYRIAD_PIPELINE_STATS=1 MYRIAD_CLUSTER_SHADE_VARIANT=$v timeout 10 $NEW --techniques clustered --frames 2 --warmup 1 --width 640 --height 360 --lights 10000 --gbuffer auto 2>&1 | grep "pipeline stats" | grep " 9=" | sed "s/^/v$v /" >> "$R/stats.txt"
done
for size in HD UHD; do
  S=${!size}
  run main-$size-1 $MAIN - $S
  for v in 59 187 1083 2107 2235; do run v$v-$size-1 $NEW $v $S; done
  N1=1 run n1v2235-$size-1 $NEW 2235 $S
done
run d315-HD1M $NEW 315 $HD1M
run d2363-HD1M $NEW 2363 $HD1M
run main-HD-2 $MAIN - $HD
run v2235-HD-2 $NEW 2235 $HD
N1=1 run n1v2235-HD-2 $NEW 2235 $HD
run v59-HD-2 $NEW 59 $HD
run v2107-HD-2 $NEW 2107 $HD
t=$(left); if (( t > 12 )); then
  log "validate n1 v2235"
  (( t > 20 )) && t=20
  MYRIAD_CLUSTER_NARROW=1 MYRIAD_CLUSTER_SHADE_VARIANT=2235 timeout $t $NEW --validate --frames 3 --warmup 1 --techniques clustered --gbuffer auto $HD1M >> "$R/validate.txt" 2>&1
  echo "exit $?" >> "$R/validate.txt"
fi
awk '/^=== /{name=$2} /^(floor|builtin)/{lights=$3; light=$8; pp=$10; ceil=$13} /passes:/{a="";s="";for(i=1;i<=NF;i++){if($i=="assign")a=$(i+1);if($i=="shade")s=$(i+1)}; printf "%-16s %8s pairs/px %s lighting %s (%s) assign %s shade %s\n", name, lights, pp, light, ceil, a, s}' "$R/bench.txt" > "$R/summary.txt"
grep -h "validation messages\|exit" "$R/validate.txt" >> "$R/summary.txt" 2>/dev/null
log done
