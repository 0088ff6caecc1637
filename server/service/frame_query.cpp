#include "service/frame_query.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <optional>

#include <glm/glm.hpp>

#include "service/problem.h"

namespace myriad::service {
namespace {

// Beyond this, squared distances in the camera maths overflow float precision into nonsense.
constexpr float kMaxCoordinate = 1.0e6f;
// Closer than this, the view direction normalises to noise.
constexpr float kMinViewDistance = 1.0e-4f;
// Eleven days: beyond this, float animation phases lose the precision to move lights smoothly.
constexpr float kMaxAnimationSeconds = 1.0e6f;

const std::string* single(const std::multimap<std::string, std::string>& params,
                          std::string_view name) {
  auto [first, last] = params.equal_range(std::string(name));
  if (first == last) return nullptr;
  return &first->second;
}

// The whole text as a float, or nothing ("1.5x", "", " 1" and "nan" are rejected; "inf" parses
// and is rejected by callers through isfinite).
std::optional<float> parseFloat(std::string_view text) {
  float value = 0.0f;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end || !std::isfinite(value)) return std::nullopt;
  return value;
}

uint32_t parseSize(std::string_view name, const std::string& text, uint32_t maxResolution) {
  const std::string expectation =
      std::string(name) + " must be a whole number of pixels from 1 to " +
      std::to_string(maxResolution) + ", got " + quoteClientText(text) + ".";
  uint64_t value = 0;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ptr != end || (ec != std::errc() && ec != std::errc::result_out_of_range)) {
    throw FrameQueryError(std::string(name), expectation);
  }
  if (value == 0) throw FrameQueryError(std::string(name), expectation);
  if (ec == std::errc::result_out_of_range || value > maxResolution) {
    throw FrameQueryError(std::string(name), std::string(name) + " " + quoteClientText(text) +
                                                 " exceeds this server's maximum resolution of " +
                                                 std::to_string(maxResolution) + " pixels.");
  }
  return static_cast<uint32_t>(value);
}

glm::vec3 parseVector(std::string_view name, const std::string& text) {
  const std::string expectation =
      std::string(name) + " must be three finite numbers separated by commas (x,y,z), got " +
      quoteClientText(text) + ".";
  glm::vec3 v(0.0f);
  std::string_view rest = text;
  for (int i = 0; i < 3; ++i) {
    size_t comma = rest.find(',');
    if ((i < 2) != (comma != std::string_view::npos))
      throw FrameQueryError(std::string(name), expectation);
    std::optional<float> component = parseFloat(rest.substr(0, comma));
    if (!component) throw FrameQueryError(std::string(name), expectation);
    if (std::abs(*component) > kMaxCoordinate) {
      throw FrameQueryError(std::string(name),
                            std::string(name) + " " + quoteClientText(text) +
                                " has a coordinate beyond +-1e6, outside any scene.");
    }
    v[i] = *component;
    rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
  }
  return v;
}

// Keeps the camera's up vector usable: looking straight up or down along the default up would
// make the view matrix degenerate.
glm::vec3 upFor(const glm::vec3& eye, const glm::vec3& target, const glm::vec3& up) {
  glm::vec3 forward = glm::normalize(target - eye);
  if (glm::length(glm::cross(forward, glm::normalize(up))) > 1.0e-3f) return up;
  return std::abs(forward.z) < 0.9f ? glm::vec3(0.0f, 0.0f, -1.0f) : glm::vec3(1.0f, 0.0f, 0.0f);
}

}  // namespace

