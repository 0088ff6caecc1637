#include "encode/encode_pool.h"

#include <algorithm>
#include <exception>
#include <utility>

namespace myriad::encode {
namespace {

// A tenant nobody asked a turn for in this long is forgotten (its virtual time with it: by then
// the pool's clock has passed it, or its debt is old).
constexpr std::chrono::seconds kTenantIdle{10};
// The pixels one encoder thread is given: 960x540, about 5 ms at VP9 speed 8 on one core of the
// H200 host (a quarter of its 19-22 ms at 1080p).
constexpr uint64_t kPixelsPerThread = 960 * 540;
constexpr uint32_t kMaxEncoderThreads = 8;

}  // namespace

uint32_t encoderThreadsFor(VideoCodec codec, uint32_t width, uint32_t height,
                           uint32_t poolThreads, uint32_t liveEncoders) {
  poolThreads = std::max(1u, poolThreads);
  const uint64_t pixels = uint64_t(width) * height;
  const auto byArea =
      static_cast<uint32_t>(std::max<uint64_t>(1, (pixels + kPixelsPerThread / 2) / kPixelsPerThread));
  const uint32_t share = std::max(1u, poolThreads / std::max(1u, liveEncoders + 1));
  (void)codec;  // every codec alike: see the header
  const uint32_t quarter = std::max(1u, poolThreads / 4);
  return std::clamp(std::min({byArea, share, quarter}), 1u, kMaxEncoderThreads);
}

EncodePool::EncodePool(uint32_t threads)
    : threads_(threads != 0 ? threads : std::max(1u, std::thread::hardware_concurrency())) {
  workers_.reserve(threads_);
  for (uint32_t i = 0; i < threads_; ++i) workers_.emplace_back([this] { work(); });
}

EncodePool::~EncodePool() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  for (std::thread& worker : workers_) worker.join();
}

void EncodePool::run(std::string_view tenant, uint32_t cores, const std::function<void()>& job) {
  Job entry;
  entry.work = &job;
  entry.cores = std::clamp(cores, 1u, threads_);
  entry.queuedAt = Clock::now();
  std::future<void> done = entry.done.get_future();
  {
    std::lock_guard lock(mutex_);
    auto it = tenants_.find(tenant);
    if (it == tenants_.end()) it = tenants_.emplace(std::string(tenant), Tenant{}).first;
    Tenant& t = it->second;
    // Back from idle: at the pool's clock, with no credit saved.
    if (t.waiting.empty() && t.running == 0) t.vtime = std::max(t.vtime, vclock_);
    t.waiting.push_back(&entry);
    t.lastUsed = entry.queuedAt;
    ++queued_;
  }
  wake_.notify_all();
  done.get();
}

EncodePool::Tenant* EncodePool::pick() {
  Tenant* best = nullptr;
  for (auto& [name, tenant] : tenants_) {
    if (tenant.waiting.empty()) continue;
    if (best == nullptr || tenant.vtime < best->vtime) best = &tenant;
  }
  if (best == nullptr) return nullptr;
  // The fair choice waits for its cores rather than let smaller jobs pass it for ever.
  const uint32_t cores = best->waiting.front()->cores;
  if (coresInUse_ != 0 && coresInUse_ + cores > threads_) return nullptr;
  return best;
}

void EncodePool::dropIdle(Clock::time_point now) {
  std::erase_if(tenants_, [&](const auto& item) {
    const Tenant& t = item.second;
    return t.waiting.empty() && t.running == 0 && now - t.lastUsed > kTenantIdle;
  });
}

void EncodePool::work() {
  std::unique_lock lock(mutex_);
  for (;;) {
    Tenant* tenant = nullptr;
    wake_.wait(lock, [&] {
      tenant = pick();
      return tenant != nullptr || (stopping_ && queued_ == 0);
    });
    if (tenant == nullptr) return;  // stopping, nothing left
    Job* job = tenant->waiting.front();
    tenant->waiting.pop_front();
    --queued_;
    ++running_;
    ++tenant->running;
    coresInUse_ += job->cores;
    const double charged = tenant->estimate * job->cores;
    tenant->vtime += charged;
    vclock_ = std::max(vclock_, tenant->vtime - charged);
    const Clock::time_point start = Clock::now();
    waitSecondsSum_ += std::chrono::duration<double>(start - job->queuedAt).count();
    lock.unlock();

    std::exception_ptr error;
    try {
      (*job->work)();
    } catch (...) {
      error = std::current_exception();
    }
    const Clock::time_point end = Clock::now();
    const double seconds = std::chrono::duration<double>(end - start).count();

    lock.lock();
    // `tenant` is still there: a tenant with a running job is never dropped.
    tenant->vtime += seconds * job->cores - charged;
    tenant->estimate = 0.75 * tenant->estimate + 0.25 * seconds;
    tenant->lastUsed = end;
    ++tenant->jobs;
    --tenant->running;
    --running_;
    coresInUse_ -= job->cores;
    ++jobs_;
    secondsSum_ += seconds;
    const auto bucket = std::lower_bound(kBuckets.begin(), kBuckets.end(), seconds);
    if (bucket != kBuckets.end()) ++buckets_[static_cast<size_t>(bucket - kBuckets.begin())];
    dropIdle(end);
    // The caller may destroy the job the moment it is told: nothing of it is used after this.
    if (error) {
      job->done.set_exception(error);
    } else {
      job->done.set_value();
    }
    wake_.notify_all();  // cores came free: a waiting job that needed them may fit now
  }
}

EncodePool::Stats EncodePool::stats() const {
  std::lock_guard lock(mutex_);
  Stats s;
  s.threads = threads_;
  s.queued = queued_;
  s.running = running_;
  s.tenants = static_cast<uint32_t>(tenants_.size());
  s.jobs = jobs_;
  s.buckets = buckets_;
  s.secondsSum = secondsSum_;
  s.waitSecondsSum = waitSecondsSum_;
  return s;
}

uint64_t EncodePool::jobsOf(std::string_view tenant) const {
  std::lock_guard lock(mutex_);
  auto it = tenants_.find(tenant);
  return it == tenants_.end() ? 0 : it->second.jobs;
}

}  // namespace myriad::encode
