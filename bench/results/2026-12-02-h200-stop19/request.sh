#!/usr/bin/env bash
# binaries: /work/wt/bins/s19/myriad-bench-s19 /work/wt/bins/s19/myriad-server-s19 /work/wt/bins/s19/myriad-stream-bench-s19 /work/wt/bins/final/myriad-bench-final
# Stop 19: main at 65e9702 (texel views for lights/materials, CPU final split) against stop 18's final binary (base).
B=$BIN/lead-myriad-bench-s19; BASE=$BIN/lead-myriad-bench-final
C="--techniques clustered --lights 10000,1000000 --frames 30 --warmup 5 --max-seconds 4 --gbuffer auto"
t0=$(date +%s); log() { echo "== $(( $(date +%s) - t0 ))s $*" | tee -a $R/steps.log; }
log "bench 1080p"; $B --width 1920 --height 1080 $C --json $R/bench-1080.json > $R/bench.txt 2>&1
log "base 1080p"; $BASE --width 1920 --height 1080 $C > $R/base.txt 2>&1
log "bench 1080p r2"; $B --width 1920 --height 1080 $C > $R/bench-r2.txt 2>&1
log "base 1080p r2"; $BASE --width 1920 --height 1080 $C > $R/base-r2.txt 2>&1
log "bench 2160p"; $B --width 3840 --height 2160 $C --json $R/bench-2160.json >> $R/bench.txt 2>&1
log "base 2160p"; $BASE --width 3840 --height 2160 $C >> $R/base.txt 2>&1
log "bench large"; $B --width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --gbuffer auto --frames 30 --warmup 5 --max-seconds 4 >> $R/bench.txt 2>&1
log "base large"; $BASE --width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20 --gbuffer auto --frames 30 --warmup 5 --max-seconds 4 >> $R/base.txt 2>&1
for g in raster; do
log "bench builtin raster"; $B --width 1920 --height 1080 --scene builtin --techniques clustered --lights 100000 --gbuffer raster --frames 30 --warmup 5 --max-seconds 4 >> $R/bench.txt 2>&1
log "base builtin raster"; $BASE --width 1920 --height 1080 --scene builtin --techniques clustered --lights 100000 --gbuffer raster --frames 30 --warmup 5 --max-seconds 4 >> $R/base.txt 2>&1
done
log "stream bench"; $BIN/lead-myriad-stream-bench-s19 --server $BIN/lead-myriad-server-s19 --lights 100000 --radius 0.5,2 --size 1920x1080 --large 3840x2160 --streams 8 --requests 20 --seconds 5 --json $R/stream-bench.json > $R/stream-bench.txt 2>&1
log "validate"; for a in "--lights 10000,1000000 --techniques clustered" "--width 3840 --height 2160 --techniques clustered --lights 1000 --lights-per-point 20" "--lights 10000" "--scene builtin --lights 1000 --sun-shadows 2048 --shadowed-lights 4 --markers" "--scene builtin --lights 1000 --gbuffer raster --markers"; do
  echo "=== $a" >> $R/validate.txt; $B --validate $a --frames 3 --warmup 1 --gbuffer auto >> $R/validate.txt 2>&1; echo "exit $?" >> $R/validate.txt; done
log "validate stream"; $BIN/lead-myriad-stream-bench-s19 --server $BIN/lead-myriad-server-s19 --lights 100000 --radius 0.5,2 --size 1920x1080 --large 1280x720 --streams 2 --requests 5 --seconds 2 --json $R/stream-validate.json -- --validate > $R/stream-validate.txt 2>&1
log done