namespace {

// Unknown or repeated parameters, before any value is looked at.
template <size_t N>
void checkNames(const QueryParams& params, const std::array<std::string_view, N>& allowed,
                std::string_view route) {
  for (auto it = params.begin(); it != params.end(); it = params.upper_bound(it->first)) {
    bool known = false;
    for (std::string_view name : allowed) known = known || name == it->first;
    if (!known) {
      std::string names;
      for (std::string_view name : allowed) names += (names.empty() ? "" : ", ") + std::string(name);
      throw FrameQueryError(it->first,
                            "Unknown query parameter " + quoteClientText(it->first) + "; " +
                                std::string(route) + " takes " + names + ".",
                            true);
    }
    if (params.count(it->first) > 1) {
      throw FrameQueryError(it->first, it->first + " is given more than once.");
    }
  }
}

// A whole number in [min, max], or FrameQueryError naming the range.
uint32_t parseBoundedInteger(std::string_view name, const std::string& text, uint32_t min,
                             uint32_t max, std::string_view what) {
  uint64_t value = 0;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ptr != end || ec != std::errc() || value < min || value > max) {
    throw FrameQueryError(std::string(name), std::string(name) + " must be " + std::string(what) +
                                                 ", a whole number from " + std::to_string(min) +
                                                 " to " + std::to_string(max) + ", got " +
                                                 quoteClientText(text) + ".");
  }
  return static_cast<uint32_t>(value);
}

std::string joinedTargets(const std::vector<render::Target>& targets) {
  std::string text;
  for (render::Target t : targets) text += (text.empty() ? "" : ",") + std::string(render::targetName(t));
  return text;
}

std::string targetNames() {
  std::string names;
  for (std::string_view name : render::kTargetNames) {
    names += (names.empty() ? "" : ", ") + std::string(name);
  }
  return names;
}

// ?target=: one name, or (session frames, `list`) a comma-separated list of up to
// protocol::query::kMaxFrameTargets names, each once.
std::vector<render::Target> parseTargets(const std::string& text, bool list) {
  std::vector<render::Target> targets;
  std::string_view rest = text;
  const size_t most = protocol::query::kMaxFrameTargets;
  if (list) {
    // Counted before anything is parsed, so a long list costs nothing.
    const size_t count = size_t(std::count(text.begin(), text.end(), ',')) + 1;
    if (count > most) {
      throw FrameQueryError("target", "target lists " + std::to_string(count) +
                                          " targets; a frame reads back at most " +
                                          std::to_string(most) + " (maxFrameTargets).");
    }
  }
  while (true) {
    const size_t comma = list ? rest.find(',') : std::string_view::npos;
    const std::string name(rest.substr(0, comma));
    std::optional<render::Target> target = render::parseTarget(name);
    if (!target) {
      const std::string what = comma == std::string_view::npos && targets.empty()
                                   ? "target " + quoteClientText(text)
                                   : "target " + quoteClientText(name) + " in " +
                                         quoteClientText(text);
      throw FrameQueryError("target", what + " is not one of: " + targetNames() + ".");
    }
    if (std::find(targets.begin(), targets.end(), *target) != targets.end()) {
      throw FrameQueryError("target", "target " + quoteClientText(text) + " names " + name +
                                          " more than once.");
    }
    targets.push_back(*target);
    if (comma == std::string_view::npos) break;
    rest = rest.substr(comma + 1);
  }
  return targets;
}

// Which of several targets the frame renders as its own (the rest are read back after it):
// final when asked (its 8-bit picture is the frame's own output), else the first that is not a
// label (the views pass then leaves the G-buffer as the extras read it), else the first.
render::Target mainTarget(const std::vector<render::Target>& targets) {
  for (render::Target t : targets) {
    if (t == render::Target::Final) return t;
  }
  for (render::Target t : targets) {
    if (!render::isLabel(t)) return t;
  }
  return targets.front();
}

