#!/usr/bin/env bash
# binaries: /work/wt/bins/lead/myriad-bench-review /work/wt/bins/final/myriad-bench-final
# Lead, after the review: the resolve's switches removed, worldFromDepth shared, the mark pass's
# two pixel paths merged. Same figures as the final run's binary (0e5df82)? Alternated + validation.
N=$BIN/lead-myriad-bench-review; F=$BIN/lead-myriad-bench-final
C="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
for r in 1 2; do
  echo "=== review $r 1080"; $N --width 1920 --height 1080 $C
  echo "=== final $r 1080"; $F --width 1920 --height 1080 $C
done
echo "=== review 2160"; $N --width 3840 --height 2160 $C
echo "=== final 2160"; $F --width 3840 --height 2160 $C
echo "=== review raster"; $N --width 1920 --height 1080 --techniques clustered --lights 1000000 --gbuffer raster --frames 30 --warmup 5 --max-seconds 4
for a in "--lights 10000,1000000 --techniques clustered" "--width 3840 --height 2160 --techniques clustered --lights 1000000 --markers" "--lights 10000" "--lights 10000 --gbuffer raster"; do
  echo "=== validate $a"; $N --validate $a --frames 3 --warmup 1 2>&1 | grep -E "messages|^floor"; done
