#!/usr/bin/env bash
# binaries: /work/wt/bins/s20/myriad-bench-s20 /work/wt/bins/s19b/myriad-bench-s19b
# Stop 20: the resolve gathers point bounds only where asked (MYRIAD_RESOLVE_BOUNDS; s20) against ef3408d (s19b), alternated.
C="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
L="--width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --gbuffer auto --frames 30 --warmup 5 --max-seconds 4"
for r in 1 2; do for v in s20 s19b; do
  B=$BIN/lead-myriad-bench-$v
  echo "== $v round $r" >> $R/runs.txt
  $B --width 1920 --height 1080 $C >> $R/runs.txt 2>&1
  $B --width 3840 --height 2160 --techniques clustered --lights 10000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto >> $R/runs.txt 2>&1
  $B $L >> $R/runs.txt 2>&1
done; done
$BIN/lead-myriad-bench-s20 --validate --lights 10000,1000000 --techniques clustered --frames 3 --warmup 1 --gbuffer auto > $R/validate.txt 2>&1; echo "exit $?" >> $R/validate.txt
MYRIAD_CLUSTER_POINT_TEST=0 $BIN/lead-myriad-bench-s20 --validate --lights 10000 --techniques clustered --frames 3 --warmup 1 --gbuffer compute >> $R/validate.txt 2>&1; echo "exit $?" >> $R/validate.txt
