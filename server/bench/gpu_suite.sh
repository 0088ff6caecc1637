#!/usr/bin/env bash
# The benchmark suite behind docs/performance.md, as run on the GPU machine:
#   bash server/bench/gpu_suite.sh BENCH_BINARY OUT_DIR
# (on the GPU machine, BENCH_BINARY is ".devpack/run.sh .devpack/bin/myriad-bench", quoted).
# Each step writes OUT_DIR/<step>.json and appends its table to OUT_DIR/bench.log.
set -uo pipefail
bench=$1
out=$2
mkdir -p "$out"
status=0
step() {
  local name=$1; shift
  echo "== $name: myriad-bench $*" | tee -a "$out/bench.log"
  $bench "$@" --json "$out/$name.json" 2>&1 | tee -a "$out/bench.log" || status=1
}
# Every technique, 1k to 1M lights at about 64 lights per floor point (volumes up to 100k).
step floor-1080p --width 1920 --height 1080 --frames 50 --warmup 10 --max-seconds 20
step floor-2160p --width 3840 --height 2160 --frames 30 --warmup 5 --max-seconds 20 \
  --volumes-max-lights 10000
# Density: the same counts with fewer and more lights reaching each point.
step floor-1080p-density4 --techniques tiled,clustered --lights 1000,1000000 --lights-per-point 4 \
  --frames 50 --warmup 10
step floor-1080p-density256 --techniques tiled,clustered --lights 1000,1000000 \
  --lights-per-point 256 --frames 30 --warmup 5 --max-seconds 20
# The built-in scene, whose light density grows with the count (about 0.026 per point per light).
step builtin-1080p --scene builtin --lights 1000,10000,100000 --volumes-max-lights 10000 \
  --frames 30 --warmup 5 --max-seconds 20
# The environment light (issue 12): shading under the sky against the constant ambient (the same
# scene and counts), and its maps rebuilt every frame (the "environment" pass).
step env-none-1080p --techniques tiled,clustered --lights 1000,100000 --frames 30 --warmup 5
step env-sky-1080p --techniques tiled,clustered --lights 1000,100000 --frames 30 --warmup 5 \
  --environment sky
step env-rebuild-1080p --techniques clustered --lights 1000 --frames 30 --warmup 5 \
  --environment sky --environment-every-frame
# Textures (issue 12): DamagedHelmet (five 2048^2 textures, 14,556 triangles) with and without its
# textures, the same geometry and lights; MYRIAD_HELMET names the .glb (on the GPU machine: packed
# as a data file). Skipped when it is not there.
helmet=${MYRIAD_HELMET:-}
if [[ -n $helmet && -f $helmet ]]; then
  for size in "1920 1080" "3840 2160"; do
    set -- $size
    step "helmet-textured-${2}p" --model "$helmet" --textures on --width "$1" --height "$2" \
      --techniques clustered --lights 1000 --frames 50 --warmup 10
    step "helmet-untextured-${2}p" --model "$helmet" --textures off --width "$1" --height "$2" \
      --techniques clustered --lights 1000 --frames 50 --warmup 10
  done
fi
# The final pass and anti-aliasing (issue 13): "final" (tonemap + the markers' resolve, compute)
# and "antialias" at 4K and 1080p, with and without anti-aliasing; and the markers' splat
# ("markers") at a million lights, 1080p.
for aa in fxaa none; do
  step "final-2160p-$aa" --width 3840 --height 2160 --techniques clustered --lights 1000 --markers \
    --antialias "$aa" --frames 50 --warmup 10
  step "final-1080p-$aa" --techniques clustered --lights 1000 --markers --antialias "$aa" \
    --frames 50 --warmup 10
done
# taa and ssaa (issue 36): sub-frames rendered with none and resolved on the host; the passes
# are the sub-frames' summed, plus "resolve-taa" / "resolve-ssaa" (the host's resolve).
for aa in taa ssaa; do
  step "final-1080p-$aa" --techniques clustered --lights 1000 --markers --antialias "$aa" \
    --frames 20 --warmup 3
  step "final-2160p-$aa" --width 3840 --height 2160 --techniques clustered --lights 1000 \
    --markers --antialias "$aa" --frames 10 --warmup 2
done
step markers-1080p-1M --techniques clustered --lights 1000000 --markers --frames 30 --warmup 5
# Validation on (core + synchronization): every technique once, and a million lights at both sizes.
step validate-1080p --validate --lights 10000,1000000 --frames 5 --warmup 2
step validate-2160p --validate --width 3840 --height 2160 --techniques clustered --lights 1000000 \
  --frames 5 --warmup 2
exit $status
