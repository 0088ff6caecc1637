// Reading frames back: the pool of readback buffers lent out with frames, a finished frame's
// pixels and report, and the frame memory released when idle and counted for /metrics.
#include <algorithm>
#include <chrono>

#include "render/extra_targets.h"
#include "render/renderer_state.h"

namespace myriad::render {

namespace {

// Readback buffers lent out with frames (FrameSettings::borrowPixels), at most: the frames in
// flight plus those being encoded (one per stream or waiting request). Past it a frame is copied
// out on the render thread as before.
constexpr size_t kMaxPooledReadbacks = 16;

}  // namespace

void Renderer::releaseFrameMemory(uint64_t keepBytes) {
  State& s = *state_;
  // Slots not in flight: nothing on the GPU uses their targets; the target descriptor set points
  // at freed views until ensureTargets() makes new ones and writes it again. Frames in flight,
  // and an unfinished split frame, keep their own.
  s.quiesce();
  // The slot of the last whole frame may stay (keepBytes): its targets, sun map and one readback
  // buffer of its size, when together they hold at most keepBytes.
  State::FrameSlot* kept = nullptr;
  VkDeviceSize keptReadback = 0;
  if (keepBytes > 0) {
    for (auto& slot : s.slots) {
      if (slot->lastUsed > 0 && (!kept || slot->lastUsed > kept->lastUsed)) kept = slot.get();
    }
    if (kept && kept->targets) {
      keptReadback = State::readbackBytes(kept->settings);
      const uint64_t bytes = kept->targets->bytesAllocated() +
                             kept->shadows->gpuMemoryBytes() + keptReadback;
      if (bytes > keepBytes) kept = nullptr;
    } else {
      kept = nullptr;
    }
  }
  for (auto& slot : s.slots) {
    if (slot->inFlight || slot.get() == kept) continue;
    slot->targets.reset();
    slot->shadows->release();
  }
  if (!s.splitBusy) {
    s.split.targets.reset();
    s.split.shadows->release();
  }
  s.trimReadbacks(kept ? keptReadback : 0);
  // The streams' taa histories: a stream that renders again starts a new one.
  s.temporal->releaseAll();
}

Renderer::State::PooledReadback* Renderer::State::acquireReadback(VkDeviceSize bytes) {
  PooledReadback* free = nullptr;
  size_t count = 0;
  // The sizes of the frames the slots' targets were last made for: a stream's still and its
  // interactive frames alternate, each in its slot, and each keeps its buffer.
  auto slotsUse = [&](VkDeviceSize size) {
    return std::any_of(slots.begin(), slots.end(), [&](const auto& slot) {
      return slot->targets && readbackBytes(slot->settings) == size;
    });
  };
  for (auto it = readbacks.begin(); it != readbacks.end();) {
    PooledReadback& r = **it;
    const bool held = r.held.load(std::memory_order_acquire);
    if (!held && r.bytes != bytes && !slotsUse(r.bytes)) {
      it = readbacks.erase(it);  // another size: nothing uses it (frames in flight hold theirs)
      continue;
    }
    if (!held && r.bytes == bytes && !free) free = &r;
    ++count;
    ++it;
  }
  if (!free && count >= kMaxPooledReadbacks) {
    // Full: a free buffer of another size goes to make room.
    auto other = std::find_if(readbacks.begin(), readbacks.end(), [&](const auto& r) {
      return r->bytes != bytes && !r->held.load(std::memory_order_acquire);
    });
    if (other != readbacks.end()) {
      readbacks.erase(other);
      --count;
    }
  }
  if (!free && count < kMaxPooledReadbacks) {
    auto made = std::make_unique<PooledReadback>();
    made->arena = std::make_unique<gpu::Arena>(context, bytes);
    made->buffer = made->arena->createBuffer(bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                             gpu::MemoryUse::Readback);
    made->bytes = bytes;
    free = made.get();
    readbacks.push_back(std::move(made));
  }
  if (free) free->held.store(true, std::memory_order_relaxed);
  return free;
}

void Renderer::State::trimReadbacks(VkDeviceSize keep) {
  bool keeping = keep > 0;
  std::erase_if(readbacks, [&](const std::unique_ptr<PooledReadback>& r) {
    if (r->held.load(std::memory_order_acquire)) return false;
    if (keeping && r->bytes == keep) {
      keeping = false;
      return false;
    }
    return true;
  });
}

void Renderer::releaseHistory(uint64_t key) { state_->temporal->release(key); }
size_t Renderer::historyCount() const { return state_->temporal->count(); }
uint64_t Renderer::historyBytes() const { return state_->temporal->bytes(); }

uint64_t Renderer::gpuMemoryBytes() const {
  const State& s = *state_;
  uint64_t total = s.uniformArena.bytesAllocated();
  for (const auto& [id, scene] : s.scenes) total += scene->bytes();
  for (const auto& [id, env] : s.environments) total += env->bytes();
  total += s.environmentPasses->gpuMemoryBytes();
  total += s.temporal->bytes();
  for (const State::FrameSlot* slot : const_cast<State&>(s).allSlots()) {
    if (slot->targets) total += slot->targets->bytesAllocated();
    total += slot->shadows->gpuMemoryBytes();
    if (slot->visibility) total += slot->visibility->arena.bytesAllocated();
  }
  for (const auto& technique : s.techniques) total += technique->gpuMemoryBytes();
  total += s.stochastic.gpuMemoryBytes();
  for (const auto& technique : s.splitTechniques) {
    if (technique) total += technique->gpuMemoryBytes();
  }
  for (const auto& readback : s.readbacks) total += readback->arena->bytesAllocated();
  return total;
}

Frame Renderer::State::metaOf(const SceneBuffers& scene, const SceneEnvironment* environment,
                              const FrameSettings& settings) {
  Frame meta;
  meta.technique = settings.technique;
  meta.lightCount = scene.lightCount;
  meta.sceneBytes = scene.bytes() + (environment ? environment->bytes() : 0);
  meta.culling.lightBytes = scene.lights.size + scene.lightOrigins.size;
  return meta;
}

// After the last submission: the pixels and what the frame reports (passes: the last
// submission's; a split frame sums its own).
Frame Renderer::State::readFrame(const FrameSlot& slot, const Frame& meta,
                                 const FrameSettings& settings, LightingTechnique& technique) {
  const FrameTargets& t = *slot.targets;
  Frame frame = meta;
  frame.width = t.extent.width;
  frame.height = t.extent.height;
  frame.times = slot.times;
  frame.yuv420 = settings.yuv420Readback();
  const size_t bytes = frame.yuv420 ? yuv420Layout(t.extent.width, t.extent.height).bytes()
                                    : size_t(t.extent.width) * t.extent.height * 4;
  const auto copyStart = std::chrono::steady_clock::now();
  if (settings.raw) {
    const auto* values = static_cast<const float*>(t.readback.mapped);
    frame.data.assign(values, values + size_t(t.extent.width) * t.extent.height * 4);
  } else if (PooledReadback* pooled = slot.readback) {
    // Lent out: the encoder reads the mapped memory; dropping the frame gives it back.
    frame.borrowed = std::make_shared<const BorrowedPixels>(
        static_cast<const uint8_t*>(pooled->buffer.mapped), bytes,
        [pooled] { pooled->held.store(false, std::memory_order_release); });
  } else {
    const auto* pixels = static_cast<const uint8_t*>(t.readback.mapped);
    frame.rgba.assign(pixels, pixels + bytes);
  }
  // Extras stay in the lent buffer after the pixels (readbackBytes), or are copied out.
  readExtraTargets(t, settings, frame,
                   slot.readback != nullptr && !settings.raw
                       ? static_cast<const uint8_t*>(slot.readback->buffer.mapped) +
                             extrasOffset(settings)
                       : nullptr);
  frame.times.copyMs = Milliseconds(std::chrono::steady_clock::now() - copyStart).count();
  for (auto& [name, ms] : slot.timer->results()) frame.passes.push_back({name, ms});
  if (slot.timer->lastTick() > slot.timer->firstTick()) {
    frame.times.gpuMs = double(slot.timer->lastTick() - slot.timer->firstTick()) *
                        context.info.timestampPeriodNs * 1e-6;
  }
  technique.report(frame.culling, technique.counters() ? slot.counters.mapped : nullptr);
  frame.lightShadows = {slot.lightShadows.lights, slot.lightShadows.requested,
                        slot.lightShadows.dropped};
  frame.sunMap = slot.sunMap;
  return frame;
}

}  // namespace myriad::render
