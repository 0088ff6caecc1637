#!/usr/bin/env bash
# binaries: /work/wt/bins/shade/myriad-bench-b6 /work/wt/bins/main/myriad-bench /work/wt/bins/shade/myriad-bench-mainnow
# shade, batch 5 (issue 16, the clustered shade pass), the branch with main merged (assign's stop 16).
#   old    = main's binary at c02f9f8 (before stop 16)
#   now    = assign's b6, copied as myriad-bench-mainnow (what main holds now: assign's stop 16,
#            the old shade pass)
#   b6     = branch shade with main merged: default walk (MYRIAD_SHADE_DEFAULT 59: mask walk, box
#            always, world narrowing, hybrid, segments <= 64 per pixel)
#   v0     = b6 with the walk before stop 16 (MYRIAD_CLUSTER_SHADE_VARIANT=0), the new BRDF
#   v1083  = b6 with 59 + 1024: the mask walk only for segments of cluster lists > 512 lights
set -u
OLD=$BIN/shade-myriad-bench; NOW=$BIN/shade-myriad-bench-mainnow; NEW=$BIN/shade-myriad-bench-b6
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*"; }
left() { echo $(( 110 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
run() {  # name binary variant(-|N) size...
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
BHD="--scene builtin --width 1920 --height 1080 --lights 10000"
for round in 1 2; do
  for size in HD UHD; do
    S=${!size}
    run old-$size-$round $OLD - $S
    run now-$size-$round $NOW - $S
    run b6-$size-$round $NEW - $S
    run v0-$size-$round $NEW 0 $S
    run v1083-$size-$round $NEW 1083 $S
  done
  if (( round == 1 )); then
    val b6-1M-HD --lights 1000000 --width 1920 --height 1080
    val b6-1M-UHD --lights 1000000 --width 3840 --height 2160
    run builtin-old $OLD - $BHD
    run builtin-now $NOW - $BHD
    run builtin-b6 $NEW - $BHD
    run builtin-v0 $NEW 0 $BHD
  fi
done
awk '/^=== /{name=$2} /^(floor|builtin)/{lights=$3; light=$8; pp=$10; ceil=$13} /passes:/{a="";s="";for(i=1;i<=NF;i++){if($i=="assign")a=$(i+1);if($i=="shade")s=$(i+1)}; printf "%-16s %8s pairs/px %s lighting %s (%s) assign %s shade %s\n", name, lights, pp, light, ceil, a, s}' "$R/bench.txt" > "$R/summary.txt"
grep -h "validation messages\|exit" "$R/validate.txt" >> "$R/summary.txt" 2>/dev/null
log done
