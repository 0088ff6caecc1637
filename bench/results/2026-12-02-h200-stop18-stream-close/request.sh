#!/usr/bin/env bash
# binaries: /work/wt/bins/lead/myriad-server-s1 /work/wt/bins/main/myriad-server /work/wt/bins/main/myriad-stream-bench
# Lead: does submitting a pipelining stream's next frame only when the current one is rendered
# (s1, 3b50e40) cost stream fps against main (b270439)? Alternated.
SB=$BIN/lead-myriad-stream-bench
for round in 1 2; do
  for s in main s1; do
    if [ $s = main ]; then S=$BIN/lead-myriad-server; else S=$BIN/lead-myriad-server-s1; fi
    echo "== round $round $s $(date -u +%T)"
    $SB --server $S --lights 100000 --radius 0.5,2 --size 1920x1080 --large 3840x2160 --streams 8 --requests 10 --seconds 2 --json $R/stream-$s-$round.json > $R/stream-$s-$round.txt 2>&1
    grep -E "fps|ms" $R/stream-$s-$round.txt | head -12
  done
done
