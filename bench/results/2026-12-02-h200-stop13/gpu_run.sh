#!/usr/bin/env bash
# The lead's one GPU run of stop 13. Usage: gpu_run.sh PACKDIR OUTDIR [small]
set -u
P=$1; FINAL=$2; small=${3:-}; O=/tmp/gpuout; rm -rf $O
export VK_LAYER_PATH=$P/data LD_LIBRARY_PATH=$P/bin
R="bash $P/run.sh"
B=$P/bin
W=1920; H=1080; W4=3840; H4=2160; BIG=1000000; SEC=5; F=30
if [[ -n $small ]]; then W=320; H=180; W4=640; H4=360; BIG=20000; SEC=2; F=3; fi
mkdir -p $O
t0=$(date +%s)
log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a $O/log.txt; (cd $O && tar czf $FINAL/results.tgz . 2>/dev/null); }
# 1. frame: old (main d3ac570) against new, clustered, both sizes
for bin in myriad-bench-old myriad-bench; do
  log "$bin frame 1080p"; $R $B/$bin --width $W --height $H --techniques clustered --lights 1000,$BIG --frames $F --warmup 5 --max-seconds 4 --json $O/$bin-1080.json >> $O/bench.txt 2>&1
  log "$bin frame 2160p"; $R $B/$bin --width $W4 --height $H4 --techniques clustered --lights 1000,$BIG --frames $F --warmup 5 --max-seconds 4 --json $O/$bin-2160.json >> $O/bench.txt 2>&1
  for aa in fxaa none; do
    log "$bin final 2160p $aa"; $R $B/$bin --width $W4 --height $H4 --techniques clustered --lights 1000 --markers --antialias $aa --frames $F --warmup 5 --max-seconds 4 >> $O/bench.txt 2>&1
  done
done
# 2. validation on, the new binary
log "validate"; $R $B/myriad-bench --validate --width $W --height $H --lights 10000,$BIG --frames 3 --warmup 1 >> $O/validate.txt 2>&1; echo "exit $?" >> $O/validate.txt
log "validate 4k"; $R $B/myriad-bench --validate --width $W4 --height $H4 --techniques clustered --lights $BIG --antialias fxaa --markers --frames 3 --warmup 1 >> $O/validate.txt 2>&1; echo "exit $?" >> $O/validate.txt
# 3. extra (helpers' benches), each given as a file of commands
if [[ -f $P/extra.sh ]]; then log "extra"; source $P/extra.sh; fi
log "done"
ls -la $O; cat $O/validate.txt | grep -E "exit|messages|valid" | tail -8
