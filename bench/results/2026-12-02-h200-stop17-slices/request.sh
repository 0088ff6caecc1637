#!/usr/bin/env bash
# binaries: /work/wt/bins/lead/myriad-bench-slices
# Lead, stop 17: depth slices experiment (MYRIAD_CLUSTER_SLICE_COUNT), merged main ff7caf2 + the switch.
B=$BIN/lead-myriad-bench-slices
C="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
for round in 1 2; do
for s in 32 48 64 96; do
  echo "=== slices $s round $round 1080p" >> $R/bench.txt
  MYRIAD_CLUSTER_SLICE_COUNT=$s $B --width 1920 --height 1080 $C >> $R/bench.txt 2>&1
done; done
for s in 32 48 64 96; do
  echo "=== slices $s 4K" >> $R/bench.txt
  MYRIAD_CLUSTER_SLICE_COUNT=$s $B --width 3840 --height 2160 $C >> $R/bench.txt 2>&1
  echo "=== slices $s large" >> $R/bench.txt
  MYRIAD_CLUSTER_SLICE_COUNT=$s $B --width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --gbuffer auto --frames 30 --warmup 5 --max-seconds 4 >> $R/bench.txt 2>&1
done
for s in 48 64; do echo "=== validate $s" >> $R/validate.txt; MYRIAD_CLUSTER_SLICE_COUNT=$s $B --validate --lights 10000,1000000 --techniques clustered --frames 3 --warmup 1 >> $R/validate.txt 2>&1; done
