#include "service/batch.h"

#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>

#include "protocol/constants.h"
#include "protocol/validate.h"
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
    case ImageFormat::Jpeg:
      return "jpg";
    case ImageFormat::Raw:
      return "raw";
    case ImageFormat::Png:
      break;
  }
  return "png";
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
        member != "framesPerIndex") {
      throw specError(job, "unknown member \"" + member +
                               "\" (snapshot, cameras, frame, framesPerIndex).");
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
  FrameRequest request;
  try {
    request = parseSessionFrameQuery(parseQuery(job, spec["frame"].get<std::string>()),
                                     context.config.limits.maxResolution);
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
  for (uint64_t i = first; i < end; ++i) {
    const auto started = std::chrono::steady_clock::now();
    {
      std::lock_guard lock(session->mutex);
      session->scene.setCamera(fromWire(cameras[i]));
      session->bump();
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
  context.sessions.remove(session->id);
  return written;
}

}  // namespace myriad::service
