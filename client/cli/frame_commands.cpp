// frame (one image to a file), stream (the multipart JPEG stream to numbered files), stats.
#include <sys/stat.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>

#include "commands.h"
#include "multipart.h"
#include "output.h"
#include "protocol/constants.h"
#include "protocol/types.h"

namespace myriad::cli {
namespace {

namespace protocol = myriad::protocol;

// The query members `frame` and `stream` share, in the order given in the spec.
Query imageQuery(const Invocation& inv) {
  Query query;
  if (auto v = inv.find<std::string>("target")) query.emplace_back("target", *v);
  if (auto v = inv.find<std::string>("format")) query.emplace_back("format", *v);
  for (const char* name : {"width", "height", "quality", "fps"}) {
    if (auto v = inv.find<uint64_t>(name)) query.emplace_back(name, std::to_string(*v));
  }
  if (auto v = inv.find<double>("time")) query.emplace_back("time", formatNumber(*v));
  return query;
}

void writeFile(const std::string& path, const std::string& bytes) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
  file.write(bytes.data(), std::streamsize(bytes.size()));
  file.close();
  if (!file) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
}

void makeDirectory(const std::string& dir) {
  struct stat st{};
  if (stat(dir.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode)) throw std::runtime_error(dir + " exists and is not a directory");
    return;
  }
  if (mkdir(dir.c_str(), 0755) != 0) {
    throw std::runtime_error("cannot create the directory " + dir + ": " + std::strerror(errno));
  }
}

// A header holding a whole number, as JSON (null when absent or not a number).
nlohmann::json wholeNumberHeader(const HttpResponse& res, std::string_view name) {
  std::string text = res.header(std::string(name));
  if (text.empty() || text.size() > 9 || text.find_first_not_of("0123456789") != std::string::npos) {
    return nullptr;
  }
  return std::stoul(text);
}

int frame(Context& ctx) {
  const Invocation& inv = ctx.inv;
  const std::string output = inv.get<std::string>("output");
  HttpResponse res =
      ctx.http.sendOk("GET", ctx.sessionRoute(protocol::routes::kSessionFrame), imageQuery(inv));
  if (output == "-") {
    // Like any filter: a reader that goes away (`| head -c 8`) ends the program silently.
    std::signal(SIGPIPE, SIG_DFL);
    std::cout.write(res.body.data(), std::streamsize(res.body.size()));
    std::cout.flush();
    if (!std::cout) throw std::runtime_error("cannot write the frame to standard output");
    return 0;
  }
  writeFile(output, res.body);
  std::string format = inv.find<std::string>("format").value_or("png");
  if (ctx.json()) {
    // No JSON came from the server; scripts get what the response headers said instead.
    nlohmann::json summary = {
        {"file", output},
        {"bytes", res.body.size()},
        {"contentType", res.header("Content-Type")},
        {"technique", res.header(std::string(protocol::headers::kTechnique))},
        {"serverTiming", res.header(std::string(protocol::headers::kServerTiming))}};
    if (format == "raw") {
      summary["width"] = wholeNumberHeader(res, protocol::headers::kWidth);
      summary["height"] = wholeNumberHeader(res, protocol::headers::kHeight);
      summary["channels"] = res.header(std::string(protocol::headers::kChannels));
      summary["target"] = res.header(std::string(protocol::headers::kTarget));
    }
    printRaw(ctx.out, summary.dump());
    return 0;
  }
  ctx.out << "wrote " << output << ": " << format;
  if (format == "raw") {
    ctx.out << " float32 " << res.header(std::string(protocol::headers::kWidth)) << "x"
            << res.header(std::string(protocol::headers::kHeight)) << " (channels "
            << res.header(std::string(protocol::headers::kChannels)) << "), target "
            << res.header(std::string(protocol::headers::kTarget));
  }
  ctx.out << ", " << formatBytes(res.body.size());
  if (std::string technique = res.header(std::string(protocol::headers::kTechnique));
      !technique.empty()) {
    ctx.out << ", technique " << technique;
  }
  ctx.out << "\n";
  return 0;
}

