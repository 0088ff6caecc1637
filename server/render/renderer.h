// The deferred renderer: one frame function, passes top to bottom (frame_recording.cpp, then
// after_lighting.cpp's steps), over any of the scenes it holds on the GPU (one per session, plus
// the server's built-in one). renderer_state.h lists the files that implement it.
// Not thread-safe: exactly one thread (the render thread) calls it. Every call but beginFrame is
// synchronous (waits for its GPU work); beginFrame leaves its frame in flight, in a frame slot of
// its own, until finishFrame (see "Frames in flight" below).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "gpu/context.h"
#include "render/frame.h"
#include "render/frame_pass.h"
#include "render/tuning.h"
#include "scene/environment_map.h"
#include "scene/scene.h"

namespace myriad::render {

class SubFrameResolve;  // render/sub_frames.h

class Renderer {
 public:
  // `tuning`: the knobs (render/tuning.h), resolved here once for the context's device.
  explicit Renderer(gpu::Context& context, const Tuning& tuning = {});
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Uploads the scene's meshes, instances, materials and lights; returns its new id. The scene's
  // sun, ambient and background are not uploaded: they come with each frame (FrameSettings).
  // Throws std::invalid_argument for an inconsistent scene (an instance naming a missing mesh or
  // material) and gpu errors (out of device memory); nothing is created then.
  SceneId createScene(const scene::Scene& scene);
  // Replaces everything of `id` with `scene`. On failure the old scene stays as it was.
  void replaceScene(SceneId id, const scene::Scene& scene);
  // Frees the scene's GPU memory at once.
  void destroyScene(SceneId id);

  // Writes lights (both where they are and the animation's origins); see LightUpdate.
  // Throws std::invalid_argument for a write at or past `count`, or an unwritten new index.
  void updateLights(SceneId id, const LightUpdate& update);
  // Writes materials' base colour, metallic and roughness (names are not kept on the GPU).
  // Throws std::invalid_argument for an index past the scene's materials.
  void updateMaterials(SceneId id, const std::vector<MaterialWrite>& writes);
  // Moves instances of scene `id` in place (SceneBuffers::updateInstances).
  void updateInstances(SceneId id, const InstanceUpdate& update);

  // The equirectangular image the scene's `hdr` environment shows (at the source size,
  // scene::resampleEquirect). Kept across replaceScene; freed with the scene. The maps are
  // rebuilt at the next frame that uses them.
  void setEnvironmentImage(SceneId id, std::shared_ptr<const scene::EnvironmentImage> image);
  // How many times the scene's environment maps were built (0 before the first frame with the
  // environment on): they are rebuilt only when the mode, the image or (sky) the sun changes.
  uint64_t environmentRebuilds(SceneId id) const;

  // Renders one frame of scene `id` and reads it back. Throws std::invalid_argument for an
  // `hdr` environment without an image (setEnvironmentImage). Throws std::invalid_argument for a size
  // outside 1..maxDimension(). Needs a free frame slot (std::logic_error otherwise):
  // finishFrame(beginFrame(id, settings)).
  Frame render(SceneId id, const FrameSettings& settings);

