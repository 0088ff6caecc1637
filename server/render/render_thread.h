// The one thread that owns the Vulkan device and the renderer: render::RenderQueue's
// implementation. HTTP workers never touch Vulkan: they submit a frame here and wait on a future;
// the pixels come back as plain memory, and the worker encodes them. One owner means no locking
// inside the renderer and one queue submission at a time, which is what a single VkQueue wants
// anyway.
//
// Scheduling: every scene has its own FIFO of tasks (its edits and frames, in the order
// submitted); the thread takes the head of each scene's queue in turn (round-robin), so a scene
// with many frames waiting (several streams, a burst of requests) delays another scene's frame by
// at most one frame of each other scene, not by its whole backlog. A frame the renderer would
// hold the GPU with for longer than Renderer::kWholeFrameMilliseconds (any technique and size:
// many lights, many pixels) is split into submissions of about Renderer::kSliceMilliseconds,
// and each is one turn: other scenes' frames run between them (Renderer::SplitFrame; one split
// frame at a time, a second waits its turn while others pass it); one over the frame budget
// (setFrameBudgetMilliseconds) fails with FrameBudgetError. destroyScene drops its scene's frames
// still waiting or split (their futures get std::invalid_argument) instead of rendering them for
// nobody. A frame's queueMs ends where its work begins: its first part, or, behind frames in
// flight, when the last of them was seen done.
//
// Frames in flight: a whole frame's turn records and submits it into a free frame slot of the
// renderer (Renderer::beginFrame) without waiting, and the thread goes on to the next turn; the
// frames in flight are finished (waited for, read back, their futures kept) oldest first: when a
// turn needs a slot and none is free, when nothing else is queued, and before any edit (so a
// scene's tasks still finish in the order submitted). The GPU thus always has the next frame
// queued while the host copies out the previous one and HTTP workers encode it; the turns, and
// so the fairness between scenes, are as above. framesInFlight 1 is the serial path of before:
// each frame is finished right after it is submitted.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "gpu/context.h"
#include "render/frame.h"
#include "render/render_queue.h"
#include "render/renderer.h"
#include "scene/scene.h"

namespace myriad::render {

// How long the render thread waits with nothing to do before it gives back the memory that only
// frames use (Renderer::releaseFrameMemory, then the heap's free pages).
inline constexpr std::chrono::seconds kIdleTrim{2};
// What the idle trim keeps: the last frame's targets, sun maps and readback buffer when together
// they are at most this (a 1920x1080 frame's are about 200 MB, 64 MiB of them the sun's four
// 2048² cascades; below a 4096x4096 raw frame's 256 MiB readback), so that a stream's next still
// after a pause does not make them again (on a CPU device, first touching new memory cost a
// 1280x720 still tens of ms: bench/history/performance-2026-11-to-12.md); a larger frame's go back.
inline constexpr uint64_t kIdleKeepBytes = 224ull << 20;

class RenderThread final : public RenderQueue {
 public:
  // Starts the thread, which creates the Vulkan context and the renderer and uploads `scene` as
  // the default scene (`scene` need not outlive the constructor). Returns once frames can be
  // submitted; rethrows whatever start-up threw on the thread (gpu::NoDeviceError among others).
  // `framesInFlight`: frame slots (1..Renderer::kMaxFramesInFlight, clamped).
  // `overlapFrames`: Renderer::setOverlap. `timestamps`: Renderer::setGpuTimestamps.
  // `gbuffer`: Renderer::setGBufferPath. `tuning`: the renderer's knobs (render/tuning.h; its
  // pipelineStatistics is the context's, options.pipelineStatistics).
  RenderThread(const gpu::ContextOptions& options, const scene::Scene& scene,
               uint32_t maxQueuedFrames, uint32_t framesInFlight = kDefaultFramesInFlight,
               bool overlapFrames = false, GpuTimestamps timestamps = GpuTimestamps::Passes,
               GBufferPath gbuffer = GBufferPath::Raster, const Tuning& tuning = {});
  static constexpr uint32_t kDefaultFramesInFlight = 2;
  ~RenderThread() override;
  RenderThread(const RenderThread&) = delete;
  RenderThread& operator=(const RenderThread&) = delete;

  // RenderQueue; see render/render_queue.h. The device and the maximum size are fixed once the
  // constructor returns.
  const DeviceSummary& device() const override { return device_; }
  uint32_t maxDimension() const override { return maxDimension_; }
  uint32_t maxQueuedFrames() const override { return maxQueuedFrames_; }
  uint32_t validationMessages() const override;
  SceneId defaultScene() const override { return defaultScene_; }
  std::future<SceneId> createScene(std::shared_ptr<const scene::Scene> scene) override;
  std::future<void> replaceScene(SceneId id, std::shared_ptr<const scene::Scene> scene) override;
  std::future<void> destroyScene(SceneId id) override;
  std::future<void> updateLights(SceneId id, LightUpdate update) override;
  std::future<void> updateMaterials(SceneId id, std::vector<MaterialWrite> writes) override;
  std::future<void> updateInstances(SceneId id, InstanceUpdate update) override;
  std::future<void> setEnvironmentImage(
      SceneId id, std::shared_ptr<const scene::EnvironmentImage> image) override;
  std::future<Frame> submit(SceneId id, const FrameSettings& settings, FrameSource source,
                            std::shared_ptr<const std::atomic<bool>> drop) override;
  using RenderQueue::submit;  // submit(settings): the default scene
  void releaseHistory(SceneId id, uint64_t key) override;
  uint64_t gpuMemoryBytes() const override { return gpuMemoryBytes_.load(); }
  // The most renderer time one frame may take (Renderer::setFrameBudgetMilliseconds; 0, the
  // default: no limit). A frame over it fails with FrameBudgetError. Any thread, any time: frames
  // split from then on use it.
  void setFrameBudgetMilliseconds(double milliseconds) { frameBudgetMs_ = milliseconds; }
  // Renders the frames already queued, then releases the renderer and the device on the render
  // thread and joins it. Idempotent.
  void stop() override;

