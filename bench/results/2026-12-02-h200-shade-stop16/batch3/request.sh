#!/usr/bin/env bash
# binaries: /work/wt/bins/shade/myriad-bench-b3 /work/wt/bins/main/myriad-bench
# shade, batch 3 (issue 16, the clustered shade pass). main's binary against branch shade's b3,
# variants of b3's subgroup pass through MYRIAD_CLUSTER_SHADE_VARIANT (bits, shared_types.h):
#   1 mask walk (each pixel shades its own mask of a 32-light chunk), 2 subgroup box on every
#   segment, 8 narrowing against the world bounds of the slice's points, 32 hybrid (lights whose
#   sphere holds the subgroup's box walked together, the rest by masks), 64 the masks' lights
#   passed round by shuffle (a loop as long as the largest mask, every lane active)
#   0 = old walk + leaner BRDF. 512 = no BRDF (a measurement).
# Batch 2: v11 (1+2+8) best at 1M (1080p 0.815, 4K 2.643); v0 best at 10k (0.424 / 1.509).
set -u
MAIN=$BIN/shade-myriad-bench; NEW=$BIN/shade-myriad-bench-b3
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*"; }
left() { echo $(( 110 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
run() {  # name binary variant(main|N) size...
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
  for v in 0 11 43 75 107 41 105; do run v$v-$size-1 $NEW $v $S; done
done
run v555-HD $NEW 555 $HD
run v619-HD $NEW 619 $HD
val v43-1M-HD 43 --lights 1000000 --width 1920 --height 1080
val v107-1M-UHD 107 --lights 1000000 --width 3840 --height 2160
run builtin-main $MAIN main $BHD
run builtin-v0 $NEW 0 $BHD
run builtin-v43 $NEW 43 $BHD
run builtin-v107 $NEW 107 $BHD
for size in HD UHD; do
  S=${!size}
  run main-$size-2 $MAIN main $S
  for v in 0 11 43 107; do run v$v-$size-2 $NEW $v $S; done
done
awk '/^=== /{name=$2} /^(floor|builtin)/{lights=$3; light=$8; pp=$10} /passes:/{a="";s="";for(i=1;i<=NF;i++){if($i=="assign")a=$(i+1);if($i=="shade")s=$(i+1)}; printf "%-16s %8s pairs/px %s lighting %s assign %s shade %s\n", name, lights, pp, light, a, s}' "$R/bench.txt" > "$R/summary.txt"
grep -h "validation messages\|exit" "$R/validate.txt" >> "$R/summary.txt" 2>/dev/null
log done
