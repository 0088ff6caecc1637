#include "render/render_thread.h"

#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "gpu/resources.h"

namespace myriad::render {

namespace {

// How long the render thread waits on a frame's fence before it looks at the queue again, while
// frames are in flight and nothing is queued.
constexpr uint64_t kAnswerPollNs = 500'000;

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
                           uint32_t maxQueuedFrames, uint32_t framesInFlight,
                           bool overlapFrames, GpuTimestamps timestamps, GBufferPath gbuffer,
                           const Tuning& tuning)
    : maxQueuedFrames_(maxQueuedFrames),
      framesInFlight_(std::clamp(framesInFlight, 1u, Renderer::kMaxFramesInFlight)),
      overlapFrames_(overlapFrames),
      timestamps_(timestamps),
      gbuffer_(gbuffer),
      tuning_(tuning) {
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
    if (task.counted) {
      // Besides the frame rendering, at most maxQueuedFrames wait; while none renders, a new
      // frame starts at once.
      if (framesUnfinished_ > maxQueuedFrames_) {
        throw RenderQueueFullError(std::to_string(framesUnfinished_ - 1) +
                                   " frames are already waiting for the renderer (the limit is " +
                                   std::to_string(maxQueuedFrames_) + ")");
      }
      ++framesUnfinished_;
    }
    SceneQueue& queue = queues_[task.scene];
    // A queue with tasks is in turns_, or its head is running and finish() puts it back.
    if (queue.tasks.empty()) turns_.push_back(task.scene);
    if (task.destroy) ++queue.destroys;
    queue.tasks.push_back(std::move(task));
  }
  wake_.notify_one();
}

// Wraps `work(renderer) -> T` in a task of `scene`'s queue whose promise gets the result or the
// exception. std::function needs a copyable callable, hence the shared promise.
template <typename T, typename Work>
std::future<T> RenderThread::enqueueWork(SceneId scene, Work work, bool destroy) {
  auto promise = std::make_shared<std::promise<T>>();
  std::future<T> result = promise->get_future();
  // gpuMemoryBytes() is refreshed before the promise is kept, so a caller whose future is ready
  // (a session deleted, say) already reads the memory it freed.
  Task task;
  task.scene = scene;
  task.destroy = destroy;
  task.run = [this, promise, work = std::move(work)](Renderer& renderer) mutable {
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
    return Step::Done;
  };
  enqueue(std::move(task));
  return result;
}

std::future<SceneId> RenderThread::createScene(std::shared_ptr<const scene::Scene> scene) {
  return enqueueWork<SceneId>(0, [scene = std::move(scene)](Renderer& r) {
    return r.createScene(*scene);
  });
}

std::future<void> RenderThread::replaceScene(SceneId id,
                                             std::shared_ptr<const scene::Scene> scene) {
  return enqueueWork<void>(id, [id, scene = std::move(scene)](Renderer& r) {
    r.replaceScene(id, *scene);
  });
}

std::future<void> RenderThread::destroyScene(SceneId id) {
  // The scene's frames still waiting (or split) are dropped when their turn comes.
  return enqueueWork<void>(id, [id](Renderer& r) { r.destroyScene(id); }, true);
}

void RenderThread::releaseHistory(SceneId id, uint64_t key) {
  try {
    enqueueWork<void>(id, [key](Renderer& r) { r.releaseHistory(key); });
  } catch (const RenderQueueFullError&) {
    // Stopping: the renderer and its histories go with it.
  }
}

std::future<void> RenderThread::updateLights(SceneId id, LightUpdate update) {
  return enqueueWork<void>(id, [id, update = std::move(update)](Renderer& r) {
    r.updateLights(id, update);
  });
}

std::future<void> RenderThread::updateInstances(SceneId id, InstanceUpdate update) {
  return enqueueWork<void>(id, [id, update = std::move(update)](Renderer& r) {
    r.updateInstances(id, update);
  });
}

std::future<void> RenderThread::updateMaterials(SceneId id,
                                                std::vector<MaterialWrite> writes) {
  return enqueueWork<void>(id, [id, writes = std::move(writes)](Renderer& r) {
    r.updateMaterials(id, writes);
  });
}

