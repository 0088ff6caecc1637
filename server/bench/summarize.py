#!/usr/bin/env python3
"""Markdown tables from myriad-bench JSON files (for docs/performance.md).

    python3 server/bench/summarize.py bench/results/DIR/*.json
"""
import json
import sys


def rows(path):
    run = json.load(open(path))
    for c in run["configs"]:
        size = f'{c["width"]}x{c["height"]}'
        if "skipped" in c:
            continue
        cull = c["culling"]
        dropped = cull["most_tile_lights_dropped"] + cull["most_cluster_lights_dropped"]
        overflow = "0" if cull["frames_overflowed"] == 0 else f'**{dropped:,} dropped**'
        mib = (c["gpu_memory_bytes"]["lights"] + c["gpu_memory_bytes"]["lists"]) / 2**20
        yield (f'| {c["scene"]} | {size} | {c["lights"]:,} | {c["technique"]} | {c["timed_frames"]} '
               f'| {c["frame_ms"]["median"]:.3f} / {c["frame_ms"]["p90"]:.3f} '
               f'| {c["lighting_ms"]["median"]:.3f} / {c["lighting_ms"]["p90"]:.3f} '
               f'| {c["pairs_per_pixel"]:.1f} '
               f'| {c["pairs_per_second"] / 1e9:.3g} | {100 * c["fraction_of_h200_ceiling"]:.3g}% '
               f'| {overflow} | {cull["list_entries"]:,} | {cull["active_clusters"]} '
               f'| {cull["most_lights_in_list"]:,} | {mib:.1f} | {c["validation_messages"]} |')


print('| scene | size | lights | technique | frames | frame ms (median / p90) | lighting ms (median / p90) '
      '| pairs/px | Gpairs/s | of ceiling | overflow | list entries | active clusters '
      '| longest list | lights+lists MiB | validation msgs |')
print('|' + '---|' * 16)
for path in sys.argv[1:]:
    for row in rows(path):
        print(row)
