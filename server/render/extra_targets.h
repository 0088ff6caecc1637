// A multi-target frame's extra read-backs (FrameSettings::alsoRead): after the frame's own
// readback, each extra view is drawn by the raw views pass from the same G-buffer and lighting
// and copied into its region of FrameTargets::extraReadback; the label pass's image is copied
// once for every label target. One render, several read-backs: the views pass is a full-screen
// compute dispatch, the copies are the cost of a raw frame's readback each.
#pragma once

#include <span>
#include <vulkan/vulkan.h>

#include "render/frame.h"
#include "render/frame_targets.h"
#include "render/passes.h"

namespace myriad::render {

// Where each of `settings.alsoRead` is read back: the region of extraReadback it lands in (the
// labels' one region shared by every label target), and how many regions there are.
struct ExtraRegions {
  std::vector<int> region;  // per alsoRead entry; -1: comes from the frame's own readback
  int labels = -1;          // the region holding the label image (-1: none needed)
  uint32_t count = 0;
};
ExtraRegions extraRegionsOf(const FrameSettings& settings);

// Where the extras are copied: `buffer` from `offset` on, a region of t.regionBytes() each (the
// frame's lent readback buffer after its pixels, or t.extraReadback from 0).
struct ExtraDestination {
  const gpu::Buffer* buffer = nullptr;
  VkDeviceSize offset = 0;
};

// Records the extra views and copies. `uniforms` is the frame's uniform buffer (its view index
// is rewritten on the GPU timeline for each view, then left so), `hostFlags` FrameUniforms::flags
// as the host wrote them; `rawSet` the target set whose output binding is t.extraOutput (for an
// 8-bit main output), or VK_NULL_HANDLE (raw main output: the bound set writes t.output, already
// copied out). The label image is in COLOR_ATTACHMENT_OPTIMAL from the label pass, unless the
// frame's own target is a label (then it was copied already and is not copied again).
void recordExtraTargets(VkCommandBuffer cmd, const Pipelines& p, const FrameTargets& t,
                        const FrameSettings& settings, const gpu::Buffer& uniforms,
                        VkDeviceSize flagsOffset, const uint32_t hostFlags[4], VkPipelineLayout layout,
                        VkDescriptorSet rawSet, ExtraDestination to);

// After the frame's fence: frame.extras and frame.labels. `lent`: the mapped regions in the
// frame's lent readback memory (they stay there, no copy); null: copied out of t.extraReadback
// into frame.extrasCopy.
void readExtraTargets(const FrameTargets& t, const FrameSettings& settings, Frame& frame,
                      const uint8_t* lent);

}  // namespace myriad::render
