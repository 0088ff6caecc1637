#include "render/render_thread.h"

#include <malloc.h>

#include <chrono>
#include <memory>
#include <type_traits>
#include <utility>

namespace myriad::render {

namespace {

// What the service may know about the device: gpu::DeviceInfo without the limits only the
// renderer uses.
DeviceSummary summarize(const gpu::DeviceInfo& d) {
  DeviceSummary s;
  s.name = d.name;
  s.type = d.type;
  s.driverName = d.driverName;
  s.driverInfo = d.driverInfo;
  s.apiVersion = d.apiVersion;
  s.vendorId = d.vendorId;
  s.deviceId = d.deviceId;
  s.index = d.index;
  s.isCpu = d.isCpu;
  s.maxImageDimension2D = d.maxImageDimension2D;
  s.maxStorageBufferRange = d.maxStorageBufferRange;
  s.maxComputeSharedMemorySize = d.maxComputeSharedMemorySize;
  s.subgroupSize = d.subgroupSize;
  s.timestampPeriodNs = d.timestampPeriodNs;
  s.timestampsSupported = d.timestampsSupported;
  return s;
}

}  // namespace

RenderThread::RenderThread(const gpu::ContextOptions& options, const scene::Scene& scene,
                           uint32_t maxQueuedFrames)
    : maxQueuedFrames_(maxQueuedFrames) {
  std::promise<void> ready;
  std::future<void> started = ready.get_future();
  thread_ = std::thread([this, &options, &scene, &ready] { run(options, scene, ready); });
  try {
    started.get();
  } catch (...) {
    // run() returns right after reporting a start-up failure.
    thread_.join();
    throw;
  }
}

RenderThread::~RenderThread() {
  stop();
}

uint32_t RenderThread::validationMessages() const {
  return validationCounter_ != nullptr ? validationCounter_->load() : 0;
}

void RenderThread::enqueue(Task task) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) throw RenderQueueFullError("the server is shutting down");
    if (task.frame) {
      // The frame being rendered is not waiting; while none is, a new frame starts at once.
      size_t ahead = framesWaiting_ + (renderingFrame_ ? 1 : 0);
      if (ahead > maxQueuedFrames_) {
        throw RenderQueueFullError(std::to_string(framesWaiting_) +
                                   " frames are already waiting for the renderer (the limit is " +
                                   std::to_string(maxQueuedFrames_) + ")");
      }
      ++framesWaiting_;
    }
    tasks_.push_back(std::move(task));
  }
  wake_.notify_one();
}

// Wraps `work(renderer) -> T` in a task whose promise gets the result or the exception.
// std::function needs a copyable callable, hence the shared promise.
template <typename T, typename Work>
std::future<T> RenderThread::enqueueWork(bool frame, Work work) {
  auto promise = std::make_shared<std::promise<T>>();
  std::future<T> result = promise->get_future();
  // gpuMemoryBytes() is refreshed before the promise is kept, so a caller whose future is ready
  // (a session deleted, say) already reads the memory it freed.
  enqueue(Task{frame, [this, promise, work = std::move(work)](Renderer& renderer) mutable {
                 try {
                   if constexpr (std::is_void_v<T>) {
                     work(renderer);
                     gpuMemoryBytes_ = renderer.gpuMemoryBytes();
                     promise->set_value();
                   } else {
                     T value = work(renderer);
                     gpuMemoryBytes_ = renderer.gpuMemoryBytes();
                     promise->set_value(std::move(value));
                   }
                 } catch (...) {
                   gpuMemoryBytes_ = renderer.gpuMemoryBytes();
                   promise->set_exception(std::current_exception());
                 }
               }});
  return result;
}

std::future<SceneId> RenderThread::createScene(std::shared_ptr<const scene::Scene> scene) {
  return enqueueWork<SceneId>(false, [scene = std::move(scene)](Renderer& r) {
    return r.createScene(*scene);
  });
}

