// GET /v1/frame's query string -> render::FrameSettings, with every rule a client can break
// reported as the offending parameter and a sentence. Pure: no HTTP, no Vulkan.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "encode/arrays.h"
#include "encode/png.h"
#include "encode/video.h"
#include "encode/video_container.h"
#include "protocol/constants.h"
#include "render/frame.h"
#include "scene/scene.h"

namespace myriad::service {

// GET /v1/frame (stateless, the built-in scene).
inline constexpr std::array<std::string_view, 13> kFrameParameters = {
    "target", "width",   "height", "format",  "quality", "eye",
    "look_at", "fov",    "markers", "exposure", "technique", "antialias",
    protocol::query::kCompression};
// GET /v1/sessions/{id}/frame: camera and settings come from the session.
// eye, look_at, up, fov, near, far: a camera for this frame only (CameraOverride).
inline constexpr std::array<std::string_view, 18> kSessionFrameParameters = {
    "target", "format", "width", "height", "quality", "time", "sample",
    protocol::query::kDepthConvention, protocol::query::kSpace, "token",
    protocol::query::kCompression, protocol::query::kPrecision,
    "eye", "look_at", "up", "fov", "near", "far"};
// GET /v1/sessions/{id}/stream.
inline constexpr std::array<std::string_view, 11> kStreamParameters = {
    "target", "format",  "fps",   "width",       "height",
    "quality", "codec", "bitrate", "interactive", "token", "container"};

// How a frame's pixels are sent; in the order of protocol::kFormats, which names them.
// Png16: 16-bit grey (depth, ids); Npy, Exr, Npz: arrays (reference.md "Frame formats").
enum class ImageFormat { Png, Jpeg, Raw, Png16, Npy, Exr, Npz };
static_assert(protocol::kFormats.size() == 7);
inline std::string_view formatName(ImageFormat f) {
  return protocol::kFormats[static_cast<size_t>(f)];
}

// JPEG quality when a request names none: small files with artefacts hard to see in a live view.
inline constexpr int kDefaultJpegQuality = 85;
// Stream frame rate bounds and default (frames per second), as the protocol states them.
inline constexpr uint32_t kMaxStreamFps = protocol::query::kMaxFps;
inline constexpr uint32_t kDefaultStreamFps = protocol::query::kDefaultFps;

// A video stream's default bitrate: this many bits per pixel per frame at the stream's size and
// fps (1920x1080 at 30 fps: 6.2 Mbit/s; 1280x720 at 15 fps: 1.4 Mbit/s), within the protocol's
// bitrate bounds.
inline constexpr double kDefaultVideoBitsPerPixel = 0.1;

// GET .../stream?codec=: the video a stream sends instead of images.
struct VideoStreamRequest {
  encode::VideoCodec codec = encode::VideoCodec::Vp8;
  uint32_t bitrateKbps = 0;
  // How the frames are framed (?container=): per stream, so streams of one channel (one encoder)
  // may each use their own. Default Myriad for vp8/vp9, Mp4 for h264.
  encode::VideoContainer container = encode::VideoContainer::Myriad;
};

// What a frame request asks for: the render settings and how to encode the result.
// Session frames: a camera for one frame (?eye=&look_at=&up=&fov=&near=&far=), over the
// session's own, which stays as it was: what a camera path rendered by several requests at once
// needs (each request its own view, none waiting for another's camera PATCH). A member left out
// keeps the session camera's.
struct CameraOverride {
  std::optional<glm::vec3> eye, lookAt, up;
  std::optional<float> fov, near, far;
  bool any() const { return eye || lookAt || up || fov || near || far; }
  // `camera` with the members given; throws FrameQueryError naming the parameter when the result
  // has no view direction (eye on look_at) or near is not below far.
  void applyTo(scene::Camera& camera) const;
};

struct FrameRequest {
  render::FrameSettings settings;  // settings.raw is set for ImageFormat::Raw
  CameraOverride camera;           // session frames only
  ImageFormat format = ImageFormat::Png;
  // Every target asked for, in the order asked (?target=a,b,c; one for a single target):
  // settings.target is one of them (final when asked, else the first view), settings.alsoRead
  // the rest (render::FrameSettings::alsoRead).
  std::vector<render::Target> targets{render::Target::Final};
  encode::PngCompression compression = encode::PngCompression::Fast;  // png, png16
  encode::ExrPrecision precision = encode::ExrPrecision::Float;       // exr
  // Session frames: the session version the frame shows (submitSessionFrame sets it).
  std::optional<uint64_t> version;
  int quality = kDefaultJpegQuality;  // JPEG only; accepted (and checked) but unused otherwise
  std::optional<double> time;         // session frames: animation time asked for, in seconds
  // Session frames: which sample a stochastic technique draws (render::FrameSettings::
  // sampleIndex): the same index the same picture, another an independent one, so a client
  // averages frames 0..N-1 of a still view into the converged image.
  uint32_t sampleIndex = 0;
  // Session frames, raw depth only: metres to the camera centre instead of along the view axis.
  bool depthDistance = false;
  // Session frames, raw position and normal only: in camera space (OpenCV axes, the frame's
  // X-Myriad-Pose) instead of world space.
  bool cameraSpace = false;
  uint32_t fps = kDefaultStreamFps;   // streams only
  std::optional<VideoStreamRequest> video;  // streams with codec= only: video, not images
  // Streams only: frames a second to hold while the session changes (interactive_quality.h);
  // 0: every frame at full quality.
  uint32_t interactiveFps = 0;
  // This frame is a stream's interactive frame: drawn without anti-aliasing and sun shadows
  // (submitSessionFrame applies it over the session's settings).
  bool interactive = false;
};

// What a frame request starts from before its parameters apply.
struct FrameDefaults {
  scene::Camera camera;       // the scene's default view
  scene::Bounds sceneBounds;  // to keep the scene inside the far plane from any eye
  uint32_t maxResolution = 4096;
  render::Technique technique = render::Technique::Clustered;  // --technique
};

class FrameQueryError : public std::runtime_error {
 public:
  FrameQueryError(std::string parameter, std::string detail, bool unknownParameter = false)
      : std::runtime_error(detail),
        parameter_(std::move(parameter)),
        unknownParameter_(unknownParameter) {}
  const std::string& parameter() const { return parameter_; }
  // True when the parameter itself is not one of kFrameParameters (rather than a bad value).
  bool unknownParameter() const { return unknownParameter_; }

