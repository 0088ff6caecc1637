# sourced by gpu_run.sh: $R (run.sh), $B (bin dir), $O (out), $small
SB_SIZE=1920x1080; SB_LARGE=3840x2160; SB_LIGHTS=100000; SB_SEC=4
if [[ -n $small ]]; then SB_SIZE=160x90; SB_LARGE=none; SB_LIGHTS=500; SB_SEC=2; fi
for mode in 1 2 "3 --overlap-frames"; do
  tag=$(echo $mode | tr -d ' -')
  log "stream-bench fif $mode"
  timeout 120 $R $B/myriad-stream-bench --server $B/myriad-server --lights $SB_LIGHTS --radius 0.5,2 \
    --size $SB_SIZE --large $SB_LARGE --streams 8 --requests 20 --seconds $SB_SEC \
    --json $O/stream-bench-fif$tag.json -- --frames-in-flight $mode > $O/stream-bench-fif$tag.txt 2>&1
done
log "stream-bench validate overlap"
timeout 90 $R $B/myriad-stream-bench --server $B/myriad-server --lights $SB_LIGHTS --streams 2 --seconds 2 --large none --requests 3 \
  --json $O/stream-bench-validate.json -- --validate --overlap-frames > $O/stream-bench-validate.txt 2>&1; echo "exit $?" >> $O/validate.txt
log "bandwidth 2 viewers"
BW_W=1920; BW_H=1080; [[ -n $small ]] && { BW_W=320; BW_H=180; }
timeout 150 bash $P/stream_bandwidth.sh "$R $B/myriad-server" "$R $B/myriad-stream-bandwidth" \
  --width $BW_W --height $BW_H --fps 30 --lights 1000 --seconds $SB_SEC --codecs vp9 --viewers 2 \
  --psnr-samples 4 --latency-edits 5 --json $O/stream-bandwidth-2viewers.json > $O/stream-bandwidth.txt 2>&1
log "light shadows"
LW=1920; LH=1080; LW4=3840; LH4=2160; [[ -n $small ]] && { LW=320; LH=180; LW4=640; LH4=360; }
for size in "$LW $LH" "$LW4 $LH4"; do set -- $size; for kind in point spot; do for n in 0 16; do
  echo "== light-shadows $1x$2 $kind $n" >> $O/light-shadows.txt
  timeout 60 $R $B/myriad-bench --scene builtin --width $1 --height $2 --techniques clustered --lights 1000 \
    --frames 20 --warmup 5 --max-seconds 3 --sun-shadows 2048 --shadowed-lights $n --shadowed-kind $kind >> $O/light-shadows.txt 2>&1
done; done; done
for n in 0 16; do
  echo "== light-shadows 100k ${LW}x$LH point $n" >> $O/light-shadows.txt
  timeout 60 $R $B/myriad-bench --scene floor --width $LW --height $LH --techniques clustered --lights 100000 \
    --frames 10 --warmup 3 --max-seconds 3 --sun-shadows 2048 --shadowed-lights $n --shadowed-kind point >> $O/light-shadows.txt 2>&1
done
log "validate shadows"
$R $B/myriad-bench --validate --scene builtin --width $LW --height $LH --lights 1000 --frames 3 --warmup 1 --sun-shadows 2048 --shadowed-lights 4 --shadowed-kind point >> $O/validate.txt 2>&1; echo "exit $?" >> $O/validate.txt