std::future<void> RenderThread::replaceScene(SceneId id,
                                             std::shared_ptr<const scene::Scene> scene) {
  return enqueueWork<void>(false, [id, scene = std::move(scene)](Renderer& r) {
    r.replaceScene(id, *scene);
  });
}

std::future<void> RenderThread::destroyScene(SceneId id) {
  return enqueueWork<void>(false, [id](Renderer& r) { r.destroyScene(id); });
}

std::future<void> RenderThread::updateLights(SceneId id, LightUpdate update) {
  return enqueueWork<void>(false, [id, update = std::move(update)](Renderer& r) {
    r.updateLights(id, update);
  });
}

std::future<void> RenderThread::updateMaterials(SceneId id,
                                                std::vector<MaterialWrite> writes) {
  return enqueueWork<void>(false, [id, writes = std::move(writes)](Renderer& r) {
    r.updateMaterials(id, writes);
  });
}

std::future<void> RenderThread::setEnvironmentImage(
    SceneId id, std::shared_ptr<const scene::EnvironmentImage> image) {
  return enqueueWork<void>(false, [id, image = std::move(image)](Renderer& r) {
    r.setEnvironmentImage(id, image);
  });
}

std::future<Frame> RenderThread::submit(SceneId id,
                                                const FrameSettings& settings) {
  const auto queued = std::chrono::steady_clock::now();
  return enqueueWork<Frame>(true, [id, settings, queued](Renderer& r) {
    const double waited =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - queued).count();
    Frame frame = r.render(id, settings);
    frame.queueMs = waited;
    return frame;
  });
}

void RenderThread::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
  validationCounter_ = nullptr;
}

void RenderThread::run(const gpu::ContextOptions& options, const scene::Scene& scene,
                       std::promise<void>& ready) {
  std::unique_ptr<gpu::Context> context;
  std::unique_ptr<Renderer> renderer;
  try {
    context = gpu::createContext(options);
    renderer = std::make_unique<Renderer>(*context);
    defaultScene_ = renderer->createScene(scene);
    device_ = summarize(context->info);
    maxDimension_ = renderer->maxDimension();
    validationCounter_ = &context->validationMessages;
    gpuMemoryBytes_ = renderer->gpuMemoryBytes();
  } catch (...) {
    // Destroy in dependency order here, on this thread, before the constructor rethrows.
    renderer.reset();
    context.reset();
    ready.set_exception(std::current_exception());
    return;
  }
  // After this the constructor returns and `options`, `scene` and `ready` are gone.
  ready.set_value();

  bool trimmed = true;  // nothing rendered yet: nothing to give back
  for (;;) {
    Task task;
    {
      std::unique_lock lock(mutex_);
      // Idle for kIdleTrim: the frame targets (sized to the last output: 1 GB at 4096 x 4096 on a
      // CPU device, where device memory is host memory) go back, and so does the heap. A stream
      // or a sequence of frames never leaves the queue idle that long, so it keeps its targets.
      if (!trimmed && !wake_.wait_for(lock, kIdleTrim,
                                      [this] { return stopping_ || !tasks_.empty(); })) {
        lock.unlock();
        renderer->releaseFrameMemory();
        gpuMemoryBytes_ = renderer->gpuMemoryBytes();
        malloc_trim(0);
        trimmed = true;
        continue;
      }
      wake_.wait(lock, [this] { return stopping_ || !tasks_.empty(); });
      // Stopping still runs what was queued: those requests are in flight and get answers.
      if (tasks_.empty()) break;
      task = std::move(tasks_.front());
      tasks_.pop_front();
      if (task.frame) {
        --framesWaiting_;
        renderingFrame_ = true;
      }
    }
    task.run(*renderer);  // fulfils its promise, exception or not
    trimmed = false;
    std::lock_guard lock(mutex_);
    renderingFrame_ = false;
  }

  renderer.reset();
  context.reset();
}

}  // namespace myriad::render
