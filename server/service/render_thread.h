// The one thread that owns the Vulkan device and the renderer. HTTP workers never touch Vulkan:
// they submit a frame here and wait on a future; the pixels come back as plain memory, and the
// worker encodes them. One owner means no locking inside the renderer and one queue submission
// at a time, which is what a single VkQueue wants anyway.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <future>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "gpu/context.h"
#include "gpu/device_info.h"
#include "render/frame.h"
#include "scene/scene.h"

namespace myriad::service {

// submit() found the queue full (or the thread stopping); the client should retry later.
class RenderQueueFullError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class RenderThread {
 public:
  // Starts the thread, which creates the Vulkan context and the renderer and uploads `scene`
  // (which need not outlive the constructor). Returns once frames can be submitted; rethrows
  // whatever start-up threw on the thread (gpu::NoDeviceError among others).
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

  // Queues a frame; the future holds the frame or what the renderer threw. Throws
  // RenderQueueFullError when maxQueuedFrames frames already wait behind the one rendering, or
  // after stop().
  std::future<render::Frame> submit(const render::FrameSettings& settings);

  // Renders the frames already queued, then releases the renderer and the device on the render
  // thread and joins it. Idempotent.
  void stop();

 private:
  struct Job {
    render::FrameSettings settings;
    std::promise<render::Frame> result;
  };

  void run(const gpu::ContextOptions& options, const scene::Scene& scene,
           std::promise<void>& ready);

  gpu::DeviceInfo device_;
  uint32_t maxDimension_ = 0;
  const uint32_t maxQueuedFrames_;
  // Points into the context the render thread owns; valid from start-up until stop().
  const std::atomic<uint32_t>* validationCounter_ = nullptr;

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Job> jobs_;  // waiting, oldest first
  bool rendering_ = false;
  bool stopping_ = false;

  std::thread thread_;
};

}  // namespace myriad::service
