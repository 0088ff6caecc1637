// --max-memory: what the server may hold, and the reservations that keep it there (issue 31).
// Work whose memory grows with what a client asks for (a body read and parsed, a frame's targets
// and readback, a million generated lights) reserves its estimated peak first. A reservation
// waits while others' would take the process past the limit and fails with 503 + Retry-After when
// they do not finish in time, or with 413 when it could never fit. The estimates come from
// measured peaks (docs/ARCHITECTURE.md, "Host memory"); the process's resident memory
// now, read at each reservation, covers what the estimates leave out (scenes, caches), so a
// session's kept memory counts against everyone's room.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <string_view>

namespace myriad::service {

// Measured peaks per unit (2026-12-04, lavapipe, myriad-server's release build).
namespace memory_cost {
// A frame: G-buffer and lighting targets, readback and encoded copies, per pixel.
inline constexpr uint64_t kRawFrameBytesPerPixel = 112;      // measured 105-119
inline constexpr uint64_t kEncodedFrameBytesPerPixel = 56;   // PNG, JPEG: measured 49-52
inline constexpr uint64_t kFrameFixedBytes = 16ull << 20;
// What taa and ssaa add to an encoded frame (render/sub_frames.h), per pixel asked, computed (not
// measured): ssaa's sub-frame has 4x the pixels (its targets: 3 more frames' worth) and its
// readback and copy (32), the resolve's linear sum (16) and answer (4); taa's sub-frames are of
// the frame's size: a readback and copy (8), the resolve's YCoCg (12) and history (16), answer (4).
inline constexpr uint64_t kSsaaExtraBytesPerPixel = 3 * kEncodedFrameBytesPerPixel + 52;
inline constexpr uint64_t kTaaExtraBytesPerPixel = 40;
// A JSON body: the text, nlohmann's document of it and the C++ values made from it.
inline constexpr uint64_t kJsonBodyFactor = 16;
// An upload: its bytes, the part copies and the loaded scene on its way to the GPU.
inline constexpr uint64_t kUploadFactor = 4;
// A generated light: the session's copy, the GPU upload's staging and the culling structures.
inline constexpr uint64_t kGeneratedLightBytes = 512;         // measured 470
}  // namespace memory_cost

// The process's resident memory now (VmRSS), in bytes; 0 where it cannot be read.
uint64_t residentBytes();

// The default --max-memory: the cgroup's memory.max when one is set, else 3/4 of the RAM.
uint64_t defaultMemoryLimit();

class MemoryBudget {
 public:
  // 0: no limit (reservations always succeed at once).
  // What the process holds at construction (after the GPU's start-up) is its floor: a
  // reservation that does not fit beside it is refused at once.
  explicit MemoryBudget(uint64_t limitBytes) : limit_(limitBytes), floor_(residentBytes()) {}

  class Reservation {
   public:
    Reservation() = default;
    Reservation(Reservation&& other) noexcept { *this = std::move(other); }
    Reservation& operator=(Reservation&& other) noexcept;
    ~Reservation() { release(); }
    void release();
    uint64_t bytes() const { return bytes_; }

   private:
    friend class MemoryBudget;
    Reservation(MemoryBudget* budget, uint64_t bytes) : budget_(budget), bytes_(bytes) {}
    MemoryBudget* budget_ = nullptr;
    uint64_t bytes_ = 0;
  };

  // Reserves `bytes` for `what` (a phrase for the problem: "a 4096x4096 raw frame"). Waits up to
  // `wait` for room. Throws ProblemError naming the limit maxMemoryBytes: 413 when `bytes` would not
  // fit beside the process's floor, 503 + Retry-After when what others reserved or what the
  // process holds does not leave room in time.
  Reservation reserve(uint64_t bytes, std::string_view what,
                      std::chrono::milliseconds wait = std::chrono::seconds(5));

  uint64_t limit() const { return limit_; }
  uint64_t reserved() const;

 private:
  void give(uint64_t bytes);

  const uint64_t limit_;
  const uint64_t floor_;
  mutable std::mutex mutex_;
  std::condition_variable freed_;
  uint64_t reserved_ = 0;
};

}  // namespace myriad::service
