#!/usr/bin/env bash
# Lead, stop 14 final (2): issue 16's rows with the server's default G-buffer (--gbuffer auto).
R="bash .devpack/run.sh"; B=.devpack/bin
for s in "1920 1080" "3840 2160"; do set -- $s
  $R $B/myriad-bench-main --width $1 --height $2 --techniques clustered --lights 10000,1000000 --gbuffer auto --frames 30 --warmup 5 --max-seconds 4 --json $OUT/bench-auto-$2.json >> $OUT/bench.txt 2>&1
done
$R $B/myriad-bench-main --width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --gbuffer auto --frames 30 --warmup 5 --max-seconds 4 >> $OUT/bench.txt 2>&1
$R $B/myriad-bench-main --width 1920 --height 1080 --techniques volumes,tiled,clustered --lights 10000 --gbuffer auto --frames 20 --warmup 5 --max-seconds 4 >> $OUT/bench.txt 2>&1
for a in "--lights 10000,1000000" "--width 3840 --height 2160 --techniques clustered --lights 1000000 --markers"; do
  $R $B/myriad-bench-main --validate --gbuffer auto $a --frames 3 --warmup 1 >> $OUT/validate.txt 2>&1; echo "exit $?" >> $OUT/validate.txt; done