 private:
  std::string parameter_;
  bool unknownParameter_;
};

using QueryParams = std::multimap<std::string, std::string>;

// GET /v1/frame. `params` is the decoded query (the same type as httplib::Params). Throws
// FrameQueryError for the first problem found: unknown or repeated parameters first, then values
// in the order of kFrameParameters.
FrameRequest parseFrameRequest(const QueryParams& params, const FrameDefaults& defaults);

// parseFrameRequest's settings alone.
render::FrameSettings parseFrameQuery(const QueryParams& params, const FrameDefaults& defaults);

// GET /v1/sessions/{id}/frame: target, format, size, quality and time; the caller fills in the
// session's camera and settings. `token` is accepted (authorization reads it) and ignored here.
FrameRequest parseSessionFrameQuery(const QueryParams& params, uint32_t maxResolution);

// GET /v1/sessions/{id}/stream: as a session frame, without time, with fps; format png or jpeg
// (default jpeg). With codec (vp8, vp9, h264): a video stream at `bitrate` kbit/s (default
// kDefaultVideoBitsPerPixel), at least 2x2 pixels (h264: even sizes, at most level 5.2's frame),
// and format and quality are refused (they describe images); container (myriad, webm, mp4) only
// with codec, and only one that carries it (myriad and webm: vp8, vp9; mp4: h264). interactive: 0 to protocol::query::kMaxInteractiveFps (image streams only).
FrameRequest parseStreamQuery(const QueryParams& params, uint32_t maxResolution);

// The Server-Timing header value: one metric per GPU pass, then the CPU PNG encode, then (when
// given) `queue`, the wait in the render queue before rendering began; durations in milliseconds
// ("gbuffer;dur=1.234, sun;dur=0.5, encode;dur=3.1, queue;dur=0.02").
// With `culling` (tiled and clustered frames), a last entry without a duration carries the light
// lists' report, so that an overflow is visible in every browser's network panel:
// culling;desc="dropped 0 light references (tiles overflowed 0), list entries 5123 / ...".
std::string formatServerTiming(const std::vector<render::PassTiming>& passes, double encodeMs,
                               const render::CullingReport* culling = nullptr,
                               std::optional<double> queueMs = std::nullopt);

// One line for logs and headers: what light culling did this frame.
std::string describeCulling(const render::CullingReport& culling);

}  // namespace myriad::service
