#include "service/frame_arrays.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "scene/camera.h"
#include "service/problem.h"
#include "service/session_frames.h"

namespace myriad::service {
namespace {

// Which of the label pass's four uint32s a label target is (render::Target::InstanceId).
size_t labelComponent(render::Target target) {
  return target == render::Target::InstanceId   ? 0
         : target == render::Target::SemanticId ? 1
                                                : 2;
}

// EXR's usual channel names for the raw channels: R,G,B for colours, X,Y,Z for vectors, U,V,
// Z for depth, Y for any other single value, id for the labels; the raw names otherwise.
std::vector<std::string> exrChannels(render::Target target) {
  if (render::isLabel(target)) return {"id"};
  const std::vector<std::string_view> raw = render::rawChannels(target);
  if (target == render::Target::Depth) return {"Z"};
  if (raw.size() == 1) return {"Y"};
  std::vector<std::string> names;
  for (std::string_view c : raw) {
    if (c.size() == 1 && std::string_view("rgbxyzuv").find(c[0]) != std::string_view::npos) {
      names.push_back(std::string(1, char(c[0] - 'a' + 'A')));
    } else {
      names.push_back(std::string(c));
    }
  }
  return names;
}

}  // namespace

std::span<const float> valuesOf(const render::Frame& frame, const FrameRequest& request,
                                render::Target target) {
  const render::Target main = request.settings.target;
  if (target == main || (render::isLabel(target) && render::isLabel(main))) return frame.data;
  if (render::isLabel(target)) return frame.labels;
  for (const render::Frame::TargetValues& extra : frame.extras) {
    if (extra.target == target) return extra.data;
  }
  throw std::logic_error("the frame did not read back " + std::string(render::targetName(target)));
}

encode::NpzWriter::Member targetLayout(const render::Frame& frame, const FrameRequest& request,
                                       render::Target target) {
  const size_t w = frame.width, h = frame.height;
  encode::NpzWriter::Member m;
  m.name = std::string(render::targetName(target));
  if (target == render::Target::Final && !request.settings.raw) {
    m.dtype = encode::Dtype::U1;  // the 8-bit sRGB picture
    m.shape = {h, w, 3};
  } else if (render::isLabel(target)) {
    m.dtype = encode::Dtype::U4;
    m.shape = {h, w};
  } else {
    const size_t channels = render::rawChannels(target).size();
    m.dtype = encode::Dtype::F4;
    m.shape = channels == 1 ? std::vector<size_t>{h, w} : std::vector<size_t>{h, w, channels};
  }
  return m;
}

void writeTarget(const render::Frame& frame, const FrameRequest& request, render::Target target,
                 std::span<uint8_t> out) {
  const uint32_t w = frame.width, h = frame.height;
  const size_t pixels = size_t(w) * h;
  if (target == render::Target::Final && !request.settings.raw) {
    // RGBA read back; alpha dropped. Four bytes stored a pixel, the fourth overwritten by the
    // next pixel's red: one store instead of three.
    const std::span<const uint8_t> rgba = frame.pixels();
    if (rgba.size() < pixels * 4) throw std::invalid_argument("final frame too small");
    if (out.size() != pixels * 3) throw std::logic_error("writeTarget: final's size");
    for (size_t i = 0; i + 1 < pixels; ++i) std::memcpy(&out[i * 3], &rgba[i * 4], 4);
    if (pixels > 0) std::memcpy(&out[(pixels - 1) * 3], &rgba[(pixels - 1) * 4], 3);
    return;
  }
  const std::span<const float> values = valuesOf(frame, request, target);
  if (values.size() < pixels * 4) throw std::invalid_argument("target values too small");
  if (render::isLabel(target)) {
    if (out.size() != pixels * 4) throw std::logic_error("writeTarget: a label's size");
    const size_t c = labelComponent(target);
    // The uint32 ids travel as the floats' bits: copied as they are (little-endian, as raw).
    for (size_t i = 0; i < pixels; ++i) std::memcpy(&out[i * 4], &values[i * 4 + c], 4);
    return;
  }
  // Floats, with the session's conversions.
  std::vector<float> converted;
  std::span<const float> source = values;
  const scene::Camera& camera = request.settings.camera;
  if (target == render::Target::Depth && request.depthDistance) {
    converted = depthAsDistance(values, w, h, camera);
    source = converted;
  } else if (request.cameraSpace &&
             (target == render::Target::Position || target == render::Target::Normal)) {
    converted = inCameraSpace(values, w, h, camera, target == render::Target::Position);
    source = converted;
  }
  const size_t channels = render::rawChannels(target).size();
  if (out.size() != pixels * channels * 4) throw std::logic_error("writeTarget: a view's size");
  const float* in = source.data();
  auto copy = [&]<size_t C>() {
    for (size_t i = 0; i < pixels; ++i) std::memcpy(&out[i * C * 4], in + i * 4, C * 4);
  };
  switch (channels) {
    case 1: copy.template operator()<1>(); break;
    case 2: copy.template operator()<2>(); break;
    case 3: copy.template operator()<3>(); break;
    default: copy.template operator()<4>(); break;
  }
}

encode::Array targetArray(const render::Frame& frame, const FrameRequest& request,
                          render::Target target) {
  encode::NpzWriter::Member m = targetLayout(frame, request, target);
  encode::Array array;
  array.name = std::move(m.name);
  array.dtype = m.dtype;
  array.shape = std::move(m.shape);
  array.channels = exrChannels(target);
  array.bytes.resize(array.elements() * encode::dtypeBytes(array.dtype));
  writeTarget(frame, request, target, array.bytes);
  return array;
}

encode::Array intrinsicsArray(const scene::Camera& camera, uint32_t width, uint32_t height) {
  const scene::Intrinsics k = scene::intrinsicsOf(camera, width, height);
  const double values[9] = {k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0};
  encode::Array array{"K", encode::Dtype::F8, {3, 3}, {}, {}};
  array.bytes.resize(sizeof values);
  std::memcpy(array.bytes.data(), values, sizeof values);
  return array;
}

encode::Array poseArray(const scene::Camera& camera) {
  const glm::mat4 pose = scene::worldFromCamera(camera);
  double values[16];
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) values[r * 4 + c] = pose[c][r];  // glm is column-major
  }
  encode::Array array{"world_from_camera", encode::Dtype::F8, {4, 4}, {}, {}};
  array.bytes.resize(sizeof values);
  std::memcpy(array.bytes.data(), values, sizeof values);
  return array;
}

