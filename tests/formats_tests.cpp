// Frames as data (issue 32): format=png16, npy, exr and npz, multi-target frames, ?compression=
// and ?precision=, against the real myriad-server with validation layers on. Every format is
// decoded by a reader of its own (libpng, OpenEXR's InputFile, numpy through
// tests/formats_numpy_check.py, and a zip reader) and compared bit for bit with the raw frames of
// the same session state. The unit cases at the top need no server.
#include <doctest/doctest.h>

#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfMatrixAttribute.h>
#include <ImfStringAttribute.h>
#include <ImathBox.h>
#include <half.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "encode/arrays.h"
#include "encode/png.h"
#include "render/frame.h"
#include "server_process.h"
#include "service/frame_arrays.h"
#include "service/problem.h"

using myriad::test::ApiClient;
using myriad::test::checkProblem;
using myriad::test::createSession;
using myriad::test::Reply;
using myriad::test::ServerProcess;
using myriad::test::TestSession;
using myriad::test::validationMessages;
using nlohmann::json;
namespace fs = std::filesystem;
namespace encode = myriad::encode;
namespace render = myriad::render;
namespace service = myriad::service;

namespace {

constexpr int kWidth = 96;
constexpr int kHeight = 64;

// Every target, by the name the protocol gives it.
const std::vector<std::string> kAllTargets = {
    "final",       "albedo",    "normal",   "position",   "uv",          "metallic",
    "roughness",   "depth",     "light-volumes", "light-count", "clusters", "emissive",
    "occlusion",   "instance-id", "semantic-id", "material-id"};

bool isId(const std::string& t) { return t.size() > 3 && t.substr(t.size() - 3) == "-id"; }

// A parsed .npy: its header's descr and shape, and its data.
struct Npy {
  std::string descr;
  std::vector<size_t> shape;
  std::string data;
};

Npy parseNpy(const std::string& bytes) {
  REQUIRE(bytes.size() >= 10);
  REQUIRE(bytes.compare(0, 6, "\x93NUMPY") == 0);
  REQUIRE(bytes[6] == 1);
  REQUIRE(bytes[7] == 0);
  const size_t length = uint8_t(bytes[8]) | size_t(uint8_t(bytes[9])) << 8;
  REQUIRE((10 + length) % 64 == 0);  // data aligned, as numpy writes it
  const std::string header = bytes.substr(10, length);
  Npy npy;
  std::smatch m;
  REQUIRE(std::regex_search(header, m, std::regex("'descr': '([^']+)'")));
  npy.descr = m[1];
  CHECK(header.find("'fortran_order': False") != std::string::npos);
  REQUIRE(std::regex_search(header, m, std::regex("'shape': \\(([0-9, ]*)\\)")));
  const std::string dims = m[1];
  const std::regex number("[0-9]+");
  for (std::sregex_iterator it(dims.begin(), dims.end(), number), end; it != end; ++it) {
    npy.shape.push_back(std::stoull(it->str()));
  }
  npy.data = bytes.substr(10 + length);
  return npy;
}

std::string channelsOf(const Reply& raw) { return raw.header("X-Myriad-Channels"); }

size_t channelCount(const Reply& raw) {
  const std::string c = channelsOf(raw);
  return size_t(std::count(c.begin(), c.end(), ',')) + 1;
}

Reply getOk(ApiClient& api, const std::string& path, const std::string& token) {
  Reply r = api.get(path, token);
  INFO(path, " -> ", r.status, " ", r.body.substr(0, 300));
  REQUIRE(r.status == 200);
  return r;
}

fs::path tempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("myriad-formats-" + name + "-" +
                                                   std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void writeFile(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), std::streamsize(bytes.size()));
  REQUIRE(out.good());
}

// numpy itself (python3-numpy) reading what the test wrote: 0 when its checks pass.
int runNumpyCheck(const fs::path& dir) {
  const std::string command = std::string(MYRIAD_PYTHON) + " " + MYRIAD_FORMATS_NUMPY_CHECK + " " +
                              dir.string() + " 2>&1";
  return std::system(command.c_str());
}

