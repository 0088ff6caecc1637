#!/usr/bin/env bash
# binaries: /work/wt/bins/shade/myriad-bench-b2 /work/wt/bins/main/myriad-bench
# shade, batch 2 (issue 16, the clustered shade pass). main's binary against branch shade's b2,
# variants of b2's subgroup pass through MYRIAD_CLUSTER_SHADE_VARIANT (bits, shared_types.h):
#   1 mask walk (each pixel shades its own mask of a 32-light chunk), 2 subgroup box on every
#   segment, 8 narrowing against the world bounds of the slice's points, 16 kept lights'
#   positions in shared memory, 32 adaptive (a chunk's union stepped together where it is hardly
#   larger than the largest mask), 64 staged (a chunk's lights through shared memory)
#   0 = old walk + b1's BRDF; 512 = no BRDF (measurement). MYRIAD_CLUSTER_TILE=32: 32-px clusters.
# Batch 1: v3 best at 1M (1080p 0.883, 4K 2.795), v0 best at 10k (0.425 / 1.509), v8 good at 4K.
set -u
MAIN=$BIN/shade-myriad-bench; NEW=$BIN/shade-myriad-bench-b2
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*"; }
left() { echo $(( 110 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
run() {  # name binary variant(main|N) extra-env size...
  local name=$1 bin=$2 v=$3 e=$4; shift 4
  local t; t=$(left); if (( t < 8 )); then log "skip $name (time)"; return; fi
  (( t > 14 )) && t=14
  log "$name [v=$v $e] $*"
  echo "=== $name [v=$v $e] $*" >> "$R/bench.txt"
  if [[ $v == main ]]; then
    env $e timeout $t $bin $COMMON "$@" --json "$R/$name.json" >> "$R/bench.txt" 2>&1
  else
    env $e MYRIAD_CLUSTER_SHADE_VARIANT=$v timeout $t $bin $COMMON "$@" --json "$R/$name.json" >> "$R/bench.txt" 2>&1
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
  run main-$size-1 $MAIN main X=0 $S
  for v in 0 3 11 43 107 75 27 35; do run v$v-$size-1 $NEW $v X=0 $S; done
  run t32-v43-$size $NEW 43 MYRIAD_CLUSTER_TILE=32 $S
  run t32-v0-$size $NEW 0 MYRIAD_CLUSTER_TILE=32 $S
done
run v555-HD $NEW 555 X=0 $HD
val v43-1M-HD 43 --lights 1000000 --width 1920 --height 1080
val v107-1M-UHD 107 --lights 1000000 --width 3840 --height 2160
run builtin-main $MAIN main X=0 $BHD
run builtin-v0 $NEW 0 X=0 $BHD
run builtin-v43 $NEW 43 X=0 $BHD
run builtin-v107 $NEW 107 X=0 $BHD
for size in HD UHD; do
  S=${!size}
  run main-$size-2 $MAIN main X=0 $S
  for v in 0 11 43 107; do run v$v-$size-2 $NEW $v X=0 $S; done
done
awk '/^=== /{name=$2} /^(floor|builtin)/{lights=$3; light=$8; pp=$10} /passes:/{a="";s="";for(i=1;i<=NF;i++){if($i=="assign")a=$(i+1);if($i=="shade")s=$(i+1)}; printf "%-16s %8s pairs/px %s lighting %s assign %s shade %s\n", name, lights, pp, light, a, s}' "$R/bench.txt" > "$R/summary.txt"
grep -h "validation messages\|exit" "$R/validate.txt" >> "$R/summary.txt" 2>/dev/null
log done