encode::ExrMetadata exrMetadata(const scene::Camera& camera, uint32_t width, uint32_t height,
                                double time, const std::string& version) {
  encode::ExrMetadata m;
  const encode::Array k = intrinsicsArray(camera, width, height);
  std::memcpy(m.K.data(), k.bytes.data(), sizeof(double) * 9);
  const encode::Array pose = poseArray(camera);
  std::memcpy(m.worldFromCamera.data(), pose.bytes.data(), sizeof(double) * 16);
  m.nearPlane = camera.nearPlane;
  m.farPlane = camera.farPlane;
  m.time = time;
  m.version = version;
  m.software = "myriad";
  return m;
}

double depthScale(const scene::Camera& camera) {
  return camera.farPlane <= 65.535f ? 0.001 : double(camera.farPlane) / 65535.0;
}

std::vector<uint16_t> depthAsUint16(const render::Frame& frame, const FrameRequest& request,
                                    double scale) {
  const std::span<const float> values = valuesOf(frame, request, render::Target::Depth);
  const size_t pixels = size_t(frame.width) * frame.height;
  if (values.size() < pixels * 4) throw std::invalid_argument("depth frame too small");
  const float far = request.settings.camera.farPlane;
  std::vector<uint16_t> out(pixels);
  for (size_t i = 0; i < pixels; ++i) {
    const float z = values[i * 4];
    // No surface (the view holds `far` there): 0, as depth images mark a missing value.
    if (!(z < far)) {
      out[i] = 0;
      continue;
    }
    const double units = std::round(double(z) / scale);
    out[i] = uint16_t(std::clamp(units, 1.0, 65535.0));
  }
  return out;
}

std::vector<uint16_t> labelsAsUint16(const render::Frame& frame, const FrameRequest& request,
                                     render::Target target) {
  const std::span<const float> values = valuesOf(frame, request, target);
  const size_t pixels = size_t(frame.width) * frame.height;
  if (values.size() < pixels * 4) throw std::invalid_argument("label frame too small");
  const size_t c = labelComponent(target);
  std::vector<uint16_t> out(pixels);
  for (size_t i = 0; i < pixels; ++i) {
    const uint32_t id = std::bit_cast<uint32_t>(values[i * 4 + c]);
    if (id > 0xffff) {
      Problem problem = invalidParameter(
          "format", std::string(render::targetName(target)) + " " + std::to_string(id) +
                        " at pixel (" + std::to_string(i % frame.width) + ", " +
                        std::to_string(i / frame.width) +
                        ") does not fit a 16-bit PNG (0 to 65535); ask for format=npy, exr or "
                        "raw, which hold uint32 ids.");
      problem.status = 422;
      throw ProblemError(std::move(problem));
    }
    out[i] = uint16_t(id);
  }
  return out;
}

}  // namespace myriad::service