// An EXR read back with OpenEXR's own reader: channel name -> (pixel type, values as uint32
// bits for UINT and float for FLOAT and HALF), and the header.
struct ExrChannelValues {
  Imf::PixelType type;
  std::vector<float> floats;
  std::vector<uint32_t> uints;
};
struct ExrRead {
  int width = 0, height = 0;
  std::map<std::string, ExrChannelValues> channels;
  Imf::Header header;
};

ExrRead readExr(const std::string& bytes) {
  const fs::path path = fs::temp_directory_path() / ("myriad-formats-" + std::to_string(::getpid()) + ".exr");
  writeFile(path, bytes);
  ExrRead out;
  {
    Imf::InputFile file(path.c_str());
    out.header = file.header();
    const Imath::Box2i window = file.header().dataWindow();
    out.width = window.max.x - window.min.x + 1;
    out.height = window.max.y - window.min.y + 1;
    Imf::FrameBuffer buffer;
    for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it) {
      ExrChannelValues& v = out.channels[it.name()];
      v.type = it.channel().type;
      const size_t n = size_t(out.width) * out.height;
      if (v.type == Imf::UINT) {
        v.uints.resize(n);
        buffer.insert(it.name(), Imf::Slice(Imf::UINT, reinterpret_cast<char*>(v.uints.data()), 4,
                                            4 * size_t(out.width)));
      } else {
        // HALF is converted to float by the library, exactly (every half is a float).
        v.floats.resize(n);
        buffer.insert(it.name(), Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(v.floats.data()), 4,
                                            4 * size_t(out.width)));
      }
    }
    file.setFrameBuffer(buffer);
    file.readPixels(window.min.y, window.max.y);
  }
  fs::remove(path);
  return out;
}

float rawFloat(const std::string& raw, size_t index) {
  float v;
  std::memcpy(&v, raw.data() + index * 4, 4);
  return v;
}

uint32_t rawUint(const std::string& raw, size_t index) {
  uint32_t v;
  std::memcpy(&v, raw.data() + index * 4, 4);
  return v;
}

// A scene worth looking at from every target: the built-in one with a few of its objects given
// semantic classes (so semantic-id is not all zero).
TestSession sceneSession(ApiClient& api) {
  TestSession s = createSession(api);
  Reply objects = api.get(s.path() + "/objects", s.token);
  REQUIRE(objects.status == 200);
  int semantic = 3;
  for (const json& o : objects.json.at("objects")) {
    Reply r = api.patch(s.path() + "/objects/" + std::to_string(o.at("id").get<uint64_t>()),
                        json{{"semantic", semantic}}.dump(), s.token);
    REQUIRE(r.status == 200);
    semantic += 1000;
  }
  return s;
}

}  // namespace

TEST_CASE("formats unit: npy headers, a stored zip of them, and ids past 16 bits") {
  encode::Array a{"depth", encode::Dtype::F4, {2, 3}, {"Z"}, std::vector<uint8_t>(24)};
  for (size_t i = 0; i < 6; ++i) {
    const float v = float(i) * 0.5f;
    std::memcpy(&a.bytes[i * 4], &v, 4);
  }
  const Npy npy = parseNpy(encode::writeNpy(a));
  CHECK(npy.descr == "<f4");
  CHECK(npy.shape == std::vector<size_t>{2, 3});
  CHECK(npy.data == std::string(reinterpret_cast<const char*>(a.bytes.data()), 24));
  encode::Array k{"K", encode::Dtype::F8, {3, 3}, {}, std::vector<uint8_t>(72, 1)};
  const std::vector<encode::Array> arrays{a, k};
  const auto members = encode::readZip(encode::writeNpz(arrays));
  REQUIRE(members.size() == 2);
  CHECK(members[0].first == "depth.npy");
  CHECK(members[1].first == "K.npy");
  CHECK(parseNpy(members[1].second).descr == "<f8");
  encode::Array wrong = a;
  wrong.bytes.pop_back();
  CHECK_THROWS_AS(encode::writeNpy(wrong), std::invalid_argument);

  // An id above 65535 is never wrapped into a 16-bit PNG: 422 naming format, with the id.
  render::Frame frame;
  frame.width = 2;
  frame.height = 1;
  frame.data.assign(8, 0.0f);
  frame.data[0] = std::bit_cast<float>(uint32_t(65535));
  frame.data[4] = std::bit_cast<float>(uint32_t(70000));
  service::FrameRequest request;
  request.settings.target = render::Target::InstanceId;
  request.targets = {render::Target::InstanceId};
  request.format = service::ImageFormat::Png16;
  try {
    (void)service::labelsAsUint16(frame, request, render::Target::InstanceId);
    FAIL("no problem for id 70000");
  } catch (const service::ProblemError& e) {
    CHECK(e.problem().status == 422);
    CHECK(e.problem().parameter == "format");
    CHECK(e.problem().detail.find("70000") != std::string::npos);
    CHECK(e.problem().detail.find("(1, 0)") != std::string::npos);
  }
  frame.data[4] = std::bit_cast<float>(uint32_t(65535));
  CHECK(service::labelsAsUint16(frame, request, render::Target::InstanceId) ==
        std::vector<uint16_t>{65535, 65535});
}

