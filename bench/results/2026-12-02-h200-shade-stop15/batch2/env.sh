#!/usr/bin/env bash
# binaries: /work/wt/env-gpu/myriad-bench
# Issue 16 (env worktree), batch 2: the clustered shade pass. main's binary against branch env
# (one binary, variants through MYRIAD_CLUSTER_SHADE). Batch 1 showed: the BRDF's per-pixel
# terms hoisted out of the light loop save ~15%; a subgroup ballot walk wins where a tile's list
# is long (1080p, 1M: 2.97 -> 1.33 ms) and loses where it is short (10k, 4K). Now:
#   subgroup = the branch's default on GPUs: main's tile narrowing (view box), Morton-ordered
#              invocations (a subgroup is 8x4 pixels), hoisted BRDF terms; a segment of at most
#              256 lights walked per pixel, a longer one by subgroup ballot against the box of
#              the subgroup's surface points (candidates passed by shuffle, not reloaded)
#   b128 / balways / bnever = the same with ballot from 128 lights / always / never
#   pixel    = main's shading pass in this binary
# Output in $OUT (bench.txt, summary.txt, validate.txt, *.json). < 120 s: steps check time left.
set -u
O=${OUT:-/tmp/out}; mkdir -p "$O"
R="bash .devpack/run.sh"; B=.devpack/bin
MAIN=$B/myriad-bench-main; NEW=$B/myriad-bench-env
[[ -x $NEW ]] || NEW=$B/myriad-bench
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a "$O/log.txt"; }
left() { echo $(( 112 - ($(date +%s) - t0) )); }
COMMON="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
run() {  # name binary env size...
  local name=$1 bin=$2 envs=$3; shift 3
  local t; t=$(left); if (( t < 8 )); then log "skip $name (time)"; return; fi
  (( t > 14 )) && t=14
  log "$name [$envs] $*"
  echo "=== $name [$envs] $*" >> "$O/bench.txt"
  env $envs timeout $t $R $bin $COMMON "$@" --json "$O/$name.json" >> "$O/bench.txt" 2>&1
  echo "exit $?" >> "$O/bench.txt"
}
val() {
  local name=$1 envs=$2; shift 2
  local t; t=$(left); if (( t < 8 )); then log "skip $name (time)"; return; fi
  (( t > 20 )) && t=20
  log "validate $name [$envs] $*"
  echo "=== $name [$envs] $*" >> "$O/validate.txt"
  env $envs timeout $t $R $NEW --validate --frames 3 --warmup 1 --techniques clustered --gbuffer auto "$@" >> "$O/validate.txt" 2>&1
  echo "exit $?" >> "$O/validate.txt"
}
HD="--width 1920 --height 1080"; UHD="--width 3840 --height 2160"
for round in 1 2; do
  for size in HD UHD; do
    S=${!size}
    run main-$size-$round $MAIN X=0 $S
    run subgroup-$size-$round $NEW MYRIAD_CLUSTER_SHADE=subgroup $S
    run bnever-$size-$round $NEW MYRIAD_CLUSTER_SHADE=bnever $S
    run b128-$size-$round $NEW MYRIAD_CLUSTER_SHADE=b128 $S
    if (( round == 1 )); then
      run balways-$size $NEW MYRIAD_CLUSTER_SHADE=balways $S
      run pixel-$size $NEW MYRIAD_CLUSTER_SHADE=pixel $S
    fi
  done
  if (( round == 1 )); then
    val subgroup-1M-HD X=0 --lights 1000000 $HD
    val subgroup-1M-UHD X=0 --lights 1000000 $UHD
  fi
done
# the built-in scene (a general one: walls at every angle), if time is left
run builtin-main $MAIN X=0 --scene builtin $HD --lights 10000,100000
run builtin-subgroup $NEW X=0 --scene builtin $HD --lights 10000,100000
# summary: per run, the two light counts' lighting and the assign/shade split
awk '/^=== /{name=$2} /^(floor|builtin)/{lights=$3; light=$8} /passes:/{a="";s="";for(i=1;i<=NF;i++){if($i=="assign")a=$(i+1);if($i=="shade")s=$(i+1)}; printf "%-22s %8s lighting %s assign %s shade %s\n", name, lights, light, a, s}' "$O/bench.txt" > "$O/summary.txt"
grep -h "validation messages\|exit" "$O/validate.txt" >> "$O/summary.txt" 2>/dev/null
log done