  // Frames in flight. Each of framesInFlight() frame slots has its own command buffer and fence,
  // uniforms, descriptor sets, targets (with the readback buffer), shadow map, timestamps and
  // copy of the culling counters. beginFrame records a frame into a free slot and submits it
  // without waiting; finishFrame waits for it and reads it back. So the host records and submits
  // frame N+1 (and copies N out) while the GPU renders, and the queue never runs dry between
  // frames. On the GPU the frames still run one after another: each frame's commands start with
  // a full memory barrier, because frames share the scenes' light buffers (animation writes them)
  // and the techniques' light lists and counters. What the host changes under frames in flight
  // waits for them first (every edit, a split frame's part, list growth, and a frame whose
  // technique, size, raw format or light count differs from the previous one, since the
  // technique may reallocate its lists then; an environment rebuild): the renderer waits for the
  // fences of the slots in flight, which then only need finishing. 1 (the default) is the
  // serial renderer of before: at most one frame in flight.
  static constexpr uint32_t kMaxFramesInFlight = 4;
  // 1..kMaxFramesInFlight (clamped); std::logic_error while a frame is in flight.
  void setFramesInFlight(uint32_t frames);
  uint32_t framesInFlight() const;
  // Overlap on the GPU (off by default): a frame of a scene no frame in flight draws starts
  // without the full barrier, so its passes before lighting (animation, shadow, G-buffer: its
  // own slot's targets and its own scene's buffers) may run while the previous frame lights and
  // finishes; the full barrier moves to just before its lighting (the techniques' shared lists
  // and counters). A frame of a scene already in flight keeps the barrier at its start (its
  // animation rewrites the lights the other frame reads). Off: every frame starts with it.
  void setOverlap(bool overlap);
  // Per-pass timestamps (the default), only the frame's first and last (one pass, "frame"), or
  // none (frames report no passes): a timestamp at ALL_COMMANDS may drain the GPU there.
  void setGpuTimestamps(GpuTimestamps mode);
  // How G-buffers are made (GBufferPath, render/frame.h; Raster until set). Takes effect from
  // the next frame; each frame reports the path it took in its pass names.
  void setGBufferPath(GBufferPath path);
  // Whether beginFrame has a free slot.
  bool canBegin() const;
  // Records and submits a frame into a free slot (the lowest: a client that waits for each frame
  // uses, and allocates targets for, one slot only); returns the slot. Throws what render()
  // throws, and std::logic_error when no slot is free; nothing is in flight then.
  uint32_t beginFrame(SceneId id, const FrameSettings& settings);
  // Whether the GPU has finished the frame in flight in `slot` (finishFrame will not wait).
  bool frameDone(uint32_t slot) const;
  // Waits at most `timeoutNs` for it; true once finished.
  bool waitFrame(uint32_t slot, uint64_t timeoutNs) const;
  // Waits for the frame in `slot` (beginFrame's) and reads it back; the slot is free afterwards,
  // even when this throws. When the technique's lists overflowed and may grow, waits for every
  // frame in flight, grows them and renders the frame again (in the same slot, synchronously),
  // as render() always did. A frame whose scene was destroyed meanwhile keeps what it rendered.
  Frame finishFrame(uint32_t slot);

  // Frames too long for one submission. A GPU submission cannot be preempted, so a frame
  // estimated to hold the queue for more than kWholeFrameMilliseconds is recorded as a sequence
  // of submissions of about kSliceMilliseconds each, every one waited for: the passes before the
  // lighting, then the technique's lighting steps in ranges of their units (volumes: lights;
  // tiled: tiles; clustered: its assignment's passes over the lights in ranges, the rest whole,
  // then its shading in ranges of tiles), then the passes after it (the final pass in ranges of
  // its workgroups, anti-aliasing, the readback). Each range is sized from what the ones before it
  // cost (LightingTechnique::unitWeights says where units differ). The caller (the render thread)
  // runs other scenes' frames and edits between them. A split frame has its own targets,
  // uniforms, descriptor sets and technique instance (lists, counters), so whole frames rendered
  // meanwhile leave it untouched; only one split frame exists at a time. Its scene must not be
  // edited, replaced or destroyed until it finishes or is dropped (the render thread queues a
  // scene's tasks behind its frame). Its image equals the frame rendered whole (the same commands,
  // in the same order, cut between submissions).
  class SplitFrame;
  static constexpr double kSliceMilliseconds = 200.0;
  // Frames estimated under this render whole (frames in flight, no waits between parts): the
  // longest a whole frame is expected to hold the queue for others. A frame not measured yet is
  // estimated from its pixels and lights (shouldSplit).
  static constexpr double kWholeFrameMilliseconds = 400.0;
  // The slice (default kSliceMilliseconds); tests make it tiny to split small frames. The whole
  // frame bound follows it (twice the slice).
  void setSliceMilliseconds(double milliseconds);
  // The most host time one split frame may take, its parts together (0: no limit, the default).
  // A frame that has taken it, or whose measured parts say it will, stops with
  // FrameBudgetError (render/frame.h) at its next part.
  void setFrameBudgetMilliseconds(double milliseconds);
  // Whether render(id, settings) is estimated to take longer than a whole frame may.
  bool shouldSplit(SceneId id, const FrameSettings& settings) const;
  // What render(id, settings) is estimated to take, in milliseconds: from the last frame of the
  // scene with that technique (scaled by the pixels), or -1 when it has none with about as many
  // lights.
  double estimateMilliseconds(SceneId id, const FrameSettings& settings) const;
  // True while a split frame is unfinished (and not dropped).
  bool splitBusy() const;
  // Starts a split frame and runs its first submission. Throws what render() throws, and
  // std::logic_error while another split frame is unfinished.
  std::unique_ptr<SplitFrame> beginSplit(SceneId id, const FrameSettings& settings);
  // Runs the next submission of `frame`; after the last one, returns the frame (read back).
  // Throws FrameBudgetError once the frame is over the budget (setFrameBudgetMilliseconds).
  std::optional<Frame> continueSplit(SplitFrame& frame);

  // Every method taking a SceneId throws std::invalid_argument for an id that is not (or no
  // longer) a scene of this renderer.
  bool hasScene(SceneId id) const;
  uint32_t lightCount(SceneId id) const;
  uint64_t sceneBytes(SceneId id) const;  // GPU memory of that scene

