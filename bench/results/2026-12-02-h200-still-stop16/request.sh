#!/usr/bin/env bash
# binaries: /work/wt/bins/still/myriad-server /work/wt/bins/main/myriad-server /work/wt/bins/main/myriad-stream-bench
# Branch still (issue 18's drag still): Renderer::beginFrame picks the free slot whose targets fit
# the frame's size (then none, then the nearest size), the readback pool keeps the slots' sizes, the
# idle trim keeps the last slot when <= 192 MiB. Checks that GPU streams are not slower and that
# validation stays silent: main's server then still's, stream bench at 1080p (1 + 4 streams, no 4K),
# then still's server with --validate (short).
set -u
O=$R; SB=$BIN/still-myriad-stream-bench
t0=$(date +%s)
left() { echo $(( 114 - ($(date +%s) - t0) )); }
run() {
  local name=$1 server=$2; shift 2
  local t; t=$(left); if (( t < 8 )); then echo "skip $name" | tee -a $O/log.txt; return; fi
  (( t > 30 )) && t=30
  echo "=== $name $(( $(date +%s) - t0 ))s" | tee -a $O/log.txt
  timeout $t $SB --server $server --lights 100000 --streams 4 --large none --seconds 4 --requests 10 --json $O/$name.json "$@" >> $O/log.txt 2>&1
  echo "exit $?" >> $O/log.txt
}
run main1 $BIN/still-myriad-server
run still1 $BIN/still-myriad-server-b
run main2 $BIN/still-myriad-server
run still2 $BIN/still-myriad-server-b
run stillvalidate $BIN/still-myriad-server-b -- --validate
