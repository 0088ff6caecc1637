// Temporal anti-aliasing of a stream's frames (antialias=taa with FrameSettings::historyKey;
// docs/ARCHITECTURE.md, "`taa` on a stream"). A still's taa is made of 8
// sub-frames resolved on the host (render/sub_frames.h); a stream's taa frame is ONE frame,
// jittered by the next of the Halton (2,3) offsets (taaJitter, the stills' table), whose 8-bit
// picture a compute pass (shaders/temporal_resolve.comp, timer name "taa") resolves against the
// stream's history: reprojected by the camera's motion, rejected off-screen and on
// disocclusions (view depth), clamped to the frame's 3x3 YCoCg box, blended.
//
// Where the history lives: here, in the renderer (Renderer::State::temporal), on the GPU: per
// key, two RGBA16F images (YCoCg and the sample count: this frame's history and the next), two
// R32F images (the view depth each was made with), ping-ponged frame by frame, and an RGBA8 sRGB
// image the frame's picture is copied into (its reads come decoded), 28 bytes a pixel in an arena
// of their own; with the host's record of the previous frame's view-projection. Keyed by
// FrameSettings::historyKey (a stream's own key, service/stream.cpp). Bounded: at most
// kMaxHistories keys and kMaxHistoryBytes together (the least recently used goes first); a frame
// whose history alone would pass kMaxHistoryBytes renders as `none`. Freed: by
// Renderer::releaseHistory (the stream ended), when the key's size changes (made again), and by
// Renderer::releaseFrameMemory (the render thread's idle trim).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>

#include <glm/glm.hpp>
#include <vulkan/vulkan.h>

#include "gpu/context.h"
#include "gpu/resources.h"
#include "render/frame.h"
#include "render/frame_targets.h"

namespace myriad::render {

// The history keys kept at once, and their GPU memory together (28 bytes a pixel each: 26 MB
// at 1280x720, 232 MB at 3840x2160).
inline constexpr size_t kMaxHistories = 8;
inline constexpr uint64_t kMaxHistoryBytes = 512ull << 20;
// The relative view-depth difference past which a reprojected history is a disocclusion.
inline constexpr float kDisocclusionDepth = 0.05f;

// What one frame of a history does (TemporalHistories::plan), kept in its frame slot so that a
// frame recorded again (its lists grew) reads and writes the same images.
struct TemporalFramePlan {
  bool active = false;
  uint64_t key = 0;
  uint64_t generation = 0;  // the history's (made again: another generation)
  uint32_t read = 0;        // the image pair read (the other is written)
  bool hasHistory = false;  // the pair read holds an earlier frame
  bool fresh = false;       // the images were just made: their first use transitions them
  glm::mat4 reprojection{1.0f};
  glm::vec2 jitter{0.0f};
  float nearPlane = 0.1f, farPlane = 100.0f;
};

class TemporalHistories {
 public:
  // `waitIdle`: waits for every frame in flight (State::quiesce), before memory they may use
  // goes. `nearest`: a nearest sampler (depth); `linear`: a linear one (the history).
  TemporalHistories(gpu::Context& context, VkSampler nearest, VkSampler linear,
                    std::function<void()> waitIdle);
  ~TemporalHistories();
  TemporalHistories(const TemporalHistories&) = delete;
  TemporalHistories& operator=(const TemporalHistories&) = delete;

  // For a frame with settings.temporalHistory(): the settings it renders with (jittered) and its
  // plan; advances the key's history (made or made again first). Any other frame: the settings
  // as they are, an inactive plan. A history too large for kMaxHistoryBytes: the frame as `none`.
  FrameSettings plan(const FrameSettings& settings, TemporalFramePlan& out);
  // After the final pass (the output GENERAL, written by compute): the resolve, in the output.
  // `slotKey`: the frame slot's own descriptor set (its scene set), rewritten here. Records
  // nothing when the plan's history is gone (freed meanwhile): the frame stays as rendered.
  // Returns whether it recorded. Binds its own compute layout: the caller binds its sets again.
  // Whether the plan's history is still here, at the targets' size (record() records then).
  bool holds(const TemporalFramePlan& plan, VkExtent2D extent) const;
  bool record(VkCommandBuffer cmd, const FrameTargets& t, const TemporalFramePlan& plan,
              VkDescriptorSet slotKey);

  void release(uint64_t key);  // waits for frames in flight first
  void releaseAll();
  uint64_t bytes() const;
  size_t count() const { return histories_.size(); }

 private:
  struct History {
    uint32_t width = 0, height = 0;
    uint64_t generation = 0;
    std::unique_ptr<gpu::Arena> arena;
    gpu::Image color[2];
    gpu::Image depth[2];
    gpu::Image picture;  // the frame's output copied (RGBA8 UNORM, as the output)
    VkImageView pictureSrgb = VK_NULL_HANDLE;  // its sRGB view: reads come decoded
    uint32_t current = 0;    // the pair the last frame wrote
    uint64_t frames = 0;     // frames made into it (the jitter's index)
    uint64_t lastUsed = 0;
    glm::mat4 viewProjection{1.0f};  // the last frame's, unjittered
    bool fresh = true;
  };
  void evict(uint64_t incoming);

  gpu::Context& context_;
  VkSampler nearest_, linear_;
  std::function<void()> waitIdle_;
  VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  std::map<VkDescriptorSet, VkDescriptorSet> sets_;  // per frame slot (its scene set)
  std::map<uint64_t, History> histories_;
  uint64_t uses_ = 0;
  uint64_t generations_ = 0;
};

}  // namespace myriad::render
