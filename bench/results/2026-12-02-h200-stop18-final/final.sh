#!/usr/bin/env bash
# binaries: /work/wt/bins/final/myriad-bench-final /work/wt/bins/final/myriad-server /work/wt/bins/final/myriad-stream-bench /work/wt/bins/main/myriad-bench
# Lead, stop 18 final: merged main's binaries (lead-myriad-*-final etc.), issue 16's and 18's
# Done-means commands; lead-myriad-bench (bins/main) is main at the stop's start (b270439), `base`.
B=$BIN/lead-myriad-bench-final; BASE=$BIN/lead-myriad-bench
C="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
t0=$(date +%s); log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a $R/steps.log; }
log "bench 1080p"; $B --width 1920 --height 1080 $C --json $R/bench-1080.json > $R/bench.txt 2>&1
log "base 1080p"; $BASE --width 1920 --height 1080 $C > $R/base.txt 2>&1
log "bench 1080p r2"; $B --width 1920 --height 1080 $C --json $R/bench-1080-r2.json > $R/bench-r2.txt 2>&1
log "bench 2160p"; $B --width 3840 --height 2160 $C --json $R/bench-2160.json >> $R/bench.txt 2>&1
log "base 2160p"; $BASE --width 3840 --height 2160 $C >> $R/base.txt 2>&1
log "bench large"; $B --width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --gbuffer auto --frames 30 --warmup 5 --max-seconds 4 --json $R/bench-large.json >> $R/bench.txt 2>&1
log "base large"; $BASE --width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --gbuffer auto --frames 30 --warmup 5 --max-seconds 4 >> $R/base.txt 2>&1
log "bench raster"; $B --width 1920 --height 1080 --techniques clustered --lights 1000000 --gbuffer raster --frames 30 --warmup 5 --max-seconds 4 >> $R/bench.txt 2>&1
log "steps"; MYRIAD_ASSIGN_STEPS=1 $B --width 1920 --height 1080 $C > $R/steps.txt 2>&1
log "all techniques 10k"; $B --width 1920 --height 1080 --lights 10000 --frames 20 --warmup 3 --max-seconds 4 --gbuffer auto > $R/techniques.txt 2>&1
log "stream bench"; $BIN/lead-myriad-stream-bench --server $BIN/lead-myriad-server --lights 100000 --radius 0.5,2 --size 1920x1080 --large 3840x2160 --streams 8 --requests 20 --seconds 5 --json $R/stream-bench.json > $R/stream-bench.txt 2>&1
log "validate"; for a in "--lights 10000,1000000 --techniques clustered" "--width 3840 --height 2160 --techniques clustered --lights 1000000 --markers" "--width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20" "--lights 10000" "--scene builtin --lights 1000 --sun-shadows 2048 --shadowed-lights 4 --markers"; do
  echo "=== $a" >> $R/validate.txt; $B --validate $a --frames 3 --warmup 1 --gbuffer auto >> $R/validate.txt 2>&1; echo "exit $?" >> $R/validate.txt; done
log "validate stream"; $BIN/lead-myriad-stream-bench --server $BIN/lead-myriad-server --lights 100000 --radius 0.5,2 --size 1920x1080 --large 1280x720 --streams 2 --requests 5 --seconds 2 --json $R/stream-validate.json -- --validate > $R/stream-validate.txt 2>&1
log done
log "late bounds (switch)"; MYRIAD_RESOLVE_BOUNDS_LATE=1 $B --width 1920 --height 1080 $C > $R/late.txt 2>&1; MYRIAD_RESOLVE_BOUNDS_LATE=1 $B --width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --gbuffer auto --frames 30 --warmup 5 --max-seconds 4 >> $R/late.txt 2>&1
log done2