// The parameters every frame route shares: target, width, height, format, quality, compression,
// precision. Formats outside `formats` are rejected; `request.format` holds the route's default
// on entry. `targetList`: ?target= may list several (session frames).
template <size_t N>
void parseOutput(const QueryParams& params, uint32_t maxRes,
                 const std::array<ImageFormat, N>& formats, FrameRequest& request,
                 bool targetList = false) {
  render::FrameSettings& settings = request.settings;
  if (const std::string* text = single(params, "target")) {
    request.targets = parseTargets(*text, targetList);
  }
  settings.target = mainTarget(request.targets);
  settings.alsoRead.clear();
  for (render::Target t : request.targets) {
    if (t != settings.target) settings.alsoRead.push_back(t);
  }

  // The default size is 720p, shrunk with its aspect ratio kept when the server's maximum is
  // smaller, so a bare request always succeeds.
  settings.width = std::min<uint32_t>(1280, maxRes);
  settings.height = std::max<uint32_t>(1, settings.width * 9 / 16);
  if (const std::string* text = single(params, "width")) {
    settings.width = parseSize("width", *text, maxRes);
  }
  if (const std::string* text = single(params, "height")) {
    settings.height = parseSize("height", *text, maxRes);
  }

  if (const std::string* text = single(params, "format")) {
    std::optional<ImageFormat> format;
    std::string names;
    for (ImageFormat f : formats) {
      if (formatName(f) == *text) format = f;
      names += (names.empty() ? "" : ", ") + std::string(formatName(f));
    }
    if (!format) {
      throw FrameQueryError("format",
                            "format " + quoteClientText(*text) + " is not one of: " + names + ".");
    }
    request.format = *format;
  }
  const bool several = request.targets.size() > 1;
  const ImageFormat format = request.format;
  if (several && format != ImageFormat::Npz && format != ImageFormat::Exr) {
    throw FrameQueryError("format", "format " + std::string(formatName(format)) +
                                        " holds one target; several targets (target=" +
                                        joinedTargets(request.targets) +
                                        ") come as format=npz or format=exr.");
  }
  if (several) {
    for (render::Target t : request.targets) {
      if (t == render::Target::LightVolumes) {
        throw FrameQueryError("target", "light-volumes is a picture of the lights over the "
                                        "final image; ask for it as the only target.");
      }
      if (t == render::Target::Motion) {
        throw FrameQueryError("target", "motion is drawn by its own pass into the frame's "
                                        "output; ask for it as the only target.");
      }
    }
  }
  if (format == ImageFormat::Png16 && settings.target != render::Target::Depth &&
      !render::isLabel(settings.target)) {
    throw FrameQueryError("format", "format png16 (16-bit grey) holds depth or an id target "
                                    "(instance-id, semantic-id, material-id), not " +
                                        std::string(render::targetName(settings.target)) + ".");
  }
  // What is read back raw (float values, or labels' uint32s): everything but an 8-bit picture.
  // npy and npz keep `final` as its 8-bit sRGB picture (uint8 HxWx3, as numpy users expect of
  // an image); exr holds linear HDR radiance for it.
  switch (format) {
    case ImageFormat::Png:
    case ImageFormat::Jpeg:
      // Label targets are always read back raw (render::Target::InstanceId); their PNG and JPEG
      // are false-colour pictures made by the encoder.
      settings.raw = render::isLabel(settings.target);
      break;
    case ImageFormat::Npy:
    case ImageFormat::Npz:
      settings.raw = settings.target != render::Target::Final;
      break;
    case ImageFormat::Raw:
    case ImageFormat::Png16:
    case ImageFormat::Exr:
      settings.raw = true;
      break;
  }

  if (const std::string* text = single(params, "quality")) {
    request.quality = static_cast<int>(parseBoundedInteger(
        "quality", *text, protocol::query::kMinQuality, protocol::query::kMaxQuality,
        "the JPEG quality"));
  }
  if (const std::string* text = single(params, std::string(protocol::query::kCompression))) {
    std::optional<encode::PngCompression> c = encode::parsePngCompression(*text);
    if (!c) {
      std::string names;
      for (std::string_view n : protocol::query::kPngCompressions) {
        names += (names.empty() ? "" : ", ") + std::string(n);
      }
      throw FrameQueryError(std::string(protocol::query::kCompression),
                            "compression (PNG) must be one of " + names + ", got " +
                                quoteClientText(*text) + ".");
    }
    request.compression = *c;
  }
  if (const std::string* text = single(params, std::string(protocol::query::kPrecision))) {
    const auto& names = protocol::query::kExrPrecisions;
    if (*text == names[0]) {
      request.precision = encode::ExrPrecision::Float;
    } else if (*text == names[1]) {
      request.precision = encode::ExrPrecision::Half;
    } else {
      throw FrameQueryError(std::string(protocol::query::kPrecision),
                            "precision (EXR) must be " + std::string(names[0]) + " or " +
                                std::string(names[1]) + ", got " + quoteClientText(*text) + ".");
    }
  }
}

}  // namespace

