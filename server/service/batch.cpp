#include "service/batch.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>

#include "protocol/constants.h"
#include "protocol/validate.h"
#include "scene/camera.h"
#include "service/frame_query.h"
#include "service/metrics.h"
#include "service/session_frames.h"
#include "service/session_json.h"

namespace myriad::service {
namespace fs = std::filesystem;
namespace {

std::runtime_error specError(const BatchJob& job, const std::string& sentence) {
  return std::runtime_error("batch spec " + job.specPath + ": " + sentence);
}

// One member of the spec checked against its protocol schema, as the HTTP API checks a body.
nlohmann::json validated(const BatchJob& job, const nlohmann::json& value,
                         std::string_view schemaName, const std::string& pointer) {
  protocol::ParsedBody parsed = protocol::parseBody(schemaName, value.dump());
  if (!parsed.ok()) {
    throw specError(job, pointer + parsed.error->pointer + ": " + parsed.error->message);
  }
  return std::move(parsed.json);
}

// "width=64&height=48&format=png" -> the decoded query (no percent-escapes: none is needed).
QueryParams parseQuery(const BatchJob& job, const std::string& text) {
  QueryParams params;
  std::stringstream in(text);
  std::string pair;
  while (std::getline(in, pair, '&')) {
    if (pair.empty()) continue;
    const size_t equals = pair.find('=');
    if (equals == std::string::npos || pair.find('%') != std::string::npos) {
      throw specError(job, "\"frame\" is a query string such as \"width=640&height=360&format=png\", "
                           "not \"" + text + "\".");
    }
    params.emplace(pair.substr(0, equals), pair.substr(equals + 1));
  }
  return params;
}

void writeAtomically(const fs::path& path, const std::string& bytes) {
  const fs::path temporary = path.string() + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    if (!out.flush()) throw std::runtime_error("cannot write " + temporary.string());
  }
  std::error_code error;
  fs::rename(temporary, path, error);
  if (error) throw std::runtime_error("cannot write " + path.string() + ": " + error.message());
}

std::string extensionOf(ImageFormat format) {
  switch (format) {
    case ImageFormat::Jpeg: return "jpg";
    case ImageFormat::Raw: return "raw";
    case ImageFormat::Npy: return "npy";
    case ImageFormat::Exr: return "exr";
    case ImageFormat::Npz: return "npz";
    case ImageFormat::Png:
    case ImageFormat::Png16: break;
  }
  return "png";
}

// A dataset's target and the format its files take (the spec's "targets").
struct DatasetTarget {
  render::Target target;
  ImageFormat format;
};

// The formats a target's dataset files may take: final's 8-bit picture as png or npy; depth and
// the ids also as 16-bit PNG; every float target as npy or exr (ids as uint32).
bool datasetFormatFits(render::Target t, ImageFormat f) {
  if (t == render::Target::Final) return f == ImageFormat::Png || f == ImageFormat::Npy;
  if (f == ImageFormat::Npy || f == ImageFormat::Exr) return true;
  return f == ImageFormat::Png16 && (t == render::Target::Depth || render::isLabel(t));
}

std::vector<DatasetTarget> datasetTargets(const BatchJob& job, const nlohmann::json& targets) {
  if (!targets.is_object() || targets.empty()) {
    throw specError(job, "\"targets\" is an object of target: format, e.g. {\"final\": \"png\", "
                         "\"depth\": \"exr\"}.");
  }
  std::vector<DatasetTarget> out;
  for (const auto& [name, value] : targets.items()) {
    const std::optional<render::Target> target = render::parseTarget(name);
    if (!target) throw specError(job, "/targets: \"" + name + "\" is not a target.");
    std::optional<ImageFormat> format;
    if (value.is_string()) {
      for (size_t i = 0; i < protocol::kFormats.size(); ++i) {
        if (protocol::kFormats[i] == value.get<std::string>()) format = ImageFormat(i);
      }
    }
    if (!format || !datasetFormatFits(*target, *format)) {
      throw specError(job, "/targets/" + name + ": " + value.dump() +
                               " is not a dataset format of " + name +
                               " (final: png or npy; depth and the ids: png16, npy or exr; "
                               "other targets: npy or exr).");
    }
    out.push_back({*target, *format});
  }
  return out;
}

// One frame's entry in metadata.json.
nlohmann::json datasetFrame(uint64_t index, const FrameRequest& rendered,
                            const nlohmann::json& files) {
  const render::FrameSettings& s = rendered.settings;
  const scene::Intrinsics k = scene::intrinsicsOf(s.camera, s.width, s.height);
  const glm::mat4 pose = scene::worldFromCamera(s.camera);
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({pose[0][r], pose[1][r], pose[2][r], pose[3][r]});
  return {{"index", index},
          {"time", s.time},
          {"width", s.width},
          {"height", s.height},
          {"K", {{k.fx, 0.0, k.cx}, {0.0, k.fy, k.cy}, {0.0, 0.0, 1.0}}},
          {"world_from_camera", rows},
          {"near", s.camera.nearPlane},
          {"far", s.camera.farPlane},
          {"files", files}};
}

// Adds `frames` to DIR/metadata.json (replacing entries of the same index), under an exclusive
// lock on DIR/metadata.json.lock: the indices of one job write one directory.
void mergeMetadata(const fs::path& dir, const std::vector<nlohmann::json>& frames) {
  const fs::path lockPath = dir / "metadata.json.lock";
  const int fd = ::open(lockPath.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot open " + lockPath.string());
  struct Unlock {
    int fd;
    ~Unlock() {
      ::flock(fd, LOCK_UN);
      ::close(fd);
    }
  } unlock{fd};
  if (::flock(fd, LOCK_EX) != 0) throw std::runtime_error("cannot lock " + lockPath.string());
  const fs::path path = dir / "metadata.json";
  nlohmann::json metadata = {{"format", "myriad-dataset"}, {"version", 1},
                             {"frames", nlohmann::json::array()}};
  if (std::ifstream in(path, std::ios::binary); in) {
    try {
      nlohmann::json existing = nlohmann::json::parse(in);
      if (existing.value("format", "") == "myriad-dataset" && existing.contains("frames") &&
          existing["frames"].is_array()) {
        metadata = std::move(existing);
      }
    } catch (const nlohmann::json::exception&) {
      throw std::runtime_error(path.string() + " is not JSON; remove it or use another --out.");
    }
  }
  std::map<uint64_t, nlohmann::json> byIndex;
  for (nlohmann::json& f : metadata["frames"]) {
    // The key first: json's assignment takes its operand by value, made before the left side.
    const uint64_t index = f.value("index", uint64_t(0));
    byIndex[index] = std::move(f);
  }
  for (const nlohmann::json& f : frames) byIndex[f.at("index").get<uint64_t>()] = f;
  metadata["frames"] = nlohmann::json::array();
  for (auto& [index, f] : byIndex) metadata["frames"].push_back(std::move(f));
  writeAtomically(path, metadata.dump(1) + "\n");
}

}  // namespace

size_t runBatch(ApiContext& context, const BatchJob& job) {
  nlohmann::json spec;
  {
    std::ifstream in(job.specPath, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read the batch spec " + job.specPath + ".");
    try {
      spec = nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception& e) {
      throw specError(job, std::string("not JSON (") + e.what() + ").");
    }
  }
  if (!spec.is_object()) throw specError(job, "the spec is a JSON object.");
  for (const auto& [member, value] : spec.items()) {
    if (member != "snapshot" && member != "cameras" && member != "frame" &&
        member != "framesPerIndex" && member != "targets") {
      throw specError(job, "unknown member \"" + member +
                               "\" (snapshot, cameras, frame, framesPerIndex, targets).");
    }
  }
  if (!spec.contains("snapshot")) throw specError(job, "\"snapshot\" is required.");
  const protocol::Snapshot snapshot =
      validated(job, spec["snapshot"], protocol::schema_names::kSnapshot, "/snapshot")
          .get<protocol::Snapshot>();
  if (!spec.contains("cameras") || !spec["cameras"].is_array() || spec["cameras"].empty()) {
    throw specError(job, "\"cameras\" is a non-empty array of cameras (the camera path).");
  }
  std::vector<protocol::Camera> cameras;
  for (size_t i = 0; i < spec["cameras"].size(); ++i) {
    cameras.push_back(validated(job, spec["cameras"][i], protocol::schema_names::kCamera,
                                "/cameras/" + std::to_string(i))
                          .get<protocol::Camera>());
  }
  if (!spec.contains("frame") || !spec["frame"].is_string()) {
    throw specError(job, "\"frame\" is GET .../frame's query string, e.g. "
                         "\"width=640&height=360&format=png\".");
  }
  std::vector<DatasetTarget> dataset;
  QueryParams query = parseQuery(job, spec["frame"].get<std::string>());
  if (spec.contains("targets")) {
    dataset = datasetTargets(job, spec["targets"]);
    for (const char* name : {"target", "format"}) {
      if (query.count(name)) {
        throw specError(job, std::string("\"frame\" parameter \"") + name +
                                 "\": with \"targets\", the targets and their formats come from "
                                 "\"targets\".");
      }
    }
    // One render of every target: a multi-target frame, as GET .../frame?format=npz asks.
    std::string list;
    for (const DatasetTarget& t : dataset) {
      list += (list.empty() ? "" : ",") + std::string(render::targetName(t.target));
    }
    query.emplace("target", list);
    query.emplace("format", std::string(formatName(ImageFormat::Npz)));
  }
  FrameRequest request;
  try {
    request = parseSessionFrameQuery(query, context.config.limits.maxResolution);
  } catch (const FrameQueryError& e) {
    throw specError(job, "\"frame\" parameter \"" + e.parameter() + "\": " + e.what());
  }
  const nlohmann::json& perIndex = spec.value("framesPerIndex", nlohmann::json(1));
  if (!perIndex.is_number_unsigned() || perIndex.get<uint64_t>() == 0) {
    throw specError(job, "\"framesPerIndex\" is a whole number from 1.");
  }
  const uint64_t k = perIndex.get<uint64_t>();
  const uint64_t first = uint64_t(job.index) * k;
  const uint64_t end = std::min<uint64_t>(first + k, cameras.size());

  std::error_code error;
  fs::create_directories(job.outDir, error);
  if (!fs::is_directory(job.outDir)) {
    throw std::runtime_error("cannot create the output directory " + job.outDir + ".");
  }
  if (first >= end) {
    std::fprintf(stderr, "myriad-server: batch index %u: no frames (the path has %zu)\n",
                 job.index, cameras.size());
    return 0;
  }

  SessionPtr session = createSessionFromSnapshot(context, snapshot);
  FrameStatsBook stats;
  Metrics metrics;
  size_t written = 0;
  std::vector<nlohmann::json> datasetFrames;
  for (uint64_t i = first; i < end; ++i) {
    const auto started = std::chrono::steady_clock::now();
    {
      std::lock_guard lock(session->mutex);
      session->scene.setCamera(fromWire(cameras[i]));
      session->bump();
    }
    if (!dataset.empty()) {
      // One render; each target encoded from it alone and written as its own file.
      const SessionFrameContext frameContext{context.renderThread, stats, metrics};
      PendingSessionFrame pending =
          submitSessionFrame(frameContext, session, request, render::FrameSource::Request);
      nlohmann::json files = nlohmann::json::object();
      size_t bytes = 0;
      const FrameEncoder encoder = [&](const render::Frame& rendered) {
        EncodedFrame all;
        for (const DatasetTarget& t : dataset) {
          FrameRequest one = pending.rendered;
          one.targets = {t.target};
          one.format = t.format;
          EncodedFrame encoded = encodeFrame(rendered, one);
          all.encodeMs += encoded.encodeMs;
          char name[64];
          std::snprintf(name, sizeof name, "%s_%05llu.%s",
                        std::string(render::targetName(t.target)).c_str(),
                        static_cast<unsigned long long>(i), extensionOf(t.format).c_str());
          writeAtomically(fs::path(job.outDir) / name, encoded.body);
          files[std::string(render::targetName(t.target))] = name;
          bytes += encoded.body.size();
        }
        return all;
      };
      collectSessionFrame(frameContext, session, pending, &encoder);
      datasetFrames.push_back(datasetFrame(i, pending.rendered, files));
      written += dataset.size();
      std::fprintf(stderr, "myriad-server: batch index %u: frame %llu, %zu files (%zu bytes, %.0f ms)\n",
                   job.index, static_cast<unsigned long long>(i), dataset.size(), bytes,
                   std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                             started)
                       .count());
      continue;
    }
    SessionFrame frame =
        renderSessionFrame({context.renderThread, stats, metrics}, session, request);
    char name[32];
    std::snprintf(name, sizeof name, "frame-%06llu.", static_cast<unsigned long long>(i));
    const fs::path path = fs::path(job.outDir) / (name + extensionOf(request.format));
    writeAtomically(path, frame.encoded.body);
    ++written;
    std::fprintf(stderr, "myriad-server: batch index %u: %s (%zu bytes, %.0f ms)\n", job.index,
                 path.c_str(), frame.encoded.body.size(),
                 std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                           started)
                     .count());
  }
  if (!datasetFrames.empty()) mergeMetadata(job.outDir, datasetFrames);
  context.sessions.remove(session->id);
  return written;
}

}  // namespace myriad::service
