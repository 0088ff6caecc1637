#!/usr/bin/env bash
# binaries: /work/wt/bins/shade/myriad-bench-final /work/wt/bins/shade/myriad-bench-b5 /work/wt/bins/main/myriad-bench
# shade, stop 17 batch 5 (if there is room; issue 16 clustered shade pass). main = main's bench.
# final = branch shade at bb849e8 (what I ship: batch 4's v123 as the code).
# b5 = final + variant bit 64 (NEAR_AHEAD): each pixel's next near light (entry, position,
#   radiance) loaded before the current one is tested and shaded. v123 = default 59 + 64.
# Want: the shipped code measured as built, against main; whether NEAR_AHEAD pays.
set -u
MAIN=$BIN/shade-myriad-bench; FINAL=$BIN/shade-myriad-bench-final; NEW=$BIN/shade-myriad-bench-b5
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
for size in HD UHD; do
  S=${!size}
  run main-$size-1 $MAIN - $S
  run final-$size-1 $FINAL - $S
  run v123-$size-1 $NEW 123 $S
done
t=$(left); if (( t > 12 )); then
  log "validate final"
  (( t > 20 )) && t=20
  timeout $t $FINAL --validate --frames 3 --warmup 1 --techniques clustered --gbuffer auto $HD1M >> "$R/validate.txt" 2>&1
  echo "exit $?" >> "$R/validate.txt"
fi
run main-HD-2 $MAIN - $HD
run final-HD-2 $FINAL - $HD
run v123-HD-2 $NEW 123 $HD
run final-UHD-2 $FINAL - $UHD
run v123-UHD-2 $NEW 123 $UHD
awk '/^=== /{name=$2} /^(floor|builtin)/{lights=$3; light=$8; pp=$10; ceil=$13} /passes:/{a="";s="";for(i=1;i<=NF;i++){if($i=="assign")a=$(i+1);if($i=="shade")s=$(i+1)}; printf "%-16s %8s pairs/px %s lighting %s (%s) assign %s shade %s\n", name, lights, pp, light, ceil, a, s}' "$R/bench.txt" > "$R/summary.txt"
grep -h "validation messages\|exit" "$R/validate.txt" >> "$R/summary.txt" 2>/dev/null
log done
