#!/usr/bin/env bash
# Lead, stop 14 final: main's binaries (myriad-*-main), issue 16's and 18's Done-means commands.
R="bash .devpack/run.sh"; B=.devpack/bin
t0=$(date +%s); log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a $OUT/log.txt; }
log "bench 1080p"; $R $B/myriad-bench-main --width 1920 --height 1080 --techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --json $OUT/bench-1080.json > $OUT/bench.txt 2>&1
log "bench 2160p"; $R $B/myriad-bench-main --width 3840 --height 2160 --techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --json $OUT/bench-2160.json >> $OUT/bench.txt 2>&1
log "bench large"; $R $B/myriad-bench-main --width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --frames 30 --warmup 5 --max-seconds 4 >> $OUT/bench.txt 2>&1
log "bench raster 1080p"; $R $B/myriad-bench-main --width 1920 --height 1080 --techniques clustered --lights 1000000 --gbuffer raster --frames 30 --warmup 5 --max-seconds 4 >> $OUT/bench.txt 2>&1
log "stream bench"; $R $B/myriad-stream-bench-main --server $B/myriad-server-main --lights 100000 --radius 0.5,2 --size 1920x1080 --large 3840x2160 --streams 8 --requests 20 --seconds 10 --json $OUT/stream-bench.json > $OUT/stream-bench.txt 2>&1
log "validate"; for a in "--lights 10000,1000000" "--width 3840 --height 2160 --techniques clustered --lights 1000000 --markers" "--scene builtin --lights 1000 --sun-shadows 2048 --shadowed-lights 4 --markers"; do
  $R $B/myriad-bench-main --validate $a --frames 3 --warmup 1 >> $OUT/validate.txt 2>&1; echo "exit $?" >> $OUT/validate.txt; done
log "validate stream"; $R $B/myriad-stream-bench-main --server $B/myriad-server-main --lights 100000 --radius 0.5,2 --size 1920x1080 --large 1280x720 --streams 2 --requests 5 --seconds 2 --json $OUT/stream-validate.json -- --validate > $OUT/stream-validate.txt 2>&1
log done
