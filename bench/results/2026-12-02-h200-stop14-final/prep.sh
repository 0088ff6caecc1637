#!/usr/bin/env bash
# Lead: pack the binaries that /work/wt/gpu-requests/*.sh name (renamed <name>-<worktree>), plus
# main's, the validation layer and the request scripts, into /work/main/.devpack.
set -euo pipefail
stage=/tmp/gpupack; rm -rf $stage; mkdir -p $stage
lead=/work/wt/lead/build/release/server
cp $lead/bench/myriad-bench $stage/myriad-bench-main
cp $lead/myriad-server $stage/myriad-server-main
cp $lead/bench/myriad-stream-bench $stage/myriad-stream-bench-main
for req in /work/wt/gpu-requests/*.sh; do
  [ -f "$req" ] || continue
  wt=$(basename "$req" .sh)
  for b in $(grep -h '^# binaries:' "$req" | sed 's/^# binaries://'); do
    n=$(basename "$b")
    case "$n" in *-$wt) cp "$b" "$stage/$n";; *) cp "$b" "$stage/$n-$wt";; esac
  done
done
ls -la $stage
cd /work/main
bash ../shared/device/pack.sh $stage/* /usr/lib/x86_64-linux-gnu/libVkLayer_khronos_validation.so \
  /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json >/dev/null
mkdir -p .devpack/requests
cp /work/wt/gpu-requests/*.sh .devpack/requests/ 2>/dev/null || true
cp /work/wt/gpu/run_batch.sh .devpack/
[ -f /work/wt/gpu/lead.sh ] && cp /work/wt/gpu/lead.sh .devpack/requests/lead.sh
du -sh .devpack; ls .devpack/bin .devpack/requests
