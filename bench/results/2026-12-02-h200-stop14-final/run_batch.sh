#!/usr/bin/env bash
# On the GPU machine, from the repo root: run each request script (or those named) with a time
# limit, each writing under $OUT/NAME; tar each NAME's output into $OUT/NAME.tgz as it goes.
set -u
OUTROOT=$OUT; W=/tmp/gpuwork; mkdir -p $W
export VK_LAYER_PATH=$PWD/.devpack/data LD_LIBRARY_PATH=$PWD/.devpack/bin${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
names=${*:-$(cd .devpack/requests && ls *.sh | sed 's/\.sh$//')}
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $W/device.txt 2>&1
for n in $names; do
  mkdir -p $W/$n; t0=$(date +%s)
  echo "== $n start $(date -u +%H:%M:%S)" >> $W/log.txt
  OUT=$W/$n timeout ${LIMIT:-150} bash .devpack/requests/$n.sh > $W/$n/stdout.txt 2>&1
  echo "== $n exit $? after $(( $(date +%s) - t0 ))s" | tee -a $W/log.txt
  cp $W/device.txt $W/log.txt $W/$n/
  (cd $W && tar czf $OUTROOT/$n.tgz $n)
done
cp $W/log.txt $OUTROOT/
