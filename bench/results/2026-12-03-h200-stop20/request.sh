#!/usr/bin/env bash
# binaries: /work/wt/bins/s19b/myriad-bench-s19b /work/wt/bins/s19/myriad-bench-s19 /work/wt/bins/final/myriad-bench-final
# Stop 19: lightReaches' radius test written out again (s19b) against 65e9702 (s19) and stop 18's final (base), alternated.
C="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
L="--width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --gbuffer auto --frames 30 --warmup 5 --max-seconds 4"
for r in 1 2; do for v in s19b s19 final; do
  B=$BIN/lead-myriad-bench-$v
  echo "== $v round $r" >> $R/runs.txt
  $B --width 1920 --height 1080 $C >> $R/runs.txt 2>&1
  $B --width 3840 --height 2160 --techniques clustered --lights 10000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto >> $R/runs.txt 2>&1
  $B $L >> $R/runs.txt 2>&1
done; done
$BIN/lead-myriad-bench-s19b --validate --lights 10000,1000000 --techniques clustered --frames 3 --warmup 1 --gbuffer auto > $R/validate.txt 2>&1; echo "exit $?" >> $R/validate.txt
