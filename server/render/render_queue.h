// The renderer as the service sees it: a queue of scene edits and frames, answered through
// futures. No Vulkan and no gpu/ header here, so HTTP code cannot reach the device by accident;
// render::RenderThread (render/render_thread.h) is the implementation main() starts.
#pragma once

#include <atomic>
#include <cstdint>
#include <future>
#include <memory>
#include <stdexcept>
#include <vector>

#include "render/device_summary.h"
#include "render/frame.h"
#include "scene/environment_map.h"
#include "scene/scene.h"

namespace myriad::render {

// Who waits for a frame. A request's frame counts against maxQueuedFrames (a waiting request
// holds an HTTP worker); a stream's does not: an open stream has at most one frame queued and
// --max-streams bounds the streams, while refusing its frame only made the stream retry 50 ms
// later, which gave concurrent streams uneven rates and left the GPU idle.
enum class FrameSource { Request, Stream };

// A frame its submitter gave up on before it started (submit's `drop`).
class FrameDroppedError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// submit() found the queue full (or the queue stopping); the client should retry later.
class RenderQueueFullError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The tasks of one scene (its edits and frames) run in the order submitted, so a frame submitted
// after an edit sees the edit; different scenes take turns (round-robin), and a frame too long
// for one GPU submission is split so that other scenes' frames run between its parts
// (render/render_thread.h). Exceptions a task throws (an unknown scene: std::invalid_argument;
// out of device memory: a gpu error) reach its future; the queue keeps serving. Every method is
// safe from any thread.
class RenderQueue {
 public:
  virtual ~RenderQueue() = default;

  // Fixed at start-up.
  virtual const DeviceSummary& device() const = 0;
  virtual uint32_t maxDimension() const = 0;
  virtual uint32_t maxQueuedFrames() const = 0;

  // Validation messages so far (0 without validation); valid until stop().
  virtual uint32_t validationMessages() const = 0;

  // The scene the queue started with (GET /v1/frame's built-in scene). Never destroyed.
  virtual SceneId defaultScene() const = 0;

  // Scene edits: queued like frames (never refused for a full queue), run in order. Each throws
  // RenderQueueFullError only after stop(). See render::Renderer for what each does and throws.
  virtual std::future<SceneId> createScene(std::shared_ptr<const scene::Scene> scene) = 0;
  virtual std::future<void> replaceScene(SceneId id, std::shared_ptr<const scene::Scene> scene) = 0;
  // Also drops the scene's frames that have not finished (waiting, or split in progress): their
  // futures get std::invalid_argument.
  virtual std::future<void> destroyScene(SceneId id) = 0;
  virtual std::future<void> updateLights(SceneId id, LightUpdate update) = 0;
  virtual std::future<void> updateMaterials(SceneId id, std::vector<MaterialWrite> writes) = 0;
  // New world transforms for some instances (an object moved): nothing else is uploaded.
  virtual std::future<void> updateInstances(SceneId id, InstanceUpdate update) = 0;
  virtual std::future<void> setEnvironmentImage(
      SceneId id, std::shared_ptr<const scene::EnvironmentImage> image) = 0;

  // Queues a frame of scene `id`; the future holds the frame or what the renderer threw. The
  // settings carry the sun, ambient and background (FrameSettings::takeLightingFrom). Throws
  // RenderQueueFullError when maxQueuedFrames() frames already wait behind the one rendering, or
  // after stop(). Only frames of FrameSource::Request count against maxQueuedFrames().
  // `drop`, when given, lets the submitter give the frame up: set before the frame starts, the
  // frame is not rendered, and set while a split frame renders, it stops at its next part; its
  // future gets FrameDroppedError.
  virtual std::future<Frame> submit(SceneId id, const FrameSettings& settings, FrameSource source,
                                    std::shared_ptr<const std::atomic<bool>> drop) = 0;
  std::future<Frame> submit(SceneId id, const FrameSettings& settings, FrameSource source) {
    return submit(id, settings, source, nullptr);
  }
  std::future<Frame> submit(SceneId id, const FrameSettings& settings) {
    return submit(id, settings, FrameSource::Request, nullptr);
  }
  // The same for the default scene.
  std::future<Frame> submit(const FrameSettings& settings) {
    return submit(defaultScene(), settings);
  }

  // Frees a stream's taa history (FrameSettings::historyKey; Renderer::releaseHistory), queued
  // behind scene `id`'s tasks (the stream's frames). Never refused; a queue without histories
  // has nothing to free.
  virtual void releaseHistory(SceneId id, uint64_t key) {
    (void)id;
    (void)key;
  }

  // GPU memory the renderer holds (every scene, targets, lists), as of the last task finished.
  virtual uint64_t gpuMemoryBytes() const = 0;

  // Runs what is already queued, then releases the renderer and the device. Idempotent.
  virtual void stop() = 0;
};

}  // namespace myriad::render