render::FrameSettings parseFrameQuery(const QueryParams& params, const FrameDefaults& defaults) {
  return parseFrameRequest(params, defaults).settings;
}

void CameraOverride::applyTo(scene::Camera& camera) const {
  if (eye) camera.eye = *eye;
  if (lookAt) camera.target = *lookAt;
  if (fov) camera.fovYDegrees = *fov;
  if (near) camera.nearPlane = *near;
  if (far) camera.farPlane = *far;
  if (glm::length(camera.target - camera.eye) < kMinViewDistance) {
    const char* culprit = lookAt ? "look_at" : "eye";
    throw FrameQueryError(culprit, std::string(culprit) + " must differ from the eye position; the "
                                   "camera would have no view direction.");
  }
  if (up && glm::length(*up) < kMinViewDistance) {
    throw FrameQueryError("up", "up must be a direction, not the zero vector.");
  }
  camera.up = upFor(camera.eye, camera.target, up ? *up : camera.up);
  if (!(camera.nearPlane < camera.farPlane)) {
    const char* culprit = far ? "far" : "near";
    throw FrameQueryError(culprit, "near (" + std::to_string(camera.nearPlane) +
                                       ") must be below far (" + std::to_string(camera.farPlane) +
                                       ").");
  }
}

namespace {

// ?eye=&look_at=&up=&fov=&near=&far= of a session frame, each checked on its own (applyTo checks
// them together with the session's camera).
CameraOverride parseCameraOverride(const QueryParams& params) {
  CameraOverride camera;
  if (const std::string* text = single(params, "eye")) camera.eye = parseVector("eye", *text);
  if (const std::string* text = single(params, "look_at")) camera.lookAt = parseVector("look_at", *text);
  if (const std::string* text = single(params, "up")) camera.up = parseVector("up", *text);
  if (const std::string* text = single(params, "fov")) {
    std::optional<float> fov = parseFloat(*text);
    if (!fov || *fov <= 0.0f || *fov >= 180.0f) {
      throw FrameQueryError("fov", "fov must be a vertical field of view in degrees, above 0 and "
                                   "below 180, got " + quoteClientText(*text) + ".");
    }
    camera.fov = *fov;
  }
  for (const char* name : {"near", "far"}) {
    if (const std::string* text = single(params, name)) {
      std::optional<float> plane = parseFloat(*text);
      if (!plane || !std::isfinite(*plane) || *plane <= 0.0f || *plane > kMaxCoordinate) {
        throw FrameQueryError(name, std::string(name) + " must be a distance in metres above 0 and "
                                    "at most 1e6, got " + quoteClientText(*text) + ".");
      }
      (std::string_view(name) == "near" ? camera.near : camera.far) = *plane;
    }
  }
  return camera;
}

}  // namespace