 private:
  // What one turn of a task did.
  enum class Step {
    Done,     // finished; its promise is kept
    More,     // a split frame with submissions left: stays at the head of its scene's queue
    Blocked,  // could not start (another split frame is unfinished): stays, others go first
    InFlight,  // a whole frame submitted: leaves the queue; finishOldest() keeps its promise
  };
  // One unit of work for the render thread; `run` fulfils its own promise.
  struct Task {
    SceneId scene = 0;     // whose queue: the scene it edits or renders (0: creating a scene)
    bool frame = false;    // a frame (dropped when its scene is destroyed)
    bool counted = false;  // a frame that counts against maxQueuedFrames (FrameSource::Request)
    bool destroy = false;  // destroyScene
    std::function<Step(Renderer&)> run;
    // A frame only: fails its promise without rendering (its scene is being destroyed).
    std::function<void()> cancel;
  };
  struct SceneQueue {
    std::deque<Task> tasks;   // oldest first; the head may be a split frame in progress
    // destroyScene tasks queued: while any is, the frames reaching the head are dropped (they
    // would render a scene about to go, for a session already closed).
    uint32_t destroys = 0;
  };

  // A frame's promise and progress, shared between its task's turns and its slot in flight.
  struct PendingFrame {
    std::promise<Frame> promise;
    std::chrono::steady_clock::time_point queued = std::chrono::steady_clock::now();
    double waitedMs = -1.0;  // until the frame started
    std::unique_ptr<Renderer::SplitFrame> split;
    // Milliseconds from `queued` to `t`.
    double msSinceQueued(std::chrono::steady_clock::time_point t) const {
      return std::chrono::duration<double, std::milli>(t - queued).count();
    }
  };
  // A frame submitted and not finished (render thread only).
  struct InFlight {
    uint32_t slot = 0;
    std::shared_ptr<PendingFrame> pending;
    bool counted = false;
    std::chrono::steady_clock::time_point begun;      // when its turn began recording it
    std::chrono::steady_clock::time_point submitted;  // when beginFrame returned
    // Other frames were in flight ahead of it: its GPU work began when the one before it ended.
    bool behind = false;
  };
  // Finishes the oldest frame in flight: reads it back and keeps its promise. Render thread.
  void finishOldest(Renderer& renderer);
  void finishAll(Renderer& renderer);

  // Queues `task`; throws RenderQueueFullError after stop() or, for a frame, when the queue is full.
  void enqueue(Task task);
  template <typename T, typename Work>
  std::future<T> enqueueWork(SceneId scene, Work work, bool destroy = false);
  // The next task to run (its queue's head; its scene is out of turns_ until finish()), or null
  // when no queue has one. Drops the frames of scenes being destroyed. mutex_ held.
  Task* pick();
  void finish(Task& task, Step step);  // mutex_ held

  void run(const gpu::ContextOptions& options, const scene::Scene& scene,
           std::promise<void>& ready);

  DeviceSummary device_;
  uint32_t maxDimension_ = 0;
  const uint32_t maxQueuedFrames_;
  const uint32_t framesInFlight_;
  const bool overlapFrames_;
  const GpuTimestamps timestamps_;
  const GBufferPath gbuffer_;
  const Tuning tuning_;
  std::deque<InFlight> inFlight_;  // oldest first; the render thread's alone
  // When the render thread saw the last frame it finished done on the GPU (render thread only):
  // where the GPU work of a frame submitted behind it began (its queue wait ends there).
  std::chrono::steady_clock::time_point lastFrameDone_;
  std::atomic<double> frameBudgetMs_{0.0};
  SceneId defaultScene_ = 0;
  std::atomic<uint64_t> gpuMemoryBytes_{0};
  // Points into the context the render thread owns; valid from start-up until stop().
  const std::atomic<uint32_t>* validationCounter_ = nullptr;

  std::mutex mutex_;
  std::condition_variable wake_;
  // Scenes with tasks, and the order they get their turns (a scene is in turns_ while it has
  // tasks and none of them is running). References to tasks stay valid across push_back.
  std::map<SceneId, SceneQueue> queues_;
  std::deque<SceneId> turns_;
  // counted frames queued, rendering, split or in flight, not yet answered
  uint32_t framesUnfinished_ = 0;
  bool stopping_ = false;

  std::thread thread_;
};

}  // namespace myriad::render
