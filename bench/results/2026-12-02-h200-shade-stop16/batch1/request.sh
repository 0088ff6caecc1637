#!/usr/bin/env bash
# binaries: /work/wt/bins/shade/myriad-bench-b1 /work/wt/bins/main/myriad-bench
# shade, batch 1 (issue 16, the clustered shade pass). main's binary against branch shade's b1,
# variants of b1's subgroup pass through MYRIAD_CLUSTER_SHADE_VARIANT (bits, shared_types.h):
#   0   old walk (ballot > 256 lights, per pixel below), with b1's leaner BRDF (5 MUFU, not 9)
#   1   mask walk: chunks of 32 lights, each pixel shades only its own mask (not the union)
#   3   mask + the subgroup box test on every segment
#   4   narrowing 4 lights a step, appends one shared atomic per subgroup
#   8   narrowing against the world bounds of the slice's points (not the view box)
#   5 = 1+4, 13 = 1+4+8
#   diagnostics (image wrong, timing only): 256 narrowing only, 260 = 256+4, 264 = 256+8,
#   512 walk + reach tests without the BRDF (old walk), 513 the same with the mask walk
# Writes $R/bench.txt, $R/validate.txt, $R/summary.txt, $R/*.json. Stays under 120 s.
set -u
MAIN=$BIN/shade-myriad-bench; NEW=$BIN/shade-myriad-bench-b1
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*"; }
left() { echo $(( 110 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
run() {  # name binary variant size...
  local name=$1 bin=$2 v=$3; shift 3
  local t; t=$(left); if (( t < 8 )); then log "skip $name (time)"; return; fi
  (( t > 14 )) && t=14
  log "$name [v=$v] $*"
  echo "=== $name [v=$v] $*" >> "$R/bench.txt"
  if [[ $v == main ]]; then
    timeout $t $bin $COMMON "$@" --json "$R/$name.json" >> "$R/bench.txt" 2>&1
  else
    MYRIAD_CLUSTER_SHADE_VARIANT=$v timeout $t $bin $COMMON "$@" --json "$R/$name.json" >> "$R/bench.txt" 2>&1
  fi
  echo "exit $?" >> "$R/bench.txt"
}
val() {  # name variant args...
  local name=$1 v=$2; shift 2
  local t; t=$(left); if (( t < 10 )); then log "skip validate $name (time)"; return; fi
  (( t > 20 )) && t=20
  log "validate $name [v=$v] $*"
  echo "=== $name [v=$v] $*" >> "$R/validate.txt"
  MYRIAD_CLUSTER_SHADE_VARIANT=$v timeout $t $NEW --validate --frames 3 --warmup 1 --techniques clustered --gbuffer auto "$@" >> "$R/validate.txt" 2>&1
  echo "exit $?" >> "$R/validate.txt"
}
HD="--width 1920 --height 1080 --lights 10000,1000000"; UHD="--width 3840 --height 2160 --lights 10000,1000000"
BHD="--scene builtin --width 1920 --height 1080 --lights 10000"
for size in HD UHD; do
  S=${!size}
  run main-$size-1 $MAIN main $S
  for v in 0 1 3 4 5 8 13 256 260 264 512 513; do run v$v-$size-1 $NEW $v $S; done
done
val v13-1M-HD 13 --lights 1000000 --width 1920 --height 1080
val v5-1M-UHD 5 --lights 1000000 --width 3840 --height 2160
run builtin-main $MAIN main $BHD
run builtin-v0 $NEW 0 $BHD
run builtin-v1 $NEW 1 $BHD
run builtin-v5 $NEW 5 $BHD
# second round, the main comparisons, while time is left
for size in HD UHD; do
  S=${!size}
  for v in main 0 1 5 13; do  # ~2 s each
    if [[ $v == main ]]; then run main-$size-2 $MAIN main $S; else run v$v-$size-2 $NEW $v $S; fi
  done
done
awk '/^=== /{name=$2} /^(floor|builtin)/{lights=$3; light=$8; pp=$10} /passes:/{a="";s="";for(i=1;i<=NF;i++){if($i=="assign")a=$(i+1);if($i=="shade")s=$(i+1)}; printf "%-16s %8s pairs/px %s lighting %s assign %s shade %s\n", name, lights, pp, light, a, s}' "$R/bench.txt" > "$R/summary.txt"
grep -h "validation messages\|exit" "$R/validate.txt" >> "$R/summary.txt" 2>/dev/null
log done