FrameRequest parseSessionFrameQuery(const QueryParams& params, uint32_t maxResolution) {
  checkNames(params, kSessionFrameParameters, protocol::routes::kSessionFrame);
  FrameRequest request;
  request.camera = parseCameraOverride(params);
  parseOutput(params, maxResolution,
              std::array{ImageFormat::Png, ImageFormat::Jpeg, ImageFormat::Raw, ImageFormat::Png16,
                         ImageFormat::Npy, ImageFormat::Exr, ImageFormat::Npz},
              request, /*targetList=*/true);
  // depth= and space= convert float values: formats that carry them.
  const bool floats = request.format == ImageFormat::Raw || request.format == ImageFormat::Npy ||
                      request.format == ImageFormat::Exr || request.format == ImageFormat::Npz;
  auto asks = [&](render::Target t) {
    return std::find(request.targets.begin(), request.targets.end(), t) != request.targets.end();
  };
  if (const std::string* text = single(params, "time")) {
    std::optional<float> time = parseFloat(*text);
    if (!time || *time < 0.0f || *time > kMaxAnimationSeconds) {
      throw FrameQueryError("time", "time must be an animation time in seconds from 0 to 1e6, got " +
                                        quoteClientText(*text) + ".");
    }
    request.time = *time;
  }
  if (const std::string* text = single(params, "sample")) {
    request.sampleIndex = parseBoundedInteger("sample", *text, 0, UINT32_MAX,
                                              "the stochastic shadows' sample to draw");
  }
  if (const std::string* text = single(params, std::string(protocol::query::kDepthConvention))) {
    if (*text != "z" && *text != "distance") {
      throw FrameQueryError(std::string(protocol::query::kDepthConvention), "depth is z (along the view axis) or distance (to the "
                                     "camera centre), got " + quoteClientText(*text) + ".");
    }
    if (!asks(render::Target::Depth) || !floats) {
      throw FrameQueryError(std::string(protocol::query::kDepthConvention), "depth= chooses the convention of float depth: it goes with "
                                     "target=depth and format=raw, npy, exr or npz.");
    }
    request.depthDistance = *text == "distance";
  }
  if (const std::string* text = single(params, std::string(protocol::query::kSpace))) {
    const std::string name(protocol::query::kSpace);
    if (*text != "world" && *text != "camera") {
      throw FrameQueryError(name, "space is world or camera, got " + quoteClientText(*text) + ".");
    }
    if ((!asks(render::Target::Position) && !asks(render::Target::Normal)) || !floats) {
      throw FrameQueryError(name, "space= chooses the axes of float position and normal: it goes "
                                  "with target=position or target=normal and format=raw, npy, "
                                  "exr or npz.");
    }
    request.cameraSpace = *text == "camera";
  }
  return request;
}

