#include "service/session_frames.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <optional>
#include <stdexcept>

#include <bit>
#include <cmath>

#include <nlohmann/json.hpp>

#include "protocol/constants.h"
#include "scene/camera.h"

#include "encode/arrays.h"
#include "encode/jpeg.h"
#include "encode/png.h"
#include "encode/raw.h"
#include "service/frame_arrays.h"
#include "service/interactive_quality.h"

namespace myriad::service {
namespace {

using Milliseconds = std::chrono::duration<double, std::milli>;

std::string joined(const std::vector<std::string_view>& names) {
  std::string text;
  for (std::string_view name : names) {
    if (!text.empty()) text += ',';
    text += name;
  }
  return text;
}

}  // namespace

namespace {

// A label frame's chosen label per pixel (Frame::data holds uint32 bit patterns: object,
// semantic, material, covered).
std::vector<uint32_t> labelsOf(const render::Frame& frame, render::Target target) {
  const size_t component = target == render::Target::InstanceId   ? 0
                           : target == render::Target::SemanticId ? 1
                                                                  : 2;
  const size_t pixels = size_t(frame.width) * frame.height;
  if (frame.data.size() < pixels * 4) throw std::invalid_argument("label frame too small");
  std::vector<uint32_t> out(pixels);
  for (size_t i = 0; i < pixels; ++i) out[i] = std::bit_cast<uint32_t>(frame.data[i * 4 + component]);
  return out;
}

// A label as a colour anyone can tell from its neighbours: 0 black, others a hash of the value
// (bright, saturated), the same colour for the same value in every frame.
std::vector<uint8_t> falseColour(const std::vector<uint32_t>& labels) {
  std::vector<uint8_t> rgba(labels.size() * 4);
  for (size_t i = 0; i < labels.size(); ++i) {
    uint32_t h = labels[i];
    uint8_t* px = &rgba[i * 4];
    px[3] = 255;
    if (h == 0) {
      px[0] = px[1] = px[2] = 0;
      continue;
    }
    // A 32-bit integer hash (xorshift-multiply), then each channel in 64..255.
    h ^= h >> 16;
    h *= 0x7feb352dU;
    h ^= h >> 15;
    h *= 0x846ca68bU;
    h ^= h >> 16;
    for (int c = 0; c < 3; ++c) px[c] = uint8_t(64 + ((h >> (c * 8)) & 0xff) * 191 / 255);
  }
  return rgba;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> cameraHeaders(const scene::Camera& camera,
                                                               uint32_t width, uint32_t height) {
  const scene::Intrinsics k = scene::intrinsicsOf(camera, width, height);
  const nlohmann::json intrinsics = {{"fx", k.fx},         {"fy", k.fy},
                                     {"cx", k.cx},         {"cy", k.cy},
                                     {"width", width},     {"height", height},
                                     {"near", camera.nearPlane}, {"far", camera.farPlane}};
  const glm::mat4 pose = scene::worldFromCamera(camera);
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({pose[0][r], pose[1][r], pose[2][r], pose[3][r]});
  return {{std::string(protocol::headers::kIntrinsics), intrinsics.dump()},
          {std::string(protocol::headers::kPose), nlohmann::json{{"worldFromCamera", rows}}.dump()}};
}

EncodedFrame encodeLabels(const render::Frame& frame, const FrameRequest& request) {
  EncodedFrame out;
  const auto start = std::chrono::steady_clock::now();
  const render::Target target = request.settings.target;
  const std::vector<uint32_t> labels = labelsOf(frame, target);
  switch (request.format) {
    case ImageFormat::Raw: {
      // Little-endian uint32, as the readback holds them (every Vulkan host Myriad runs on is).
      out.body.assign(reinterpret_cast<const char*>(labels.data()), labels.size() * 4);
      out.contentType = protocol::kRawContentType;
      out.headers.emplace_back(protocol::headers::kWidth, std::to_string(frame.width));
      out.headers.emplace_back(protocol::headers::kHeight, std::to_string(frame.height));
      out.headers.emplace_back(protocol::headers::kChannels, joined(render::rawChannels(target)));
      out.headers.emplace_back(protocol::headers::kTarget, std::string(render::targetName(target)));
      out.headers.emplace_back(protocol::headers::kDtype, "uint32");
      break;
    }
    case ImageFormat::Png: {
      const std::vector<uint8_t> png =
          encode::encodePng(frame.width, frame.height, falseColour(labels), request.compression);
      out.body.assign(reinterpret_cast<const char*>(png.data()), png.size());
      out.contentType = protocol::kPngContentType;
      break;
    }
    case ImageFormat::Jpeg: {
      const std::vector<uint8_t> jpeg =
          encode::encodeJpeg(falseColour(labels), frame.width, frame.height, request.quality);
      out.body.assign(reinterpret_cast<const char*>(jpeg.data()), jpeg.size());
      out.contentType = protocol::kJpegContentType;
      break;
    }
    default:
      throw std::logic_error("encodeLabels: not an image format");
  }
  out.encodeMs = Milliseconds(std::chrono::steady_clock::now() - start).count();
  out.headers.emplace_back(protocol::headers::kServerTiming,
                           formatServerTiming(frame.passes, out.encodeMs, nullptr, frame.queueMs));
  out.headers.emplace_back(protocol::headers::kTechnique,
                           std::string(render::techniqueName(frame.technique)));
  for (auto& header : cameraHeaders(request.settings.camera, frame.width, frame.height)) {
    out.headers.push_back(std::move(header));
  }
  return out;
}

std::vector<float> inCameraSpace(std::span<const float> data, uint32_t width, uint32_t height,
                                 const scene::Camera& camera, bool points) {
  // World to camera: R^T (p - t) for points, R^T n for directions (the pose is rigid).
  const glm::mat4 cameraFromWorld = glm::inverse(scene::worldFromCamera(camera));
  std::vector<float> out(data.size(), 0.0f);
  const size_t pixels = size_t(width) * height;
  for (size_t i = 0; i < pixels && i * 4 + 3 < data.size(); ++i) {
    const glm::vec3 v(data[i * 4], data[i * 4 + 1], data[i * 4 + 2]);
    // Where nothing is, the views hold zeros: left zero, not moved to the eye.
    const bool empty = v == glm::vec3(0.0f);
    const glm::vec3 c = empty ? v : glm::vec3(cameraFromWorld * glm::vec4(v, points ? 1.0f : 0.0f));
    out[i * 4] = c.x;
    out[i * 4 + 1] = c.y;
    out[i * 4 + 2] = c.z;
  }
  return out;
}

std::vector<float> depthAsDistance(std::span<const float> data, uint32_t width, uint32_t height,
                                   const scene::Camera& camera) {
  // The depth view holds z (metres along the view axis), or `far` where there is no surface.
  // Along the ray through a pixel's centre, distance = z * |(u - cx) / fx, (v - cy) / fy, 1|.
  const scene::Intrinsics k = scene::intrinsicsOf(camera, width, height);
  if (data.size() < size_t(width) * height * 4) throw std::invalid_argument("depth frame too small");
  // 4 floats a pixel, as Frame::data (packRaw keeps the first).
  std::vector<float> out(size_t(width) * height * 4, 0.0f);
  for (uint32_t y = 0; y < height; ++y) {
    const float dy = (float(y) + 0.5f - k.cy) / k.fy;
    for (uint32_t x = 0; x < width; ++x) {
      const size_t i = size_t(y) * width + x;
      const float z = data[i * 4];
      const float dx = (float(x) + 0.5f - k.cx) / k.fx;
      out[i * 4] = z >= camera.farPlane ? z : z * std::sqrt(1.0f + dx * dx + dy * dy);
    }
  }
  return out;
}

namespace {

const char* dtypeName(encode::Dtype d) {
  switch (d) {
    case encode::Dtype::F4: return "float32";
    case encode::Dtype::U4: return "uint32";
    case encode::Dtype::U1: return "uint8";
    case encode::Dtype::F8: return "float64";
  }
  return "uint8";
}

// png16, npy, exr and npz: the frame's targets as values (frame_arrays.h).
EncodedFrame encodeArrays(const render::Frame& frame, const FrameRequest& request) {
  EncodedFrame out;
  const auto start = std::chrono::steady_clock::now();
  // png16 and npy hold one target: the first asked (a batch writes each target of one frame
  // with a request naming it alone, the frame's own target staying as rendered).
  const render::Target target = request.targets.front();
  const scene::Camera& camera = request.settings.camera;
  auto bodyOf = [&out](auto&& bytes) {
    out.body.assign(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  };
  std::vector<std::string_view> names;
  for (render::Target t : request.targets) names.push_back(render::targetName(t));
  switch (request.format) {
    case ImageFormat::Png16: {
      std::vector<uint16_t> values;
      encode::PngText text;
      if (target == render::Target::Depth) {
        const double scale = depthScale(camera);
        values = depthAsUint16(frame, request, scale);
        char number[32];
        std::snprintf(number, sizeof number, "%.9g", scale);
        out.headers.emplace_back(protocol::headers::kDepthScale, number);
        text.emplace_back("DepthScale", std::string(number) + " m per unit; 0: no surface");
      } else {
        values = labelsAsUint16(frame, request, target);
      }
      bodyOf(encode::encodePngGrey16(frame.width, frame.height, values, request.compression, text));
      out.contentType = protocol::kPngContentType;
      out.headers.emplace_back(protocol::headers::kTarget, std::string(render::targetName(target)));
      out.headers.emplace_back(protocol::headers::kDtype, "uint16");
      break;
    }
    case ImageFormat::Npy: {
      const encode::Array array = targetArray(frame, request, target);
      out.body = encode::writeNpy(array);
      out.contentType = protocol::kNpyContentType;
      out.headers.emplace_back(protocol::headers::kTarget, std::string(render::targetName(target)));
      out.headers.emplace_back(protocol::headers::kDtype, dtypeName(array.dtype));
      break;
    }
    case ImageFormat::Exr: {
      std::vector<encode::Array> arrays;
      for (render::Target t : request.targets) arrays.push_back(targetArray(frame, request, t));
      const std::string version = request.version ? std::to_string(*request.version) : "";
      out.body = encode::writeExr(arrays, request.precision,
                                  exrMetadata(camera, frame.width, frame.height,
                                              request.settings.time, version));
      out.contentType = protocol::kExrContentType;
      out.headers.emplace_back(protocol::headers::kTargets, joined(names));
      break;
    }
    case ImageFormat::Npz: {
      // Each target written once, straight into the archive (a 1280x720 frame of final, depth
      // and ids is 10 MB: no array of its own, no copy of it).
      const encode::Array cameraArrays[] = {intrinsicsArray(camera, frame.width, frame.height),
                                            poseArray(camera)};
      std::vector<encode::NpzWriter::Member> members;
      for (render::Target t : request.targets) members.push_back(targetLayout(frame, request, t));
      for (const encode::Array& a : cameraArrays) members.push_back({a.name, a.dtype, a.shape});
      encode::NpzWriter npz(members);
      for (size_t i = 0; i < request.targets.size(); ++i) {
        writeTarget(frame, request, request.targets[i], npz.data(i));
      }
      for (size_t i = 0; i < std::size(cameraArrays); ++i) {
        const std::vector<uint8_t>& bytes = cameraArrays[i].bytes;
        std::copy(bytes.begin(), bytes.end(), npz.data(request.targets.size() + i).begin());
      }
      out.body = std::move(npz).finish();
      out.contentType = protocol::kZipContentType;
      out.headers.emplace_back(protocol::headers::kTargets, joined(names));
      break;
    }
    default:
      throw std::logic_error("encodeArrays: not an array format");
  }
  out.encodeMs = Milliseconds(std::chrono::steady_clock::now() - start).count();
  out.headers.emplace_back(protocol::headers::kWidth, std::to_string(frame.width));
  out.headers.emplace_back(protocol::headers::kHeight, std::to_string(frame.height));
  auto asks = [&](render::Target t) {
    return std::find(request.targets.begin(), request.targets.end(), t) != request.targets.end();
  };
  if (request.format != ImageFormat::Png16 && asks(render::Target::Depth)) {
    out.headers.emplace_back(protocol::headers::kDepth, request.depthDistance ? "distance" : "z");
  }
  if (asks(render::Target::Position) || asks(render::Target::Normal)) {
    out.headers.emplace_back(protocol::headers::kSpace, request.cameraSpace ? "camera" : "world");
  }
  const bool culled = frame.technique != render::Technique::Volumes;
  out.headers.emplace_back(protocol::headers::kServerTiming,
                           formatServerTiming(frame.passes, out.encodeMs,
                                              culled ? &frame.culling : nullptr, frame.queueMs));
  out.headers.emplace_back(protocol::headers::kTechnique,
                           std::string(render::techniqueName(frame.technique)));
  for (auto& header : cameraHeaders(camera, frame.width, frame.height)) {
    out.headers.push_back(std::move(header));
  }
  return out;
}

}  // namespace

EncodedFrame encodeFrame(const render::Frame& frame, const FrameRequest& request) {
  switch (request.format) {
    case ImageFormat::Png16:
    case ImageFormat::Npy:
    case ImageFormat::Exr:
    case ImageFormat::Npz: return encodeArrays(frame, request);
    default: break;
  }
  if (render::isLabel(request.settings.target)) return encodeLabels(frame, request);
  EncodedFrame out;
  const auto start = std::chrono::steady_clock::now();
  switch (request.format) {
    case ImageFormat::Png: {
      std::vector<uint8_t> png =
          encode::encodePng(frame.width, frame.height, frame.pixels(), request.compression);
      out.body.assign(reinterpret_cast<const char*>(png.data()), png.size());
      out.contentType = protocol::kPngContentType;
      break;
    }
    case ImageFormat::Jpeg: {
      std::vector<uint8_t> jpeg;
      if (frame.yuv420) {
        // Converted and subsampled on the GPU (render::FrameSettings::yuv420).
        const render::Yuv420Layout l = render::yuv420Layout(frame.width, frame.height);
        const std::span<const uint8_t> planes = frame.pixels();
        if (planes.size() < l.bytes()) throw std::invalid_argument("YCbCr frame too small");
        jpeg = encode::encodeJpegYuv420(planes.subspan(0, l.yBytes()),
                                        planes.subspan(l.yBytes(), l.chromaBytes()),
                                        planes.subspan(l.yBytes() + l.chromaBytes(), l.chromaBytes()),
                                        frame.width, frame.height, l.yStride, l.chromaStride,
                                        request.quality);
      } else {
        jpeg = encode::encodeJpeg(frame.pixels(), frame.width, frame.height, request.quality);
      }
      out.body.assign(reinterpret_cast<const char*>(jpeg.data()), jpeg.size());
      out.contentType = protocol::kJpegContentType;
      break;
    }
    case ImageFormat::Raw: {
      const render::Target target = request.settings.target;
      std::vector<uint8_t> raw =
          request.depthDistance
              ? encode::packRaw(frame.width, frame.height,
                                depthAsDistance(frame.data, frame.width, frame.height,
                                                request.settings.camera),
                                1)
          : request.cameraSpace
              ? encode::packRaw(frame.width, frame.height,
                                inCameraSpace(frame.data, frame.width, frame.height,
                                              request.settings.camera,
                                              target == render::Target::Position),
                                3)
              : encode::packRaw(frame.width, frame.height, frame.data,
                                render::rawChannels(target).size());
      out.body.assign(reinterpret_cast<const char*>(raw.data()), raw.size());
      out.contentType = protocol::kRawContentType;
      out.headers.emplace_back(protocol::headers::kWidth, std::to_string(frame.width));
      out.headers.emplace_back(protocol::headers::kHeight, std::to_string(frame.height));
      out.headers.emplace_back(protocol::headers::kChannels, joined(render::rawChannels(target)));
      out.headers.emplace_back(protocol::headers::kTarget, std::string(render::targetName(target)));
      out.headers.emplace_back(protocol::headers::kDtype, "float32");
      if (target == render::Target::Position || target == render::Target::Normal) {
        out.headers.emplace_back(protocol::headers::kSpace, request.cameraSpace ? "camera" : "world");
      }
      if (target == render::Target::Depth) {
        out.headers.emplace_back(protocol::headers::kDepth, request.depthDistance ? "distance" : "z");
      }
      break;
    }
    default:
      throw std::logic_error("encodeFrame: an array format");
  }
  out.encodeMs = Milliseconds(std::chrono::steady_clock::now() - start).count();

  const bool culled = frame.technique != render::Technique::Volumes;
  out.headers.emplace_back(
      protocol::headers::kServerTiming, formatServerTiming(frame.passes, out.encodeMs, culled ? &frame.culling : nullptr,
                                                          frame.queueMs));
  out.headers.emplace_back(protocol::headers::kTechnique, std::string(render::techniqueName(frame.technique)));
  for (auto& header : cameraHeaders(request.settings.camera, frame.width, frame.height)) {
    out.headers.push_back(std::move(header));
  }
  if (frame.culling.overflowed()) {
    std::fprintf(stderr, "myriad-server: WARNING: light lists overflowed, lights are missing from "
                         "this frame: %s\n", describeCulling(frame.culling).c_str());
  }
  return out;
}

namespace {

// The median of what `value` picks from each of `items` that has it (>= 0); nullopt for none.
template <class T, class Pick>
std::optional<double> medianOf(const std::deque<T>& items, Pick value) {
  std::vector<double> values;
  values.reserve(items.size());
  for (const T& item : items) {
    const double v = value(item);
    if (v >= 0.0) values.push_back(v);
  }
  if (values.empty()) return std::nullopt;
  const size_t middle = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(middle), values.end());
  return values[middle];
}

}  // namespace

void FrameStatsBook::recordSend(const SessionPtr& session, double sendMs, double intervalMs) {
  std::lock_guard lock(mutex_);
  auto it = entries_.find(session->id);
  if (it == entries_.end()) return;
  std::deque<std::pair<double, double>>& sends = it->second.sends;
  sends.emplace_back(sendMs, intervalMs);
  if (sends.size() > kPipelineWindow) sends.pop_front();
}

void FrameStatsBook::record(const SessionPtr& session, const render::Frame& frame,
                            render::Target target, double encodeMs, double waitMs) {
  protocol::FrameStats stats;
  for (const render::PassTiming& pass : frame.passes) {
    stats.passes.push_back({pass.name, pass.milliseconds});
    stats.totalGpuMs += pass.milliseconds;
    if (pass.name == "readback") stats.readbackMs += pass.milliseconds;
  }
  stats.encodeMs = encodeMs;
  stats.width = frame.width;
  stats.height = frame.height;
  stats.technique = std::string(render::techniqueName(frame.technique));
  stats.target = std::string(render::targetName(target));

  const render::CullingReport& c = frame.culling;
  protocol::CullingStats culling{c.tilesOverflowed, c.tileLightsDropped, c.clusterLightsDropped,
                                 c.listEntries,     c.activeClusters,    c.mostLightsInList};
  protocol::GpuMemory memory{c.lightBytes, c.listBytes, frame.sceneBytes};
  // The lights that had a shadow map, by id: the slots as the session holds them now (an edit
  // between the frame and here may have moved a light; a slot past the end is left out).
  protocol::LightShadowStats lightShadows{{}, frame.lightShadows.requested, frame.lightShadows.dropped};
  if (!frame.lightShadows.lights.empty()) {
    std::lock_guard sessionLock(session->mutex);
    const std::vector<uint64_t>& ids = session->scene.lightIds();
    for (uint32_t slot : frame.lightShadows.lights) {
      if (slot < ids.size()) lightShadows.lights.push_back(ids[slot]);
    }
  }

  std::lock_guard lock(mutex_);
  for (auto it = entries_.begin(); it != entries_.end();) {
    it = it->second.session.expired() ? entries_.erase(it) : std::next(it);
  }
  Entry& entry = entries_[session->id];
  entry.session = session;
  entry.frame = std::move(stats);
  entry.culling = culling;
  entry.lightShadows = std::move(lightShadows);
  entry.gpuMemory = memory;
  ++entry.frames;
  if (entry.timesWidth != frame.width || entry.timesHeight != frame.height) {
    // Another size: its medians start again (a stream's 4K frames are not mixed with 1080p).
    entry.times.clear();
    entry.sends.clear();
    entry.timesWidth = frame.width;
    entry.timesHeight = frame.height;
  }
  const render::FrameTimes& t = frame.times;
  entry.times.push_back({frame.queueMs, t.recordMs, t.gpuMs, t.gpuIdleMs, t.fenceWaitMs, t.copyMs,
                         t.submitToAnswerMs, waitMs, encodeMs});
  if (entry.times.size() > kPipelineWindow) entry.times.pop_front();
}

protocol::Stats FrameStatsBook::statsOf(const Session& session, uint64_t lightCount,
                                        bool animated) const {
  protocol::Stats stats;
  stats.lightCount = lightCount;
  stats.lightsAnimated = animated;
  std::lock_guard lock(mutex_);
  auto it = entries_.find(session.id);
  // A session id is never reused, so an entry under this id belongs to this session.
  if (it != entries_.end()) {
    stats.frame = it->second.frame;
    stats.culling = it->second.culling;
    stats.lightShadows = it->second.lightShadows;
    stats.gpuMemory = it->second.gpuMemory;
    stats.frames = it->second.frames;
    const std::deque<Times>& times = it->second.times;
    if (!times.empty()) {
      protocol::PipelineStats p;
      p.frames = times.size();
      p.queueMs = medianOf(times, [](const Times& t) { return t.queueMs; }).value_or(0.0);
      p.recordMs = medianOf(times, [](const Times& t) { return t.recordMs; }).value_or(0.0);
      p.gpuMs = medianOf(times, [](const Times& t) { return t.gpuMs; });
      p.gpuIdleMs = medianOf(times, [](const Times& t) { return t.gpuIdleMs; });
      p.fenceWaitMs = medianOf(times, [](const Times& t) { return t.fenceWaitMs; }).value_or(0.0);
      p.copyMs = medianOf(times, [](const Times& t) { return t.copyMs; }).value_or(0.0);
      p.answerMs = medianOf(times, [](const Times& t) { return t.answerMs; }).value_or(0.0);
      p.waitMs = medianOf(times, [](const Times& t) { return t.waitMs; });
      p.encodeMs = medianOf(times, [](const Times& t) { return t.encodeMs; }).value_or(0.0);
      const std::deque<std::pair<double, double>>& sends = it->second.sends;
      p.parts = sends.size();
      p.sendMs = medianOf(sends, [](const auto& s) { return s.first; });
      p.intervalMs = medianOf(sends, [](const auto& s) { return s.second; });
      stats.pipeline = p;
    }
  }
  return stats;
}

DeliveredFrame deliverFrame(render::RenderQueue& renderThread, Metrics& metrics, render::SceneId id,
                            const FrameRequest& request, render::FrameSource source) {
  const auto start = std::chrono::steady_clock::now();
  std::future<render::Frame> pending = renderThread.submit(id, request.settings, source);
  DeliveredFrame delivered;
  delivered.frame = pending.get();
  delivered.encoded = encodeFrame(delivered.frame, request);
  metrics.observeFrame(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  metrics.observeQueueWait(delivered.frame.queueMs / 1000.0);
  return delivered;
}

PendingSessionFrame submitSessionFrame(const SessionFrameContext& context, const SessionPtr& session,
                                       const FrameRequest& request, render::FrameSource source) {
  PendingSessionFrame pending;
  pending.rendered = request;
  render::SceneId sceneId = 0;
  {
    std::lock_guard lock(session->mutex);
    if (session->closed) throw ProblemError(notFoundDetail("Session " + session->id + " is gone."));
    pending.rendered.settings =
        session->scene.frameSettings(request.settings, request.time, Clock::now());
    pending.rendered.settings.sampleIndex = request.sampleIndex;
    if (request.camera.any()) {
      try {
        request.camera.applyTo(pending.rendered.settings.camera);
      } catch (const FrameQueryError& e) {
        throw ProblemError(invalidParameter(e.parameter(), e.what()));
      }
    }
    pending.rendered.settings.borrowPixels = context.borrowPixels;
    // A JPEG with subsampled chroma: converted to YCbCr 4:2:0 on the GPU, read back at 1.5
    // bytes a pixel, encoded from the planes (the same picture: gpu CTest "YCbCr frames").
    pending.rendered.settings.yuv420 = context.yuvJpeg && request.format == ImageFormat::Jpeg &&
                                       !request.video && encode::jpegSubsamplesChroma(request.quality);
    if (request.interactive) {
      // A stream's interactive frame (interactive_quality.h): the costly passes that change the
      // picture least while it moves are left out; the still after it has them.
      pending.rendered.settings.antialias = render::Antialias::None;
      pending.rendered.settings.shadows.sun = false;
      // Coarser meshes where the difference stays under half a pixel.
      pending.rendered.settings.geometryErrorPixels = InteractiveQuality::kGeometryErrorPixels;
    }
    sceneId = static_cast<render::SceneId>(session->sceneId);
    pending.version = session->version;
    pending.rendered.version = session->version;
  }
  pending.submitted = Clock::now();
  pending.frame =
      context.renderThread.submit(sceneId, pending.rendered.settings, source, pending.drop);
  return pending;
}

SessionFrame collectSessionFrame(const SessionFrameContext& context, const SessionPtr& session,
                                 PendingSessionFrame& pending, const FrameEncoder* encoder) {
  DeliveredFrame delivered;
  const Clock::time_point waitStart = Clock::now();
  try {
    delivered.frame = pending.frame.get();
  } catch (const std::exception&) {
    // A session deleted while its frame waited takes its scene with it: that is a 404, not a
    // renderer failure.
    std::lock_guard lock(session->mutex);
    if (session->closed) throw ProblemError(notFoundDetail("Session " + session->id + " is gone."));
    throw;
  }
  const double waitMs = std::chrono::duration<double, std::milli>(Clock::now() - waitStart).count();
  delivered.encoded = encoder ? (*encoder)(delivered.frame)
                              : encodeFrame(delivered.frame, pending.rendered);
  // Encoded: borrowed pixels go back to the renderer now, not when the caller is done.
  delivered.frame.giveBackReadback();
  context.metrics.observeFrame(
      std::chrono::duration<double>(Clock::now() - pending.submitted).count());
  context.metrics.observeQueueWait(delivered.frame.queueMs / 1000.0);
  context.stats.record(session, delivered.frame, pending.rendered.settings.target,
                       delivered.encoded.encodeMs, waitMs);
  SessionFrame result;
  result.encoded = std::move(delivered.encoded);
  {
    char time[32];
    std::snprintf(time, sizeof time, "%.17g", pending.rendered.settings.time);
    result.encoded.headers.emplace_back(protocol::headers::kFrameTime, time);
    result.encoded.headers.emplace_back(protocol::headers::kFrameVersion,
                                        std::to_string(pending.version));
  }
  result.version = pending.version;
  result.time = pending.rendered.settings.time;
  return result;
}

SessionFrame renderSessionFrame(const SessionFrameContext& context, const SessionPtr& session,
                                const FrameRequest& request, render::FrameSource source) {
  PendingSessionFrame pending = submitSessionFrame(context, session, request, source);
  return collectSessionFrame(context, session, pending);
}

}  // namespace myriad::service