TEST_CASE("formats: npy of every target equals its raw frame; png16 depth and ids; PNG choices") {
  ServerProcess server({"--lights", "16"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  const TestSession s = sceneSession(api);
  const std::string size = "&width=" + std::to_string(kWidth) + "&height=" + std::to_string(kHeight);
  const size_t pixels = size_t(kWidth) * kHeight;
  const fs::path dir = tempDir("npy");

  for (const std::string& target : kAllTargets) {
    CAPTURE(target);
    const Reply npyReply = getOk(api, s.path() + "/frame?format=npy&target=" + target + size, s.token);
    CHECK(npyReply.header("Content-Type") == "application/x-npy");
    CHECK(npyReply.header("X-Myriad-Target") == target);
    CHECK(!npyReply.header("X-Myriad-Intrinsics").empty());
    CHECK(!npyReply.header("X-Myriad-Pose").empty());
    CHECK(!npyReply.header("X-Myriad-Version").empty());
    CHECK(!npyReply.header("X-Myriad-Time").empty());
    const Npy npy = parseNpy(npyReply.body);
    writeFile(dir / (target + ".npy"), npyReply.body);
    if (target == "final") {
      // The 8-bit sRGB picture: the PNG's pixels without alpha.
      CHECK(npy.descr == "|u1");
      CHECK(npy.shape == std::vector<size_t>{size_t(kHeight), size_t(kWidth), 3});
      const Reply png = getOk(api, s.path() + "/frame?format=png&target=final" + size, s.token);
      writeFile(dir / "final.png", png.body);
      const encode::DecodedImage decoded = encode::decodePng(
          {reinterpret_cast<const uint8_t*>(png.body.data()), png.body.size()});
      REQUIRE(npy.data.size() == pixels * 3);
      size_t differing = 0;
      for (size_t i = 0; i < pixels; ++i) {
        differing += std::memcmp(&npy.data[i * 3], &decoded.rgba[i * 4], 3) != 0;
      }
      CHECK(differing == 0);
      continue;
    }
    const Reply raw = getOk(api, s.path() + "/frame?format=raw&target=" + target + size, s.token);
    writeFile(dir / (target + ".raw"), raw.body);
    const size_t channels = channelCount(raw);
    CHECK(npy.descr == (isId(target) ? "<u4" : "<f4"));
    CHECK(npy.shape == (channels == 1 ? std::vector<size_t>{size_t(kHeight), size_t(kWidth)}
                                      : std::vector<size_t>{size_t(kHeight), size_t(kWidth), channels}));
    CHECK(npy.data.size() == raw.body.size());
    CHECK(npy.data == raw.body);  // bit for bit
  }
  // Some ids are not zero, so the comparison above compared something.
  {
    const Reply raw = getOk(api, s.path() + "/frame?format=raw&target=semantic-id" + size, s.token);
    size_t labelled = 0;
    for (size_t i = 0; i < pixels; ++i) labelled += rawUint(raw.body, i) != 0;
    CHECK(labelled > pixels / 10);
  }
  // numpy's own reader agrees: every .npy equals its .raw (numpy.load vs numpy.frombuffer).
  CHECK(runNumpyCheck(dir) == 0);

  // png16: depth in millimetres (the built-in camera's far plane is within 65.535 m) or far/65535,
  // 0 where no surface is; ids as they are.
  {
    const Reply png = getOk(api, s.path() + "/frame?format=png16&target=depth" + size, s.token);
    const Reply raw = getOk(api, s.path() + "/frame?format=raw&target=depth" + size, s.token);
    const double scale = std::stod(png.header("X-Myriad-Depth-Scale"));
    const json intrinsics = json::parse(raw.header("X-Myriad-Intrinsics"));
    const double far = intrinsics.at("far").get<double>();
    CHECK(scale == doctest::Approx(far <= 65.535 ? 0.001 : far / 65535.0));
    uint32_t w = 0, h = 0;
    encode::PngText text;
    const std::vector<uint16_t> values = encode::decodePngGrey16(
        {reinterpret_cast<const uint8_t*>(png.body.data()), png.body.size()}, w, h, &text);
    REQUIRE(w == uint32_t(kWidth));
    REQUIRE(h == uint32_t(kHeight));
    REQUIRE(!text.empty());
    CHECK(text[0].first == "DepthScale");
    size_t surfaces = 0;
    for (size_t i = 0; i < pixels; ++i) {
      const float z = rawFloat(raw.body, i);
      if (z >= float(far)) {
        CHECK(values[i] == 0);
        continue;
      }
      ++surfaces;
      CHECK(values[i] == uint16_t(std::lround(double(z) / scale)));
    }
    CHECK(surfaces > pixels / 2);
  }
  for (const std::string target : {"instance-id", "semantic-id", "material-id"}) {
    CAPTURE(target);
    const Reply png = getOk(api, s.path() + "/frame?format=png16&target=" + target + size, s.token);
    const Reply raw = getOk(api, s.path() + "/frame?format=raw&target=" + target + size, s.token);
    uint32_t w = 0, h = 0;
    const std::vector<uint16_t> values = encode::decodePngGrey16(
        {reinterpret_cast<const uint8_t*>(png.body.data()), png.body.size()}, w, h);
    size_t differing = 0;
    for (size_t i = 0; i < pixels; ++i) differing += values[i] != rawUint(raw.body, i);
    CHECK(differing == 0);
  }

  // ?compression=: every choice decodes to the same pixels, smaller as it costs more.
  {
    std::vector<size_t> sizes;
    std::vector<uint8_t> reference;
    for (const std::string c : {"none", "fast", "small"}) {
      const Reply png = getOk(api, s.path() + "/frame?format=png&compression=" + c + size, s.token);
      const encode::DecodedImage decoded = encode::decodePng(
          {reinterpret_cast<const uint8_t*>(png.body.data()), png.body.size()});
      if (reference.empty()) reference = decoded.rgba;
      CHECK(decoded.rgba == reference);
      sizes.push_back(png.body.size());
    }
    CHECK(sizes[0] > sizes[1]);
    CHECK(sizes[1] > sizes[2]);
    // The default is `fast`: the same bytes.
    const Reply plain = getOk(api, s.path() + "/frame?format=png" + size, s.token);
    CHECK(plain.body.size() == sizes[1]);
  }
  fs::remove_all(dir);
  CHECK(validationMessages(api) == 0);
}

TEST_CASE("formats: one multi-target frame as npz and exr equals the single frames") {
  ServerProcess server({"--lights", "16"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  const TestSession s = sceneSession(api);
  const std::string size = "&width=" + std::to_string(kWidth) + "&height=" + std::to_string(kHeight);
  const size_t pixels = size_t(kWidth) * kHeight;
  const std::vector<std::string> targets = {"final", "depth",       "normal",      "instance-id",
                                            "uv",    "semantic-id", "light-count", "material-id"};
  std::string list;
  for (const std::string& t : targets) list += (list.empty() ? "" : ",") + t;

  std::map<std::string, Reply> singles;
  for (const std::string& t : targets) {
    singles[t] = getOk(api, s.path() + "/frame?format=" + std::string(t == "final" ? "png" : "raw") +
                                "&target=" + t + size, s.token);
  }

  // npz: one request, one render, every target.
  const Reply npz = getOk(api, s.path() + "/frame?format=npz&target=" + list + size, s.token);
  CHECK(npz.header("Content-Type") == "application/zip");
  CHECK(npz.header("X-Myriad-Targets") == list);
  CHECK(npz.header("X-Myriad-Intrinsics") == singles["depth"].header("X-Myriad-Intrinsics"));
  CHECK(npz.header("X-Myriad-Pose") == singles["depth"].header("X-Myriad-Pose"));
  CHECK(!npz.header("X-Myriad-Time").empty());
  CHECK(!npz.header("X-Myriad-Version").empty());
  // One render: the frame's passes are timed once (a single gbuffer pass), plus the extra views.
  const std::string timing = npz.header("Server-Timing");
  CHECK(timing.find("extra-targets") != std::string::npos);
  CHECK(timing.find("gbuffer") == timing.rfind("gbuffer"));
  const auto members = encode::readZip(npz.body);
  std::map<std::string, std::string> byName(members.begin(), members.end());
  CHECK(members.size() == targets.size() + 2);
  const fs::path dir = tempDir("npz");
  writeFile(dir / "frame.npz", npz.body);
  for (const std::string& t : targets) {
    CAPTURE(t);
    REQUIRE(byName.contains(t + ".npy"));
    const Npy npy = parseNpy(byName[t + ".npy"]);
    if (t == "final") {
      writeFile(dir / "final.png", singles[t].body);
      const encode::DecodedImage decoded = encode::decodePng(
          {reinterpret_cast<const uint8_t*>(singles[t].body.data()), singles[t].body.size()});
      size_t differing = 0;
      for (size_t i = 0; i < pixels; ++i) {
        differing += std::memcmp(&npy.data[i * 3], &decoded.rgba[i * 4], 3) != 0;
      }
      CHECK(npy.descr == "|u1");
      CHECK(differing == 0);
    } else {
      writeFile(dir / (t + ".raw"), singles[t].body);
      CHECK(npy.data == singles[t].body);  // bit for bit, from the one render
    }
  }
  // K and world_from_camera as the headers say.
  {
    const Npy k = parseNpy(byName["K.npy"]);
    CHECK(k.descr == "<f8");
    CHECK(k.shape == std::vector<size_t>{3, 3});
    double values[9];
    std::memcpy(values, k.data.data(), sizeof values);
    const json intrinsics = json::parse(npz.header("X-Myriad-Intrinsics"));
    CHECK(values[0] == doctest::Approx(intrinsics.at("fx").get<double>()));
    CHECK(values[2] == doctest::Approx(intrinsics.at("cx").get<double>()));
    CHECK(values[4] == doctest::Approx(intrinsics.at("fy").get<double>()));
    CHECK(values[5] == doctest::Approx(intrinsics.at("cy").get<double>()));
    CHECK(values[8] == 1.0);
    const Npy pose = parseNpy(byName["world_from_camera.npy"]);
    CHECK(pose.shape == std::vector<size_t>{4, 4});
    double m[16];
    std::memcpy(m, pose.data.data(), sizeof m);
    const json rows = json::parse(npz.header("X-Myriad-Pose")).at("worldFromCamera");
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) CHECK(m[r * 4 + c] == doctest::Approx(rows[r][c].get<double>()));
    }
    std::ofstream(dir / "headers.json") << json{{"intrinsics", intrinsics}, {"pose", rows}}.dump();
  }
  // numpy.load(io.BytesIO(body))["depth"] works, and equals the raw frames.
  CHECK(runNumpyCheck(dir) == 0);
  fs::remove_all(dir);

  // depth=distance and space=camera apply to a multi-target frame as to a raw one.
  {
    const Reply both = getOk(api, s.path() + "/frame?format=npz&target=depth,normal&depth=distance&space=camera" + size, s.token);
    const auto m = encode::readZip(both.body);
    const Reply depth = getOk(api, s.path() + "/frame?format=raw&target=depth&depth=distance" + size, s.token);
    const Reply normal = getOk(api, s.path() + "/frame?format=raw&target=normal&space=camera" + size, s.token);
    CHECK(parseNpy(m[0].second).data == depth.body);
    CHECK(parseNpy(m[1].second).data == normal.body);
    CHECK(both.header("X-Myriad-Depth") == "distance");
    CHECK(both.header("X-Myriad-Space") == "camera");
  }

  // exr: the same targets as named layers; final is linear HDR radiance there (raw final).
  {
    const Reply rawFinal = getOk(api, s.path() + "/frame?format=raw&target=final" + size, s.token);
    const Reply exr = getOk(api, s.path() + "/frame?format=exr&target=" + list + size, s.token);
    CHECK(exr.header("Content-Type") == "image/x-exr");
    const ExrRead read = readExr(exr.body);
    CHECK(read.width == kWidth);
    CHECK(read.height == kHeight);
    const std::map<std::string, std::vector<std::string>> names = {
        {"final", {"R", "G", "B"}}, {"depth", {"Z"}}, {"normal", {"X", "Y", "Z"}},
        {"instance-id", {"id"}}, {"uv", {"U", "V"}}, {"semantic-id", {"id"}},
        {"light-count", {"Y"}}, {"material-id", {"id"}}};
    size_t channelsSeen = 0;
    for (const auto& [target, channels] : names) {
      CAPTURE(target);
      const std::string& raw = target == "final" ? rawFinal.body : singles[target].body;
      for (size_t c = 0; c < channels.size(); ++c) {
        const std::string name = target + "." + channels[c];
        CAPTURE(name);
        REQUIRE(read.channels.contains(name));
        const ExrChannelValues& v = read.channels.at(name);
        ++channelsSeen;
        size_t differing = 0;
        if (isId(target)) {
          CHECK(v.type == Imf::UINT);
          for (size_t i = 0; i < pixels; ++i) differing += v.uints[i] != rawUint(raw, i);
        } else {
          CHECK(v.type == Imf::FLOAT);
          for (size_t i = 0; i < pixels; ++i) {
            differing += std::bit_cast<uint32_t>(v.floats[i]) !=
                         std::bit_cast<uint32_t>(rawFloat(raw, i * channels.size() + c));
          }
        }
        CHECK(differing == 0);
      }
    }
    CHECK(read.channels.size() == channelsSeen);
    const auto* k = read.header.findTypedAttribute<Imf::M33dAttribute>("K");
    REQUIRE(k != nullptr);
    const json intrinsics = json::parse(exr.header("X-Myriad-Intrinsics"));
    CHECK(k->value()[0][0] == doctest::Approx(intrinsics.at("fx").get<double>()));
    CHECK(k->value()[1][2] == doctest::Approx(intrinsics.at("cy").get<double>()));
    REQUIRE(read.header.findTypedAttribute<Imf::M44dAttribute>("worldFromCamera") != nullptr);
    REQUIRE(read.header.findTypedAttribute<Imf::DoubleAttribute>("far") != nullptr);
    CHECK(read.header.findTypedAttribute<Imf::DoubleAttribute>("far")->value() ==
          doctest::Approx(intrinsics.at("far").get<double>()));
    const auto* version = read.header.findTypedAttribute<Imf::StringAttribute>("myriadVersion");
    REQUIRE(version != nullptr);
    CHECK(version->value() == exr.header("X-Myriad-Version"));

    // precision=half: HALF channels holding each float rounded to half.
    const Reply halfExr = getOk(api, s.path() + "/frame?format=exr&precision=half&target=depth,normal" + size, s.token);
    const ExrRead halves = readExr(halfExr.body);
    REQUIRE(halves.channels.contains("depth.Z"));
    CHECK(halves.channels.at("depth.Z").type == Imf::HALF);
    size_t differing = 0;
    for (size_t i = 0; i < pixels; ++i) {
      differing += halves.channels.at("normal.Y").floats[i] !=
                   float(half(rawFloat(singles["normal"].body, i * 3 + 1)));
    }
    CHECK(differing == 0);
    CHECK(halfExr.body.size() < exr.body.size());
  }
  CHECK(validationMessages(api) == 0);
}

TEST_CASE("formats: bad target lists, formats, compression and precision are 400s naming them") {
  ServerProcess server({"--lights", "4", "--max-resolution", "2048"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  const TestSession s = createSession(api);
  const std::string frame = s.path() + "/frame?";
  std::string many;
  for (int i = 0; i < 64; ++i) many += (i ? "," : "") + std::string("depth");
  struct Case {
    std::string query, parameter, says;
  };
  const std::vector<Case> cases = {
      {"format=npz&target=final,depth,bogus", "target", "bogus"},
      {"format=npz&target=" + many, "target", "maxFrameTargets"},
      {"format=npz&target=depth,normal,depth", "target", "more than once"},
      {"format=npz&target=final,light-volumes", "target", "light-volumes"},
      {"format=png&target=final,depth", "format", "npz"},
      {"format=jpeg&target=final,depth", "format", "npz"},
      {"format=raw&target=depth,normal", "format", "npz"},
      {"format=png16&target=normal", "format", "png16"},
      {"format=png&compression=99", "compression", "none, fast, small"},
      {"format=exr&target=depth&precision=quad", "precision", "float or half"},
      {"format=exr&target=depth&width=100000&height=24", "width", "2048"},
      {"format=npz&target=depth,normal&width=32&height=9999999999", "height", "2048"},
      {"format=tiff", "format", "npz"},
      {"format=npy&target=final&depth=distance", "depth", "target=depth"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.query);
    const bool sized = c.query.find("width=") != std::string::npos ||
                       c.query.find("height=") != std::string::npos;
    const Reply r = api.get(frame + c.query + (sized ? "" : "&width=32&height=24"), s.token);
    checkProblem(r, 400, "invalid-parameter", c.query, std::nullopt, std::nullopt, c.parameter);
    CHECK(r.json.value("detail", "").find(c.says) != std::string::npos);
  }
  // GET /v1/info states the limit.
  const Reply info = api.get("/v1/info");
  REQUIRE(info.status == 200);
  CHECK(info.json.at("limits").at("maxFrameTargets") == 8);
  CHECK(validationMessages(api) == 0);
}

TEST_CASE("formats: a 1920x1080 npz of 8 targets stays within its memory reservation") {
  ServerProcess server({"--lights", "16"});
  REQUIRE(server.start() == ServerProcess::Start::Listening);
  ApiClient api(server);
  api.raw().set_read_timeout(600, 0);
  const TestSession s = createSession(api);
  const std::string list = "final,depth,normal,albedo,uv,instance-id,semantic-id,material-id";
  const uint64_t before = server.residentBytes();
  const auto start = std::chrono::steady_clock::now();
  const Reply npz = getOk(api, s.path() + "/frame?format=npz&width=1920&height=1080&target=" + list, s.token);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const uint64_t peak = server.peakResidentBytes();
  const auto members = encode::readZip(npz.body);
  CHECK(members.size() == 10);
  // The reservation (api_frames.cpp reserveFrame): 56 B/px for the 8-bit final, 112 for each of
  // the 7 others, + the fixed part.
  const double pixels = 1920.0 * 1080.0;
  const double reserved = pixels * (56 + 7 * 112);
  const double used = double(peak) - double(before);
  MESSAGE("1920x1080 npz of 8 targets: ", npz.body.size() / 1e6, " MB body in ", seconds,
          " s; server RSS ", before / 1048576.0, " MiB before, peak ", peak / 1048576.0,
          " MiB (+", used / 1048576.0, " MiB = ", used / pixels, " B/px; reserved ",
          reserved / 1048576.0, " MiB = ", reserved / pixels, " B/px)");
  CHECK(used < reserved);
  CHECK(validationMessages(api) == 0);
}