FrameRequest parseStreamQuery(const QueryParams& params, uint32_t maxResolution) {
  checkNames(params, kStreamParameters, protocol::routes::kSessionStream);
  FrameRequest request;
  request.format = ImageFormat::Jpeg;
  parseOutput(params, maxResolution, std::array{ImageFormat::Jpeg, ImageFormat::Png}, request);
  if (const std::string* text = single(params, "fps")) {
    request.fps = parseBoundedInteger("fps", *text, protocol::query::kMinFps, kMaxStreamFps,
                                      "frames per second");
  }
  const std::string* codecText = single(params, "codec");
  const std::string* bitrateText = single(params, "bitrate");
  if (const std::string* text = single(params, "interactive")) {
    request.interactiveFps = parseBoundedInteger(
        "interactive", *text, 0, protocol::query::kMaxInteractiveFps,
        "the frames a second to hold while the scene changes (0: off)");
    if (codecText && request.interactiveFps > 0) {
      throw FrameQueryError("interactive",
                            "interactive applies to image streams; a video stream (codec=" +
                                *codecText + ") keeps its size, so leave interactive out.");
    }
  }
  const std::string* containerText = single(params, "container");
  if (!codecText) {
    if (bitrateText || containerText) {
      const char* name = bitrateText ? "bitrate" : "container";
      throw FrameQueryError(name, std::string(name) +
                                      " applies to video streams; name a codec (codec=vp8, vp9 "
                                      "or h264) or leave " + name + " out.");
    }
    return request;
  }
  if (render::isLabel(request.settings.target)) {
    throw FrameQueryError("target", "The label targets (instance-id, semantic-id, material-id) "
                                    "stream as images (JPEG or PNG, false colour), not as video.");
  }
  VideoStreamRequest video;
  std::string names;
  bool known = false;
  for (size_t i = 0; i < protocol::kVideoCodecs.size(); ++i) {
    if (protocol::kVideoCodecs[i] == *codecText) {
      video.codec = static_cast<encode::VideoCodec>(i);
      known = true;
    }
    names += (names.empty() ? "" : ", ") + std::string(protocol::kVideoCodecs[i]);
  }
  if (!known) {
    throw FrameQueryError("codec",
                          "codec " + quoteClientText(*codecText) + " is not one of: " + names + ".");
  }
  for (const char* imageOnly : {"format", "quality"}) {
    if (single(params, imageOnly)) {
      throw FrameQueryError(imageOnly, std::string(imageOnly) +
                                           " describes image streams; a video stream (codec=" +
                                           *codecText + ") takes bitrate instead.");
    }
  }
  for (auto [name, value] : {std::pair{"width", request.settings.width},
                             std::pair{"height", request.settings.height}}) {
    if (value < 2) {
      throw FrameQueryError(name, std::string(name) + " of a video stream must be at least 2.");
    }
  }
  video.container = video.codec == encode::VideoCodec::H264 ? encode::VideoContainer::Mp4
                                                            : encode::VideoContainer::Myriad;
  if (containerText) {
    std::string containers;
    bool knownContainer = false;
    for (size_t i = 0; i < protocol::kVideoContainers.size(); ++i) {
      if (protocol::kVideoContainers[i] == *containerText) {
        video.container = static_cast<encode::VideoContainer>(i);
        knownContainer = true;
      }
      containers += (containers.empty() ? "" : ", ") + std::string(protocol::kVideoContainers[i]);
    }
    if (!knownContainer) {
      throw FrameQueryError("container", "container " + quoteClientText(*containerText) +
                                             " is not one of: " + containers + ".");
    }
  }
  if (!encode::containerCarries(video.container, video.codec)) {
    throw FrameQueryError(
        "container", "container=" + std::string(encode::videoContainerName(video.container)) +
                         " does not carry " + *codecText +
                         ": myriad and webm carry vp8 and vp9, mp4 carries h264.");
  }
  if (video.codec == encode::VideoCodec::H264) {
    for (auto [name, value] : {std::pair{"width", request.settings.width},
                               std::pair{"height", request.settings.height}}) {
      if (value % 2 != 0) {
        throw FrameQueryError(name, std::string(name) + " of an h264 stream must be even.");
      }
    }
    if (encode::h264Level(request.settings.width, request.settings.height, request.fps, 0) == 0) {
      throw FrameQueryError("width", "an h264 stream's frame is at most 36,864 macroblocks of "
                                     "16x16 (H.264 level 5.2: 4096x2304); ask a smaller width "
                                     "and height.");
    }
  }
  if (bitrateText) {
    video.bitrateKbps = parseBoundedInteger("bitrate", *bitrateText,
                                            protocol::query::kMinBitrateKbps,
                                            protocol::query::kMaxBitrateKbps,
                                            "the video bitrate in kbit/s");
  } else {
    const double bits = kDefaultVideoBitsPerPixel * request.settings.width *
                        request.settings.height * request.fps;
    video.bitrateKbps = static_cast<uint32_t>(
        std::clamp(bits / 1000.0, double(protocol::query::kMinBitrateKbps),
                   double(protocol::query::kMaxBitrateKbps)));
  }
  request.video = video;
  return request;
}