std::future<void> RenderThread::setEnvironmentImage(
    SceneId id, std::shared_ptr<const scene::EnvironmentImage> image) {
  return enqueueWork<void>(id, [id, image = std::move(image)](Renderer& r) {
    r.setEnvironmentImage(id, image);
  });
}

std::future<Frame> RenderThread::submit(SceneId id, const FrameSettings& settings,
                                        FrameSource source,
                                        std::shared_ptr<const std::atomic<bool>> drop) {
  // Shared between the task's turns (a split frame keeps its progress here) and its slot in flight.
  auto pending = std::make_shared<PendingFrame>();
  const bool counted = source == FrameSource::Request;
  std::future<Frame> result = pending->promise.get_future();
  Task task;
  task.scene = id;
  task.frame = true;
  task.counted = counted;
  task.run = [this, pending, id, settings, counted, drop = std::move(drop)](Renderer& r) {
    try {
      if (drop && drop->load()) {
        throw FrameDroppedError(pending->split ? "the frame was given up while it rendered"
                                               : "the frame was given up before it started");
      }
      if (!pending->split) {
        // Not started yet: a whole frame, or the first submission of a split one.
        const bool split = r.shouldSplit(id, settings);
        if (split && r.splitBusy()) return Step::Blocked;
        if (split) {
          finishAll(r);  // the parts are waited for: answer the frames in flight first
          // Its work begins now, on an idle GPU.
          pending->waitedMs = pending->msSinceQueued(std::chrono::steady_clock::now());
          r.setFrameBudgetMilliseconds(frameBudgetMs_.load());
          pending->split = r.beginSplit(id, settings);
          return Step::More;
        }
        // A whole frame: into a free slot (the oldest in flight finished first when none is).
        if (!r.canBegin()) finishOldest(r);
        InFlight frame;
        frame.pending = pending;
        frame.counted = counted;
        frame.begun = std::chrono::steady_clock::now();
        frame.behind = !inFlight_.empty();
        // Until its GPU work begins: now, or when the frames ahead of it are done (finishOldest).
        pending->waitedMs = pending->msSinceQueued(frame.begun);
        frame.slot = r.beginFrame(id, settings);
        frame.submitted = std::chrono::steady_clock::now();
        inFlight_.push_back(std::move(frame));
        if (framesInFlight_ == 1) finishOldest(r);  // the serial path
        return Step::InFlight;
      }
      finishAll(r);  // whole frames submitted between the parts
      std::optional<Frame> frame = r.continueSplit(*pending->split);
      if (!frame) return Step::More;
      pending->split.reset();
      frame->queueMs = pending->waitedMs;
      gpuMemoryBytes_ = r.gpuMemoryBytes();
      pending->promise.set_value(std::move(*frame));
    } catch (...) {
      pending->split.reset();
      gpuMemoryBytes_ = r.gpuMemoryBytes();
      pending->promise.set_exception(std::current_exception());
    }
    return Step::Done;
  };
  task.cancel = [pending, id] {
    pending->split.reset();
    pending->promise.set_exception(std::make_exception_ptr(std::invalid_argument(
        "scene " + std::to_string(id) + " was destroyed before its frame was rendered")));
  };
  enqueue(std::move(task));
  return result;
}

void RenderThread::finishOldest(Renderer& renderer) {
  InFlight frame = std::move(inFlight_.front());
  inFlight_.pop_front();
  // A frame submitted behind others began on the GPU when the one before it was seen done (the
  // render thread looks between its turns, and waits for it before any split part or edit).
  if (frame.behind && lastFrameDone_ > frame.begun) {
    frame.pending->waitedMs = frame.pending->msSinceQueued(lastFrameDone_);
  }
  try {
    renderer.waitFrame(frame.slot, UINT64_MAX);
    lastFrameDone_ = std::chrono::steady_clock::now();
    Frame result = renderer.finishFrame(frame.slot);
    result.queueMs = frame.pending->waitedMs;
    result.times.submitToAnswerMs = std::chrono::duration<double, std::milli>(
                                        std::chrono::steady_clock::now() - frame.submitted)
                                        .count();
    gpuMemoryBytes_ = renderer.gpuMemoryBytes();
    frame.pending->promise.set_value(std::move(result));
  } catch (...) {
    gpuMemoryBytes_ = renderer.gpuMemoryBytes();
    frame.pending->promise.set_exception(std::current_exception());
  }
  if (frame.counted) {
    std::lock_guard lock(mutex_);
    --framesUnfinished_;
  }
}

