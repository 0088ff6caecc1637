// The one thread that owns the Vulkan device and the renderer: render::RenderQueue's
// implementation. HTTP workers never touch Vulkan: they submit a frame here and wait on a future;
// the pixels come back as plain memory, and the worker encodes them. One owner means no locking
// inside the renderer and one queue submission at a time, which is what a single VkQueue wants
// anyway.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
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

class RenderThread final : public RenderQueue {
 public:
  // Starts the thread, which creates the Vulkan context and the renderer and uploads `scene` as
  // the default scene (`scene` need not outlive the constructor). Returns once frames can be
  // submitted; rethrows whatever start-up threw on the thread (gpu::NoDeviceError among others).
  RenderThread(const gpu::ContextOptions& options, const scene::Scene& scene,
               uint32_t maxQueuedFrames);
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
  std::future<void> setEnvironmentImage(
      SceneId id, std::shared_ptr<const scene::EnvironmentImage> image) override;
  std::future<Frame> submit(SceneId id, const FrameSettings& settings) override;
  using RenderQueue::submit;  // submit(settings): the default scene
  uint64_t gpuMemoryBytes() const override { return gpuMemoryBytes_.load(); }
  // Renders the frames already queued, then releases the renderer and the device on the render
  // thread and joins it. Idempotent.
  void stop() override;

 private:
  // One unit of work for the render thread; `run` fulfils its own promise.
  struct Task {
    bool frame = false;  // counts against maxQueuedFrames
    std::function<void(Renderer&)> run;
  };

  // Queues `task`; throws RenderQueueFullError after stop() or, for a frame, when the queue is full.
  void enqueue(Task task);
  template <typename T, typename Work>
  std::future<T> enqueueWork(bool frame, Work work);

  void run(const gpu::ContextOptions& options, const scene::Scene& scene,
           std::promise<void>& ready);

  DeviceSummary device_;
  uint32_t maxDimension_ = 0;
  const uint32_t maxQueuedFrames_;
  SceneId defaultScene_ = 0;
  std::atomic<uint64_t> gpuMemoryBytes_{0};
  // Points into the context the render thread owns; valid from start-up until stop().
  const std::atomic<uint32_t>* validationCounter_ = nullptr;

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Task> tasks_;  // waiting, oldest first
  uint32_t framesWaiting_ = 0;
  bool renderingFrame_ = false;
  bool stopping_ = false;

  std::thread thread_;
};

}  // namespace myriad::render