FrameRequest parseFrameRequest(const QueryParams& params, const FrameDefaults& defaults) {
  checkNames(params, kFrameParameters, protocol::routes::kFrame);

  FrameRequest request;
  render::FrameSettings& settings = request.settings;
  settings.camera = defaults.camera;
  settings.technique = defaults.technique;
  parseOutput(params, defaults.maxResolution,
              std::array{ImageFormat::Png, ImageFormat::Jpeg, ImageFormat::Raw}, request);

  const std::string* eyeText = single(params, "eye");
  const std::string* lookAtText = single(params, "look_at");
  if (eyeText) settings.camera.eye = parseVector("eye", *eyeText);
  if (lookAtText) settings.camera.target = parseVector("look_at", *lookAtText);
  if (eyeText || lookAtText) {
    // Blame the parameter the client sent; look_at when both were.
    const char* culprit = lookAtText ? "look_at" : "eye";
    if (glm::length(settings.camera.target - settings.camera.eye) < kMinViewDistance) {
      throw FrameQueryError(culprit, std::string(culprit) +
                                         " must differ from the eye position; the camera would "
                                         "have no view direction.");
    }
    scene::Camera& camera = settings.camera;
    camera.up = upFor(camera.eye, camera.target, camera.up);
    // The default far plane encloses the scene from the default eye only.
    if (!defaults.sceneBounds.empty()) {
      float radius = 0.5f * glm::length(defaults.sceneBounds.size());
      float reach = glm::length(camera.eye - defaults.sceneBounds.center()) + radius;
      camera.farPlane = std::max(camera.farPlane, reach * 1.05f);
    }
  }

  if (const std::string* text = single(params, "fov")) {
    std::optional<float> fov = parseFloat(*text);
    if (!fov || *fov <= 0.0f || *fov >= 180.0f) {
      throw FrameQueryError("fov",
                            "fov must be a vertical field of view in degrees, above 0 and "
                            "below 180, got " +
                                quoteClientText(*text) + ".");
    }
    settings.camera.fovYDegrees = *fov;
  }

  if (const std::string* text = single(params, "markers")) {
    if (*text == "true" || *text == "1") {
      settings.markers = true;
    } else if (*text == "false" || *text == "0") {
      settings.markers = false;
    } else {
      throw FrameQueryError(
          "markers", "markers must be true, false, 1 or 0, got " + quoteClientText(*text) + ".");
    }
  }

  if (const std::string* text = single(params, "exposure")) {
    std::optional<float> exposure = parseFloat(*text);
    if (!exposure || *exposure <= 0.0f) {
      throw FrameQueryError("exposure",
                            "exposure must be a finite number above 0 (1 = as lit), got " +
                                quoteClientText(*text) + ".");
    }
    settings.exposure = *exposure;
  }

  if (const std::string* text = single(params, "technique")) {
    std::optional<render::Technique> technique = render::parseTechnique(*text);
    if (!technique) {
      throw FrameQueryError("technique", "technique must be " + render::techniqueChoices() +
                                             ", got " + quoteClientText(*text) + ".");
    }
    settings.technique = *technique;
  }

  if (const std::string* text = single(params, "antialias")) {
    std::optional<render::Antialias> antialias = render::parseAntialias(*text);
    if (!antialias) {
      throw FrameQueryError("antialias", "antialias must be none, fxaa, taa or ssaa, got " +
                                             quoteClientText(*text) + ".");
    }
    settings.antialias = *antialias;
  }
  return request;
}

std::string formatServerTiming(const std::vector<render::PassTiming>& passes, double encodeMs,
                               const render::CullingReport* culling,
                               std::optional<double> queueMs) {
  std::string header;
  auto append = [&header](std::string_view name, double ms) {
    // Server-Timing metric names are HTTP tokens; pass names are ours, but a space or comma
    // slipping in would silently corrupt the header for every client.
    std::string token;
    for (char c : name) {
      bool ok = std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.';
      token += ok ? c : '-';
    }
    char number[32];
    double value = std::isfinite(ms) && ms >= 0.0 ? ms : 0.0;
    auto [end, ec] =
        std::to_chars(number, number + sizeof number, value, std::chars_format::fixed, 3);
    if (!header.empty()) header += ", ";
    header += token + ";dur=" + std::string(number, ec == std::errc() ? end : number);
  };
  for (const render::PassTiming& pass : passes) append(pass.name, pass.milliseconds);
  append("encode", encodeMs);
  if (queueMs) append("queue", *queueMs);
  if (culling != nullptr) header += ", culling;desc=\"" + describeCulling(*culling) + "\"";
  return header;
}

std::string describeCulling(const render::CullingReport& c) {
  // Words, digits and slashes only: this goes inside a quoted Server-Timing desc, and clients that
  // split the header on commas or semicolons without honouring quotes must still parse it.
  return "dropped " + std::to_string(c.tileLightsDropped + c.clusterLightsDropped) +
         " light references (tiles overflowed " + std::to_string(c.tilesOverflowed) +
         ") / list entries " + std::to_string(c.listEntries) + " / active clusters " +
         std::to_string(c.activeClusters) + " / longest list " +
         std::to_string(c.mostLightsInList) + " / list capacity " + std::to_string(c.listCapacity) +
         (c.listsGrew ? " / lists grew and the frame was rendered again" : "");
}

}  // namespace myriad::service