int stream(Context& ctx) {
  const Invocation& inv = ctx.inv;
  const std::string dir = inv.get<std::string>("output");
  const std::optional<uint64_t> wanted = inv.find<uint64_t>("frames");

  std::optional<MultipartReader> reader;
  uint64_t written = 0;
  std::string lastSequence;
  auto onHead = [&](const HttpResponse& head) {
    std::string type = head.header("Content-Type");
    std::optional<std::string> boundary = multipartBoundary(type);
    if (!boundary) {
      throw ApiError("the stream is not multipart (Content-Type \"" + type + "\")", head.status);
    }
    reader.emplace(*boundary);
    makeDirectory(dir);  // only once the server has accepted the stream
    return true;
  };
  auto onData = [&](const char* data, size_t size) {
    for (MultipartPart& part : reader->feed(std::string_view(data, size))) {
      std::string extension =
          part.headers["content-type"] == protocol::kPngContentType ? "png" : "jpg";
      char name[32];
      std::snprintf(name, sizeof name, "frame-%04llu.", static_cast<unsigned long long>(written));
      std::string path = dir + "/" + name + extension;
      writeFile(path, part.body);
      ++written;
      if (ctx.json()) {
        nlohmann::json line = {{"file", path}, {"bytes", part.body.size()},
                               {"contentType", part.headers["content-type"]},
                               {"frame", part.headers["x-myriad-frame"]}};
        ctx.out << line.dump() << std::endl;
      } else {
        ctx.out << path << "  " << formatBytes(part.body.size());
        if (auto seq = part.headers.find("x-myriad-frame"); seq != part.headers.end()) {
          // Without scene changes the server re-sends the last image every 2 s, same number.
          ctx.out << "  frame " << seq->second << (seq->second == lastSequence ? " (re-sent)" : "");
          lastSequence = seq->second;
        }
        ctx.out << std::endl;  // one line per frame as it arrives
      }
      if (wanted && written >= *wanted) return false;
    }
    return !reader->finished();
  };
  ctx.http.stream(ctx.sessionRoute(protocol::routes::kSessionStream), imageQuery(inv), onHead,
                  onData);
  if (wanted && written < *wanted) {
    throw ApiError("the stream ended after " + std::to_string(written) + " of " +
                   std::to_string(*wanted) + " frames");
  }
  if (!ctx.json()) ctx.out << "wrote " << written << " frames to " << dir << "\n";
  return 0;
}

int stats(Context& ctx) {
  nlohmann::json json = ctx.call("GET", ctx.sessionRoute(protocol::routes::kSessionStats));
  if (ctx.json()) return 0;
  auto s = json.get<protocol::Stats>();
  std::vector<std::pair<std::string, std::string>> fields;
  fields.push_back({"frames", std::to_string(s.frames)});
  fields.push_back({"lights", std::to_string(s.lightCount) + (s.lightsAnimated ? " (animated)" : "")});
  if (s.frame) {
    const protocol::FrameStats& f = *s.frame;
    fields.push_back({"last frame", std::to_string(f.width) + "x" + std::to_string(f.height) +
                                        ", " + f.technique + ", target " + f.target});
    fields.push_back({"gpu", formatNumber(f.totalGpuMs) + " ms"});
    for (const auto& pass : f.passes) fields.push_back({"  " + pass.name, formatNumber(pass.ms) + " ms"});
    fields.push_back({"readback", formatNumber(f.readbackMs) + " ms"});
    fields.push_back({"encode", formatNumber(f.encodeMs) + " ms"});
  } else {
    fields.push_back({"last frame", "none yet"});
  }
  if (s.culling) {
    const protocol::CullingStats& c = *s.culling;
    fields.push_back({"light lists", std::to_string(c.listEntries) + " entries, at most " +
                                         std::to_string(c.mostLightsInList) + " lights in one"});
    fields.push_back({"dropped", std::to_string(c.tileLightsDropped + c.clusterLightsDropped) +
                                     " light references"});
  }
  fields.push_back({"gpu memory", "lights " + formatBytes(s.gpuMemory.lightBytes) + ", lists " +
                                      formatBytes(s.gpuMemory.listBytes) + ", scene " +
                                      formatBytes(s.gpuMemory.sceneBytes)});
  printFields(ctx.out, fields);
  return 0;
}

}  // namespace

int runFrameCommand(Context& ctx) {
  const std::string& name = ctx.inv.command->name;
  if (name == "frame") return frame(ctx);
  if (name == "stream") return stream(ctx);
  return stats(ctx);
}

}  // namespace myriad::cli