  // GPU memory the renderer holds: every scene, the frame targets, the light lists, uniforms.
  uint64_t gpuMemoryBytes() const;

  // Frees what only frames use, sized to the last output (the G-buffer, HDR and output images,
  // the sun's shadow map and the readback buffers); the next frame makes them again. Scenes are
  // kept. With keepBytes > 0 the slot of the last whole frame keeps its targets, sun map and one
  // readback buffer when together they hold at most keepBytes (RenderThread's idle trim: the
  // next still of a stream at that size does not make them again).
  void releaseFrameMemory(uint64_t keepBytes = 0);
  // Frees a stream's taa history (FrameSettings::historyKey, render/temporal.h) now, after the
  // frames in flight; nothing when there is none. The histories held and their GPU memory
  // (counted in gpuMemoryBytes too).
  void releaseHistory(uint64_t key);
  size_t historyCount() const;
  uint64_t historyBytes() const;

  // The largest width or height render() accepts on this device.
  uint32_t maxDimension() const;

  // For tests: caps the clustered light lists at `bytes` (0: the device's maxStorageBufferRange,
  // the default), and starts them at `startBytes` (0: sized from the output and the light count,
  // at least 2^18 references) so that overflow and growth are reachable at small sizes. Forgets
  // what the lists grew to.
  void limitListMemory(uint64_t bytes, uint64_t startBytes = 0);

 private:
  // One frame of the GPU's (a sub-frame of a taa or ssaa frame, or any other frame): beginFrame
  // and finishFrame around render/sub_frames.h's sub-frames.
  uint32_t beginWhole(SceneId id, const FrameSettings& settings);
  Frame finishWhole(uint32_t slot);

  struct State;
  std::unique_ptr<State> state_;
};

// A split frame in progress (Renderer::beginSplit). Dropping it before the last submission
// abandons the frame (nothing is in flight between submissions) and frees the split targets for
// the next split frame.
class Renderer::SplitFrame {
 public:
  ~SplitFrame();
  SplitFrame(const SplitFrame&) = delete;
  SplitFrame& operator=(const SplitFrame&) = delete;

  uint32_t submissions() const { return submissions_; }  // run so far
  // Host time its submissions took so far (recording, submitting, waiting), in milliseconds.
  double elapsedMilliseconds() const { return elapsedMs_; }
  // What the whole frame is estimated to take from its parts measured so far (at least elapsed).
  double projectedMilliseconds() const;

 private:
  friend class Renderer;
  SplitFrame(Renderer& renderer, SceneId scene, const FrameSettings& settings)
      : renderer_(renderer), scene_(scene), settings_(settings) {}

  // One step of the frame: `units` that may be recorded in ranges, [first, first + count).
  struct Step {
    uint32_t units = 0;
    uint32_t declaredUnits = 0;  // `units` before the technique said how many have work
    std::function<void(VkCommandBuffer cmd, uint32_t first, uint32_t count)> record;
    // Relative costs of the units (empty: alike), known once the steps before it ran.
    std::vector<float> weights;
    bool weighed = false;     // `weights` asked for (after the step before it ran)
    int lightingStep = -1;    // the technique's step it records, or -1
    bool listsBuilt = false;  // the technique's lists are complete after it
    bool unitsAlike = true;   // LightingTechnique::Step::unitsAlike
    double msPerWeight = 0.0;  // measured (0: not yet); a unit weighs 1 without weights
    uint32_t lastRange = 0;    // units in its last range
    double lastRangeWeight = 0.0;  // and their weight
    // A range of it took a good share of a slice: its cost is not mostly a part's overhead, and
    // may project what its other units take (projectedMilliseconds).
    bool measuredWell = false;
    double weightOf(uint32_t first, uint32_t count) const;
  };

  Renderer& renderer_;
  SceneId scene_;
  FrameSettings settings_;
  std::vector<Step> steps_;
  size_t step_ = 0;       // the next step to record
  uint32_t nextUnit_ = 0;  // its next unit
  size_t firstLightingStep_ = 0;
  // Where the steps after the lighting left the images they hand on (render/frame_pass.h).
  FrameImageStates images_;
  uint32_t submissions_ = 0;
  double elapsedMs_ = 0.0;
  bool listsGrew_ = false;
  std::vector<PassTiming> passes_;  // summed by name over the submissions
  // A taa or ssaa frame: its sub-frames, run one after another (settings_ is the current one's).
  std::shared_ptr<SubFrameResolve> resolve_;
  double subFrameStartMs_ = 0.0;  // elapsedMs_ when the current sub-frame began
};

}  // namespace myriad::render