void RenderThread::finishAll(Renderer& renderer) {
  while (!inFlight_.empty()) finishOldest(renderer);
}

RenderThread::Task* RenderThread::pick() {
  while (!turns_.empty()) {
    const SceneId id = turns_.front();
    turns_.pop_front();
    SceneQueue& queue = queues_.at(id);
    // A scene being destroyed: its frames ahead of the destroyScene are for nobody.
    while (queue.destroys > 0 && !queue.tasks.empty() && queue.tasks.front().frame) {
      queue.tasks.front().cancel();
      if (queue.tasks.front().counted) --framesUnfinished_;
      queue.tasks.pop_front();
    }
    if (queue.tasks.empty()) {
      queues_.erase(id);
      continue;
    }
    return &queue.tasks.front();
  }
  return nullptr;
}

void RenderThread::finish(Task& task, Step step) {
  const SceneId id = task.scene;
  SceneQueue& queue = queues_.at(id);
  if (step == Step::Done || step == Step::InFlight) {
    // A frame in flight stays counted until finishOldest() answers it.
    if (task.counted && step == Step::Done) --framesUnfinished_;
    if (task.destroy) --queue.destroys;
    queue.tasks.pop_front();  // `task`
  }
  if (queue.tasks.empty()) {
    queues_.erase(id);
  } else {
    turns_.push_back(id);  // the back of the round
  }
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
    std::fprintf(stderr, "myriad-server: readback memory: %s\n",
                 gpu::describeMemoryUse(*context, gpu::MemoryUse::Readback).c_str());
    renderer = std::make_unique<Renderer>(*context, tuning_);
    renderer->setFramesInFlight(framesInFlight_);
    renderer->setOverlap(overlapFrames_);
    renderer->setGpuTimestamps(timestamps_);
    renderer->setGBufferPath(gbuffer_);
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
    Task* task = nullptr;
    bool answer = false;
    // Frames the GPU has finished are answered at once, whatever is queued.
    while (!inFlight_.empty() && renderer->frameDone(inFlight_.front().slot)) {
      finishOldest(*renderer);
    }
    {
      std::unique_lock lock(mutex_);
      // Nothing queued but frames in flight: answer the oldest (its GPU work is under way).
      answer = !inFlight_.empty() && turns_.empty();
    }
    if (answer) {
      // Wait for it in short steps: a frame queued meanwhile is submitted at once (into the slot
      // the previous answer freed), so the GPU gets it before this one is copied out.
      if (renderer->waitFrame(inFlight_.front().slot, kAnswerPollNs)) finishOldest(*renderer);
      continue;
    }
    {
      std::unique_lock lock(mutex_);
      // Idle for kIdleTrim: the frame targets (sized to the last output: 1 GB at 4096 x 4096 on a
      // CPU device, where device memory is host memory) go back, and so does the heap. A stream
      // or a sequence of frames never leaves the queue idle that long, so it keeps its targets.
      if (!trimmed && !wake_.wait_for(lock, kIdleTrim,
                                      [this] { return stopping_ || !turns_.empty(); })) {
        lock.unlock();
        renderer->releaseFrameMemory(kIdleKeepBytes);
        gpuMemoryBytes_ = renderer->gpuMemoryBytes();
        malloc_trim(0);
        trimmed = true;
        continue;
      }
      wake_.wait(lock, [this] { return stopping_ || !turns_.empty(); });
      // Stopping still runs what was queued: those requests are in flight and get answers.
      if (turns_.empty()) break;
      task = pick();
      if (task == nullptr) continue;  // only dropped frames
    }
    // Outside the lock: other threads only append to the queues, which keeps `task` valid.
    // An edit waits for the frames in flight to be answered: a scene's tasks finish in order.
    if (!task->frame) finishAll(*renderer);
    const Step step = task->run(*renderer);  // fulfils its promise when Done, exception or not
    trimmed = false;
    std::lock_guard lock(mutex_);
    finish(*task, step);
  }

  finishAll(*renderer);  // none: the loop ends with nothing queued or in flight
  renderer.reset();
  context.reset();
}

}  // namespace myriad::render
