// The one thread that owns the Vulkan device and the renderer. HTTP workers never touch Vulkan:
// they submit a frame here and wait on a future; the pixels come back as plain memory, and the
// worker encodes them. One owner means no locking inside the renderer and one queue submission
// at a time, which is what a single VkQueue wants anyway.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include "gpu/context.h"
#include "gpu/device_info.h"
#include "render/renderer.h"
#include "render/frame.h"
#include "scene/scene.h"

namespace myriad::service {

// Every task (scene edits and frames) runs on the render thread in the order submitted, so a
// frame submitted after an edit sees the edit. Exceptions a task throws there (an unknown scene:
// std::invalid_argument; out of device memory: gpu::VulkanError) reach its future; the thread
// keeps serving.

// submit() found the queue full (or the thread stopping); the client should retry later.
class RenderQueueFullError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class RenderThread {
 public:
  // Starts the thread, which creates the Vulkan context and the renderer and uploads `scene` as
  // the default scene (`scene` need not outlive the constructor). Returns once frames can be
  // submitted; rethrows whatever start-up threw on the thread (gpu::NoDeviceError among others).
  RenderThread(const gpu::ContextOptions& options, const scene::Scene& scene,
               uint32_t maxQueuedFrames);
  ~RenderThread();
  RenderThread(const RenderThread&) = delete;
  RenderThread& operator=(const RenderThread&) = delete;

  // Fixed at start-up; safe from any thread.
  const gpu::DeviceInfo& device() const { return device_; }
  uint32_t maxDimension() const { return maxDimension_; }
  uint32_t maxQueuedFrames() const { return maxQueuedFrames_; }

  // Validation messages so far; safe from any thread until stop().
  uint32_t validationMessages() const;

  // The scene given to the constructor (GET /v1/frame's built-in scene). Never destroyed.
  render::SceneId defaultScene() const { return defaultScene_; }

  // Scene edits: queued like frames (never refused for a full queue), run in order. Each throws
  // RenderQueueFullError only after stop(). See render::Renderer for what each does and throws.
  std::future<render::SceneId> createScene(std::shared_ptr<const scene::Scene> scene);
  std::future<void> replaceScene(render::SceneId id, std::shared_ptr<const scene::Scene> scene);
  std::future<void> destroyScene(render::SceneId id);
  std::future<void> updateLights(render::SceneId id, render::LightUpdate update);
  std::future<void> updateMaterials(render::SceneId id, std::vector<render::MaterialWrite> writes);

  // Queues a frame of scene `id`; the future holds the frame or what the renderer threw. The
  // settings carry the sun, ambient and background (FrameSettings::takeLightingFrom). Throws
  // RenderQueueFullError when maxQueuedFrames frames already wait behind the one rendering, or
  // after stop(). Only frames count against maxQueuedFrames.
  std::future<render::Frame> submit(render::SceneId id, const render::FrameSettings& settings);
  // The same for the default scene.
  std::future<render::Frame> submit(const render::FrameSettings& settings) {
    return submit(defaultScene_, settings);
  }

  // GPU memory the renderer holds (every scene, targets, lists), as of the last task finished.
  uint64_t gpuMemoryBytes() const { return gpuMemoryBytes_.load(); }

  // Renders the frames already queued, then releases the renderer and the device on the render
  // thread and joins it. Idempotent.
  void stop();

 private:
  // One unit of work for the render thread; `run` fulfils its own promise.
  struct Task {
    bool frame = false;  // counts against maxQueuedFrames
    std::function<void(render::Renderer&)> run;
  };

  // Queues `task`; throws RenderQueueFullError after stop() or, for a frame, when the queue is full.
  void enqueue(Task task);
  template <typename T, typename Work>
  std::future<T> enqueueWork(bool frame, Work work);

  void run(const gpu::ContextOptions& options, const scene::Scene& scene,
           std::promise<void>& ready);

  gpu::DeviceInfo device_;
  uint32_t maxDimension_ = 0;
  const uint32_t maxQueuedFrames_;
  render::SceneId defaultScene_ = 0;
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

}  // namespace myriad::service
