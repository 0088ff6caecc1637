// Textures end to end against the real server (lavapipe, validation on): DamagedHelmet as a .glb
// and as a zip of its files, judged pixel by pixel against its own images decoded here; the
// textured boxes; and bad images (missing, 30,000 x 30,000, truncated, too many) answered 422
// naming the problem, the server healthy and its memory bounded; the material API's clear coat,
// sheen, ior and specular factors (refusals, snapshots, and the pixels of the material they edit).
#include <doctest/doctest.h>

#include <png.h>
#include <turbojpeg.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "api_client.h"
#include "encode/png.h"
#include "image_compare.h"
#include "server_process.h"
#include "zip_builder.h"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace myriad::test;

namespace {

const fs::path kAssimpModels = "/usr/share/assimp/models";

void requireListening(const ServerProcess& server) {
  INFO(server.stderrText());
  REQUIRE(server.start() == ServerProcess::Start::Listening);
}

void checkStopsCleanly(ServerProcess& server) {
  std::optional<ExitStatus> status = server.stop();
  REQUIRE(status.has_value());
  INFO(server.stderrText().substr(0, 4000));
  CHECK(status->cleanExit());
}

fs::path helmetDir() {
  const char* env = std::getenv("MYRIAD_TEST_ASSETS");
  return fs::path(env != nullptr ? env : MYRIAD_TEST_ASSETS_DIR) / "DamagedHelmet";
}

bool haveHelmet() {
  if (fs::exists(helmetDir() / "DamagedHelmet.glb")) return true;
  MESSAGE("DamagedHelmet not found under ", helmetDir().string(),
          " (set MYRIAD_TEST_ASSETS or -DMYRIAD_TEST_ASSETS_DIR): skipped");
  return false;
}

std::string readBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  REQUIRE(in);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// An 8-bit RGBA image decoded here, independently of the server's decoder.
struct Texture {
  enum class Wrap { repeat, mirror, clamp };
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;
  Wrap wrapS = Wrap::repeat, wrapT = Wrap::repeat;  // glTF's default sampler repeats

  static int wrap(int i, int size, Wrap mode) {
    switch (mode) {
      case Wrap::clamp: return std::clamp(i, 0, size - 1);
      case Wrap::mirror: {
        const int period = ((i % (2 * size)) + 2 * size) % (2 * size);
        return period < size ? period : 2 * size - 1 - period;
      }
      case Wrap::repeat: break;
    }
    return ((i % size) + size) % size;
  }
  // Channel `c` of texel (x, y), wrapped as the sampler says.
  float texel(int x, int y, int c) const {
    x = wrap(x, width, wrapS);
    y = wrap(y, height, wrapT);
    return rgba[(size_t(y) * width + x) * 4 + c] / 255.0f;
  }
};

Texture decodeJpeg(const std::string& bytes) {
  Texture t;
  tjhandle handle = tjInitDecompress();
  int subsampling = 0, colorspace = 0;
  REQUIRE(tjDecompressHeader3(handle, reinterpret_cast<const unsigned char*>(bytes.data()),
                              bytes.size(), &t.width, &t.height, &subsampling, &colorspace) == 0);
  t.rgba.resize(size_t(t.width) * t.height * 4);
  REQUIRE(tjDecompress2(handle, reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(),
                        t.rgba.data(), t.width, t.width * 4, t.height, TJPF_RGBA,
                        TJFLAG_ACCURATEDCT) == 0);
  tjDestroy(handle);
  return t;
}

Texture decodePng(const std::string& bytes) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  REQUIRE(png_image_begin_read_from_memory(&image, bytes.data(), bytes.size()));
  image.format = PNG_FORMAT_RGBA;
  Texture t;
  t.width = int(image.width);
  t.height = int(image.height);
  t.rgba.resize(size_t(t.width) * t.height * 4);
  REQUIRE(png_image_finish_read(&image, nullptr, t.rgba.data(), 0, nullptr));
  return t;
}

float srgbToLinear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

// A raw frame: N floats per pixel.
struct Raw {
  int width = 0, height = 0, channels = 0;
  std::vector<float> values;
  float at(int x, int y, int c) const { return values[(size_t(y) * width + x) * channels + c]; }
};

Raw rawFrame(ApiClient& api, const TestSession& s, const std::string& target, int width, int height) {
  Reply reply = api.get(s.path() + "/frame?format=raw&target=" + target + "&width=" +
                            std::to_string(width) + "&height=" + std::to_string(height),
                        s.token);
  INFO(target, " ", reply.body.substr(0, 200));
  REQUIRE(reply.status == 200);
  Raw raw;
  raw.width = width;
  raw.height = height;
  const std::string names = reply.header("X-Myriad-Channels");
  raw.channels = int(std::count(names.begin(), names.end(), ',')) + 1;
  REQUIRE(reply.body.size() == size_t(width) * height * raw.channels * 4);
  raw.values.resize(reply.body.size() / 4);
  std::memcpy(raw.values.data(), reply.body.data(), reply.body.size());
  for (float v : raw.values) REQUIRE(std::isfinite(v));
  return raw;
}

// Every texel the bilinear footprint of (u, v) can reach when u and v are known only to within
// `slack` texels (the uv target is half floats: at u near 1, one step is 2^-11, half a texel of a
// 2048 image): the smallest and largest value of channel `c` there, through `convert`.
template <typename Convert>
std::pair<float, float> texelRange(const Texture& t, float u, float v, int c, float slack,
                                   Convert convert) {
  const float x = u * t.width - 0.5f, y = v * t.height - 0.5f;
  const int x0 = int(std::floor(x - slack)), x1 = int(std::floor(x + slack)) + 1;
  const int y0 = int(std::floor(y - slack)), y1 = int(std::floor(y + slack)) + 1;
  float lo = 1e9f, hi = -1e9f;
  for (int ty = y0; ty <= y1; ++ty) {
    for (int tx = x0; tx <= x1; ++tx) {
      const float value = convert(t.texel(tx, ty, c));
      lo = std::min(lo, value);
      hi = std::max(hi, value);
    }
  }
  return {lo, hi};
}

// Texels per pixel at (x, y): the largest uv difference to the four neighbours, in texels
// (infinite at an edge of the surface, so pixels whose derivatives a GPU quad might take across a
// uv seam or off the model are left out).
float texelsPerPixel(const Raw& uv, const Raw& depth, float far, int x, int y, int size) {
  float most = 0.0f;
  const int offsets[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (const auto& o : offsets) {
    const int nx = x + o[0], ny = y + o[1];
    if (nx < 0 || ny < 0 || nx >= uv.width || ny >= uv.height) return INFINITY;
    if (depth.at(nx, ny, 0) >= far) return INFINITY;
    most = std::max({most, std::abs(uv.at(nx, ny, 0) - uv.at(x, y, 0)),
                     std::abs(uv.at(nx, ny, 1) - uv.at(x, y, 1))});
  }
  return most * float(size);
}

TestSession helmetSession(ApiClient& api, const std::string& body, const std::string& filename,
                          const std::string& contentType) {
  TestSession s = createSession(api);
  Reply loaded = api.put(s.path() + "/model?filename=" + filename, body, s.token, contentType);
  INFO(loaded.body.substr(0, 400));
  REQUIRE(loaded.status == 200);
  // Only what the surface itself gives: no sun, no ambient, no environment, no local lights.
  REQUIRE(api.patch(s.path() + "/settings",
                    R"({"sun": {"intensity": 0}, "ambient": [0, 0, 0], "markers": false,
                        "environment": {"mode": "none"}})",
                    s.token)
              .status == 200);
  REQUIRE(api.del(s.path() + "/lights", s.token).status == 204);
  return s;
}

// A close view: from the model's framing eye, a 3-degree field of view centred on the surface
// point where the emission-only picture is brightest (DamagedHelmet's glowing panels, with dark
// metal around them: every kind of texel the checks below need).
json closeUp(ApiClient& api, const TestSession& s);

std::vector<ZipEntry> helmetFiles(const std::string& gltf) {
  const fs::path dir = helmetDir();
  std::vector<ZipEntry> files = {{"DamagedHelmet.gltf", gltf},
                                 {"DamagedHelmet.bin", readBytes(dir / "DamagedHelmet.bin")}};
  for (const char* image : {"Default_albedo.jpg", "Default_metalRoughness.jpg",
                            "Default_emissive.jpg", "Default_AO.jpg", "Default_normal.jpg"}) {
    files.push_back({image, readBytes(dir / image), false, false});
  }
  return files;
}

float quantile(std::vector<float> values, double q) {
  REQUIRE(!values.empty());
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1, size_t(q * double(values.size())))];
}

constexpr int kSize = 200;

json closeUp(ApiClient& api, const TestSession& s) {
  const Raw wide = rawFrame(api, s, "final", 160, 160);
  const Raw position = rawFrame(api, s, "position", 160, 160);
  const Raw depth = rawFrame(api, s, "depth", 160, 160);
  Reply camera = api.get(s.path() + "/camera", s.token);
  REQUIRE(camera.status == 200);
  json c = camera.json;
  const float far = c["far"].get<float>();
  float best = -1.0f;
  int bx = 0, by = 0;
  for (int y = 8; y < 152; ++y) {
    for (int x = 8; x < 152; ++x) {
      if (depth.at(x, y, 0) >= far) continue;
      const float radiance = wide.at(x, y, 0) + wide.at(x, y, 1) + wide.at(x, y, 2);
      if (radiance > best) best = radiance, bx = x, by = y;
    }
  }
  REQUIRE(best > 0.0f);
  for (int i = 0; i < 3; ++i) c["target"][i] = position.at(bx, by, i);
  c["fovY"] = 3.0;
  // The model's framing camera pushes near as far as it can; keep the whole model in range.
  c["near"] = 0.01;
  c["far"] = 20.0;
  REQUIRE(api.put(s.path() + "/camera", c.dump(), s.token).status == 200);
  return c;
}

}  // namespace

TEST_CASE("textures: DamagedHelmet's albedo, emission and normal map, as a .glb and as a zip") {
  if (!haveHelmet()) return;
  ServerProcess server({"--lights", "4"});
  requireListening(server);
  ApiClient api(server);
  const fs::path dir = helmetDir();
  const Texture albedo = decodeJpeg(readBytes(dir / "Default_albedo.jpg"));
  const Texture emissive = decodeJpeg(readBytes(dir / "Default_emissive.jpg"));
  const Texture normalMap = decodeJpeg(readBytes(dir / "Default_normal.jpg"));
  const std::string gltf = readBytes(dir / "DamagedHelmet.gltf");

  for (const bool zipped : {false, true}) {
    CAPTURE(zipped);
    TestSession s = zipped ? helmetSession(api, makeZip(helmetFiles(gltf)), "helmet.zip", "application/zip")
                           : helmetSession(api, readBytes(dir / "DamagedHelmet.glb"), "DamagedHelmet.glb",
                                           "application/octet-stream");
    // The material lists its five textures.
    Reply materials = api.get(s.path() + "/materials", s.token);
    REQUIRE(materials.status == 200);
    const json& textures = materials.json["materials"][0]["textures"];
    CHECK(textures.size() == 5);
    for (const json& t : textures) {
      CHECK(t["width"] == 2048);
      CHECK(t["height"] == 2048);
    }
    CHECK(materials.json["materials"][0]["emissive"] == json::array({1.0, 1.0, 1.0}));
    CHECK(materials.json["materials"][0]["doubleSided"] == false);

    closeUp(api, s);
    const Raw depth = rawFrame(api, s, "depth", kSize, kSize);
    const Raw uv = rawFrame(api, s, "uv", kSize, kSize);
    const Raw gpuAlbedo = rawFrame(api, s, "albedo", kSize, kSize);
    const Raw final = rawFrame(api, s, "final", kSize, kSize);
    const float far = api.get(s.path() + "/camera", s.token).json["far"].get<float>();

    // 1. Albedo = the base-colour image sampled at the uv. Compared where the texture is
    // magnified (under one texel per pixel: the sampler reads level 0 bilinearly, in linear
    // light), each channel within 0.02 of the range of the texels a bilinear lookup at uv +- 1
    // texel reaches (the uv target's half floats are a texel coarse at 2048).
    int compared = 0, outside = 0;
    std::vector<float> errors;
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        if (depth.at(x, y, 0) >= far) continue;
        if (!(texelsPerPixel(uv, depth, far, x, y, albedo.width) < 1.0f)) continue;
        ++compared;
        const float u = uv.at(x, y, 0), v = uv.at(x, y, 1);
        bool inside = true;
        for (int c = 0; c < 3; ++c) {
          const auto [lo, hi] = texelRange(albedo, u, v, c, 1.0f, srgbToLinear);
          const float value = gpuAlbedo.at(x, y, c);
          inside = inside && value >= lo - 0.02f && value <= hi + 0.02f;
          errors.push_back(value < lo ? lo - value : value > hi ? value - hi : 0.0f);
        }
        outside += !inside;
      }
    }
    MESSAGE("albedo: ", compared, " magnified pixels compared, ", outside,
            " outside the texel range + 0.02; 99th percentile distance ", quantile(errors, 0.99));
    CHECK(compared >= 2000);
    CHECK(outside <= compared / 100);  // at most 1% (pixels on uv seams between charts)

    // 2. Emission with every light, sun and ambient off: the final image is > 0 exactly where
    // the emissive image is not black. Judged where the texels around the uv agree (all black, or
    // all at least 0.1 in some channel).
    int glowing = 0, dark = 0, wrong = 0;
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        if (depth.at(x, y, 0) >= far) continue;
        if (!(texelsPerPixel(uv, depth, far, x, y, emissive.width) < 2.0f)) continue;
        const float u = uv.at(x, y, 0), v = uv.at(x, y, 1);
        float brightest = 0.0f, darkest = 1.0f;
        for (int c = 0; c < 3; ++c) {
          const auto [lo, hi] = texelRange(emissive, u, v, c, 2.0f, [](float t) { return t; });
          brightest = std::max(brightest, hi);
          darkest = std::min(darkest, std::max(lo, 0.0f));
        }
        const float radiance = final.at(x, y, 0) + final.at(x, y, 1) + final.at(x, y, 2);
        if (brightest == 0.0f) {
          ++dark;
          wrong += radiance != 0.0f;
        } else {
          float least = 1.0f;  // the dimmest texel's brightest channel, over the window
          const float fx = u * emissive.width - 0.5f, fy = v * emissive.height - 0.5f;
          for (int ty = int(std::floor(fy)) - 2; ty <= int(std::floor(fy)) + 3; ++ty) {
            for (int tx = int(std::floor(fx)) - 2; tx <= int(std::floor(fx)) + 3; ++tx) {
              least = std::min(least, std::max({emissive.texel(tx, ty, 0), emissive.texel(tx, ty, 1),
                                                emissive.texel(tx, ty, 2)}));
            }
          }
          if (least >= 0.1f) {
            ++glowing;
            wrong += !(radiance > 0.0f);
          }
        }
      }
    }
    MESSAGE("emission: ", glowing, " pixels under a lit emissive texel window, ", dark,
            " under an all-black one, ", wrong, " wrong");
    CHECK(glowing >= 100);
    CHECK(dark >= 1000);
    CHECK(wrong == 0);
  }

  // 3. The normal map: the same view with and without the material's normalTexture. Where the
  // map tilts the normal (its texels around the uv all agree within 3 degrees), the mapped normal
  // turns from the unmapped one by the tilt the texel says; where the map is flat, not at all.
  json withoutNormalMap = json::parse(gltf);
  withoutNormalMap["materials"][0].erase("normalTexture");
  TestSession mapped = helmetSession(api, makeZip(helmetFiles(gltf)), "helmet.zip", "application/zip");
  TestSession flat = helmetSession(api, makeZip(helmetFiles(withoutNormalMap.dump())), "flat.zip",
                                   "application/zip");
  const json view = closeUp(api, mapped);
  REQUIRE(api.put(flat.path() + "/camera", view.dump(), flat.token).status == 200);
  const Raw depth = rawFrame(api, mapped, "depth", kSize, kSize);
  const Raw uv = rawFrame(api, mapped, "uv", kSize, kSize);
  const Raw n1 = rawFrame(api, mapped, "normal", kSize, kSize);
  const Raw n0 = rawFrame(api, flat, "normal", kSize, kSize);
  const float far = api.get(mapped.path() + "/camera", mapped.token).json["far"].get<float>();
  // The tilt (degrees from the surface normal) the map gives at (u, v): its texels as vectors
  // (2 t - 1), bilinearly interpolated as the GPU filters them, normalised.
  auto tiltAt = [&](float u, float v) {
    const float fx = u * normalMap.width - 0.5f, fy = v * normalMap.height - 0.5f;
    const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
    const float ax = fx - float(x0), ay = fy - float(y0);
    float n[3] = {0, 0, 0};
    for (int c = 0; c < 3; ++c) {
      const float top = (1 - ax) * normalMap.texel(x0, y0, c) + ax * normalMap.texel(x0 + 1, y0, c);
      const float bottom = (1 - ax) * normalMap.texel(x0, y0 + 1, c) + ax * normalMap.texel(x0 + 1, y0 + 1, c);
      n[c] = ((1 - ay) * top + ay * bottom) * 2 - 1;
    }
    const float length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    return std::acos(std::clamp(n[2] / length, -1.0f, 1.0f)) * 180.0f / float(M_PI);
  };
  // Per magnified pixel: the turn from the unmapped to the mapped normal, and the tilt the image
  // says there. Flat texels must turn nothing; the turn must follow the tilt (correlation), and
  // within 3 degrees at 90% of the pixels (the uv target's half floats, the tangent frame from
  // derivatives, and 8-bit texels set the tolerance).
  std::vector<float> measured, expected, flatTurns, errors;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      if (depth.at(x, y, 0) >= far || n0.at(x, y, 0) == 0.0f) continue;
      if (!(texelsPerPixel(uv, depth, far, x, y, normalMap.width) < 1.0f)) continue;
      float dot = 0.0f;
      for (int c = 0; c < 3; ++c) dot += n1.at(x, y, c) * n0.at(x, y, c);
      const float turn = std::acos(std::clamp(dot, -1.0f, 1.0f)) * 180.0f / float(M_PI);
      const float tilt = tiltAt(uv.at(x, y, 0), uv.at(x, y, 1));
      measured.push_back(turn);
      expected.push_back(tilt);
      errors.push_back(std::abs(turn - tilt));
      if (tilt < 1.0f) flatTurns.push_back(turn);
    }
  }
  REQUIRE(measured.size() >= 1000);
  double mx = 0, my = 0;
  for (size_t i = 0; i < measured.size(); ++i) mx += measured[i], my += expected[i];
  mx /= double(measured.size());
  my /= double(measured.size());
  double sxy = 0, sxx = 0, syy = 0;
  for (size_t i = 0; i < measured.size(); ++i) {
    sxy += (measured[i] - mx) * (expected[i] - my);
    sxx += (measured[i] - mx) * (measured[i] - mx);
    syy += (expected[i] - my) * (expected[i] - my);
  }
  const double correlation = sxy / std::sqrt(sxx * syy);
  const float tiltedShare = float(std::count_if(expected.begin(), expected.end(),
                                                [](float t) { return t > 5.0f; })) /
                            float(expected.size());
  MESSAGE("normal map: ", measured.size(), " magnified pixels, mean turn ", mx, " deg, mean tilt ",
          my, " deg, ", tiltedShare * 100, "% tilted over 5 deg, correlation ", correlation,
          ", 90th percentile |turn - tilt| ", quantile(errors, 0.9), " deg, 90th percentile turn "
          "under flat texels ", flatTurns.empty() ? -1.0f : quantile(flatTurns, 0.9), " deg");
  // Where the image tilts by more than 5 degrees, the normal turns by about as much.
  std::vector<float> tiltedTurns, tiltedTilts;
  for (size_t i = 0; i < measured.size(); ++i) {
    if (expected[i] > 5.0f) tiltedTurns.push_back(measured[i]), tiltedTilts.push_back(expected[i]);
  }
  REQUIRE(tiltedTurns.size() >= 15);
  MESSAGE("normal map: under texels tilted over 5 deg (", tiltedTurns.size(), " pixels) median turn ",
          quantile(tiltedTurns, 0.5), " deg for a median tilt of ", quantile(tiltedTilts, 0.5), " deg");
  CHECK(quantile(tiltedTurns, 0.5) > 0.7f * quantile(tiltedTilts, 0.5));
  CHECK(correlation > 0.5);
  CHECK(quantile(errors, 0.9) < 3.0f);
  REQUIRE(flatTurns.size() >= 100);
  CHECK(quantile(flatTurns, 0.9) < 2.5f);
  CHECK(validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("textures: the textured boxes of assimp's glTF2 models show their texture") {
  const fs::path box = kAssimpModels / "glTF2/BoxTextured-glTF";
  if (!fs::exists(box / "BoxTextured.gltf")) {
    MESSAGE("no BoxTextured under /usr/share/assimp/models (install assimp-testmodels): skipped");
    return;
  }
  ServerProcess server({"--lights", "2"});
  requireListening(server);
  ApiClient api(server);
  const Texture logo = decodePng(readBytes(box / "CesiumLogoFlat.png"));
  // The .gltf with separate files samples it mirrored in S and clamped in T (its sampler says
  // 33648, 33071); the .glb and the embedded .gltf repeat.
  Texture mirroredClamped = logo;
  mirroredClamped.wrapS = Texture::Wrap::mirror;
  mirroredClamped.wrapT = Texture::Wrap::clamp;
  struct Variant {
    std::string name, body, filename, contentType;
  };
  const std::vector<Variant> variants = {
      {"binary", readBytes(kAssimpModels / "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb"), "box.glb",
       "application/octet-stream"},
      {"embedded", readBytes(kAssimpModels / "glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf"),
       "box.gltf", "application/octet-stream"},
      {"separate files",
       makeZip({{"BoxTextured.gltf", readBytes(box / "BoxTextured.gltf")},
                {"BoxTextured0.bin", readBytes(box / "BoxTextured0.bin")},
                {"CesiumLogoFlat.png", readBytes(box / "CesiumLogoFlat.png")}}),
       "box.zip", "application/zip"},
  };
  for (const Variant& variant : variants) {
    CAPTURE(variant.name);
    TestSession s = createSession(api);
    Reply loaded = api.put(s.path() + "/model?filename=" + variant.filename, variant.body, s.token,
                           variant.contentType);
    INFO(loaded.body.substr(0, 300));
    REQUIRE(loaded.status == 200);
    const Raw depth = rawFrame(api, s, "depth", 128, 128);
    const Raw uv = rawFrame(api, s, "uv", 128, 128);
    const Raw albedo = rawFrame(api, s, "albedo", 128, 128);
    const float far = api.get(s.path() + "/camera", s.token).json["far"].get<float>();
    int surface = 0, matching = 0;
    float darkest = 1.0f, brightest = 0.0f;
    const Texture& texture = variant.name == "separate files" ? mirroredClamped : logo;
    for (int y = 0; y < 128; ++y) {
      for (int x = 0; x < 128; ++x) {
        if (depth.at(x, y, 0) >= far) continue;
        // Not across the cube's edges, where the uv jumps from face to face.
        if (!(texelsPerPixel(uv, depth, far, x, y, logo.width) < 6.0f)) continue;
        ++surface;
        bool inside = true;
        for (int c = 0; c < 3; ++c) {
          // Minified here (the whole box in 128 pixels): the mip chain averages up to a few texels.
          const auto [lo, hi] = texelRange(texture, uv.at(x, y, 0), uv.at(x, y, 1), c, 3.0f, srgbToLinear);
          inside = inside && albedo.at(x, y, c) >= lo - 0.03f && albedo.at(x, y, c) <= hi + 0.03f;
        }
        matching += inside;
        const float luminance = albedo.at(x, y, 0) + albedo.at(x, y, 1) + albedo.at(x, y, 2);
        darkest = std::min(darkest, luminance);
        brightest = std::max(brightest, luminance);
      }
    }
    MESSAGE(variant.name, ": ", matching, " of ", surface,
            " surface pixels within the logo's texels around their uv; albedo sum from ", darkest,
            " to ", brightest);
    CHECK(surface >= 1500);
    CHECK(matching >= surface * 95 / 100);
    CHECK(brightest - darkest > 0.5f);  // the logo's dark and light areas, not one flat colour
  }
  CHECK(validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("textures: bad images are 422 naming the problem; the server stays healthy and small") {
  if (!haveHelmet()) return;
  ServerProcess server({"--lights", "2"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  const std::string gltf = readBytes(helmetDir() / "DamagedHelmet.gltf");

  std::vector<ZipEntry> missing, truncated, huge;
  for (const ZipEntry& e : helmetFiles(gltf)) {
    if (e.path != "Default_AO.jpg") missing.push_back(e);
    truncated.push_back(e);
    if (e.path == "Default_normal.jpg") truncated.back().data.resize(e.data.size() / 2);
  }
  // The 30,000 x 30,000 PNG: a valid header, a token of data; the material's albedo points at it.
  json hugeGltf = json::parse(gltf);
  hugeGltf["images"][0]["uri"] = "huge.png";
  huge = helmetFiles(hugeGltf.dump());
  {
    auto crc = [](const std::string& bytes) {
      uint32_t c = 0xFFFFFFFFu;
      for (unsigned char b : bytes) {
        c ^= b;
        for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
      }
      return ~c;
    };
    auto big = [](uint32_t v) {
      return std::string{char(v >> 24), char(v >> 16), char(v >> 8), char(v)};
    };
    auto chunk = [&](const std::string& type, const std::string& data) {
      return big(uint32_t(data.size())) + type + data + big(crc(type + data));
    };
    const std::string png = std::string("\x89PNG\r\n\x1a\n", 8) +
                            chunk("IHDR", big(30000) + big(30000) + std::string("\x08\x06\x00\x00\x00", 5)) +
                            chunk("IDAT", std::string("\x78\x9c\x03\x00\x00\x00\x00\x01", 8)) +
                            chunk("IEND", "");
    huge.push_back({"huge.png", png});
  }
  // 257 images: BoxTextured's box placed 52 times, each with a material of five textures, each
  // texture a 1x1 PNG file of its own.
  const fs::path box = kAssimpModels / "glTF2/BoxTextured-glTF";
  REQUIRE(fs::exists(box / "BoxTextured.gltf"));
  json manyGltf = json::parse(readBytes(box / "BoxTextured.gltf"));
  std::vector<ZipEntry> manyFiles = {{"BoxTextured0.bin", readBytes(box / "BoxTextured0.bin")}};
  {
    const std::vector<uint8_t> pixel = {200, 100, 50, 255};
    const std::vector<uint8_t> encoded = myriad::encode::encodePng(1, 1, pixel);
    const std::string png(encoded.begin(), encoded.end());
    manyGltf["images"] = json::array();
    manyGltf["textures"] = json::array();
    manyGltf["materials"] = json::array();
    const json primitive = manyGltf["meshes"][0]["primitives"][0];
    manyGltf["meshes"] = json::array();
    manyGltf["nodes"] = json::array();
    manyGltf["scenes"][0]["nodes"] = json::array();
    const char* slots[] = {"baseColorTexture", "metallicRoughnessTexture"};
    for (int i = 0; i < 257; ++i) {
      const std::string name = "p" + std::to_string(i) + ".png";
      manyGltf["images"].push_back({{"uri", name}});
      manyGltf["textures"].push_back({{"source", i}});
      manyFiles.push_back({name, png});
    }
    for (int m = 0; m * 5 < 257; ++m) {
      json material = {{"pbrMetallicRoughness", json::object()}};
      for (int k = 0; k < 5 && m * 5 + k < 257; ++k) {
        const json ref = {{"index", m * 5 + k}};
        if (k < 2) material["pbrMetallicRoughness"][slots[k]] = ref;
        if (k == 2) material["normalTexture"] = ref;
        if (k == 3) material["occlusionTexture"] = ref;
        if (k == 4) material["emissiveTexture"] = ref;
      }
      manyGltf["materials"].push_back(material);
      json p = primitive;
      p["material"] = m;
      manyGltf["meshes"].push_back({{"primitives", json::array({p})}});
      manyGltf["nodes"].push_back({{"mesh", m}, {"translation", {2.0 * m, 0.0, 0.0}}});
      manyGltf["scenes"][0]["nodes"].push_back(m);
    }
    manyFiles.push_back({"many.gltf", manyGltf.dump()});
  }

  struct Bad {
    std::string what;
    std::string zip;
    std::string named;
  };
  const std::vector<Bad> bad = {
      {"missing image", makeZip(missing), "'Default_AO.jpg', which is missing"},
      {"truncated JPEG", makeZip(truncated), "'Default_normal.jpg' is corrupt or truncated"},
      {"30000 x 30000 PNG", makeZip(huge), "30000 x 30000 pixels, over the texture dimension limit of 8192"},
      {"257 images", makeZip(manyFiles), "more than 256 images (the image count limit)"},
  };
  const unsigned long long before = server.residentBytes();
  for (const Bad& b : bad) {
    CAPTURE(b.what);
    Reply reply = api.put(s.path() + "/model?filename=bad.zip", b.zip, s.token, "application/zip");
    checkProblem(reply, 422, "model-rejected", b.what);
    CHECK_MESSAGE(reply.json.value("detail", "").find(b.named) != std::string::npos,
                  reply.json.value("detail", ""));
    REQUIRE(api.get("/v1/health").status == 200);
  }
  const unsigned long long after = server.residentBytes();
  const unsigned long long peak = server.peakResidentBytes();
  MESSAGE("server RSS ", before >> 20, " MiB before the bad images, ", after >> 20,
          " MiB after, peak ", peak >> 20, " MiB");
  // The images are decoded (or refused) in the loader child: the server's own memory hardly moves.
  CHECK(after <= before + (64ull << 20));
  // Still a working session: the good zip loads after all of that.
  Reply good = api.put(s.path() + "/model?filename=helmet.zip", makeZip(helmetFiles(gltf)), s.token,
                       "application/zip");
  CHECK(good.status == 200);
  CHECK(validationMessages(api) == 0);
  checkStopsCleanly(server);
}

TEST_CASE("textures: the material API edits the glTF factors and the pictures follow") {
  const fs::path box = kAssimpModels / "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb";
  if (!fs::exists(box)) {
    MESSAGE("no BoxTextured under /usr/share/assimp/models (install assimp-testmodels): skipped");
    return;
  }
  ServerProcess server({"--lights", "2"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = helmetSession(api, readBytes(box), "box.glb", "application/octet-stream");
  Reply list = api.get(s.path() + "/materials", s.token);
  REQUIRE(list.status == 200);
  const json& material = list.json["materials"][0];
  REQUIRE(material["textures"].size() == 1);
  CHECK(material["textures"][0]["slot"] == "baseColor");
  CHECK(material["textures"][0]["width"] == 211);
  CHECK(material["textures"][0]["minFilter"] == "nearest");  // NEAREST_MIPMAP_LINEAR
  CHECK(material["textures"][0]["mipmaps"] == true);
  CHECK(material["doubleSided"] == false);
  const std::string path = s.path() + "/materials/0";

  const Raw depth = rawFrame(api, s, "depth", 64, 64);
  const float far = api.get(s.path() + "/camera", s.token).json["far"].get<float>();
  // The surface's radiance (the background colour elsewhere is not the box's).
  auto sum = [&](const Raw& raw) {
    double total = 0;
    for (int y = 0; y < 64; ++y) {
      for (int x = 0; x < 64; ++x) {
        if (depth.at(x, y, 0) >= far) continue;
        for (int c = 0; c < raw.channels; ++c) total += raw.at(x, y, c);
      }
    }
    return total;
  };
  // With every light off the box is black; an emissive factor makes it glow, its strength scales
  // the glow exactly (emission is factor x strength x texture, and the box has no emissive map).
  CHECK(sum(rawFrame(api, s, "final", 64, 64)) == 0.0);
  Reply glow = api.patch(path, R"({"emissive": [0.5, 0.25, 0.0], "emissiveStrength": 2})", s.token);
  REQUIRE(glow.status == 200);
  CHECK(glow.json["emissiveStrength"] == 2.0);
  const Raw emitted = rawFrame(api, s, "emissive", 64, 64);
  int surface = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      if (depth.at(x, y, 0) >= far) continue;
      ++surface;
      CHECK(emitted.at(x, y, 0) == doctest::Approx(1.0).epsilon(1e-3));
      CHECK(emitted.at(x, y, 1) == doctest::Approx(0.5).epsilon(1e-3));
      CHECK(emitted.at(x, y, 2) == 0.0f);
    }
  }
  CHECK(surface > 500);
  CHECK(sum(rawFrame(api, s, "final", 64, 64)) > 0.0);

  // alphaMode mask with a cutoff above the alpha: every pixel of the box is cut away.
  REQUIRE(api.patch(path, R"({"alphaMode": "mask", "alpha": 0.4, "alphaCutoff": 0.5})", s.token).status == 200);
  const Raw cut = rawFrame(api, s, "depth", 64, 64);
  int left = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) left += cut.at(x, y, 0) < far;
  }
  CHECK(left == 0);
  REQUIRE(api.patch(path, R"({"alphaCutoff": 0.3})", s.token).status == 200);
  const Raw kept = rawFrame(api, s, "depth", 64, 64);
  int back = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) back += kept.at(x, y, 0) < far;
  }
  CHECK(back == surface);

  // Textures stay as loaded; a bad alpha mode is a 400 naming the member.
  checkProblem(api.patch(path, R"({"alphaMode": "OPAQUE"})", s.token), 400, "invalid-body",
               "alphaMode", std::string("/alphaMode"));
  checkProblem(api.patch(path, R"({"textures": []})", s.token), 400, "invalid-body", "textures",
               std::string("/textures"));
  // The snapshot carries the factors and a new session restores them.
  Reply snapshot = api.get(s.path() + "/snapshot", s.token);
  REQUIRE(snapshot.status == 200);
  CHECK(snapshot.json["materials"][0]["emissiveStrength"] == 2.0);
  CHECK(snapshot.json["materials"][0]["alphaMode"] == "mask");
  CHECK(validationMessages(api) == 0);
  checkStopsCleanly(server);
}

namespace {

// GET .../frame as 8-bit RGBA (final; with the session's anti-aliasing none, a pixel is its own
// surface's).
std::vector<uint8_t> finalPixels(ApiClient& api, const TestSession& s, int width, int height) {
  Reply reply = api.get(s.path() + "/frame?format=png&width=" +
                            std::to_string(width) + "&height=" + std::to_string(height),
                        s.token);
  REQUIRE(reply.status == 200);
  return decodePng(reply.body).rgba;
}

// The material-id label per pixel (raw uint32).
std::vector<uint32_t> materialIds(ApiClient& api, const TestSession& s, int width, int height) {
  Reply reply = api.get(s.path() + "/frame?format=raw&target=material-id&width=" +
                            std::to_string(width) + "&height=" + std::to_string(height),
                        s.token);
  REQUIRE(reply.status == 200);
  REQUIRE(reply.header("X-Myriad-Dtype") == "uint32");
  REQUIRE(reply.body.size() == size_t(width) * height * 4);
  std::vector<uint32_t> ids(size_t(width) * height);
  std::memcpy(ids.data(), reply.body.data(), reply.body.size());
  return ids;
}

// Pixels whose R, G or B moved by more than 2/255, inside material `id` and outside it.
struct Changed {
  size_t inside = 0, outside = 0, material = 0;
};
Changed changedPixels(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b,
                      const std::vector<uint32_t>& ids, uint32_t id) {
  REQUIRE(a.size() == b.size());
  REQUIRE(a.size() == ids.size() * 4);
  Changed c;
  for (size_t p = 0; p < ids.size(); ++p) {
    const bool mine = ids[p] == id;
    c.material += mine;
    if (pixelDifference(a, b, p) > 2) ++(mine ? c.inside : c.outside);
  }
  return c;
}

}  // namespace

TEST_CASE("materials: clear coat, sheen, ior and specular: GET, PATCH, refusals, snapshots, pixels") {
  ServerProcess server({"--lights", "8"});
  requireListening(server);
  ApiClient api(server);
  TestSession s = createSession(api);
  REQUIRE(api.patch(s.path() + "/settings", R"({"antialias": "none"})", s.token).status == 200);
  // A light of its own, so that the snapshot lists the lights rather than naming the generator's
  // recipe (a session restored from the built-in scene's recipe gets other lights).
  REQUIRE(api.post(s.path() + "/lights",
                   R"({"lights": [{"position": [6, 1, 4], "radius": 2, "color": [1, 1, 1], "intensity": 1, "falloff": 1}]})",
                   s.token).status == 201);
  const json list = api.get(s.path() + "/materials", s.token).json.at("materials");
  // The built-in scene uses none of the extensions: every material has their defaults.
  auto idNamed = [&](const std::string& name) {
    for (const json& m : list) {
      if (m.at("name") == name) return m.at("id").get<uint32_t>();
    }
    FAIL("no material named ", name);
    return 0u;
  };
  for (const json& m : list) {
    CHECK(m.at("clearcoat") == 0.0);
    CHECK(m.at("clearcoatRoughness") == 0.0);
    CHECK(m.at("sheenColor") == json{0.0, 0.0, 0.0});
    CHECK(m.at("sheenRoughness") == 0.0);
    CHECK(m.at("ior") == 1.5);
    CHECK(m.at("specular") == 1.0);
  }
  const uint32_t rough = idNamed("sphere m0.00 r1.00");   // a rough dielectric, front row
  const uint32_t cloth = idNamed("sphere m0.00 r0.60");
  const uint32_t glossy = idNamed("sphere m0.00 r0.30");
  const std::string roughPath = s.path() + "/materials/" + std::to_string(rough);

  // Refusals: the schema's, naming the member's pointer; the material stays as it was.
  struct Bad {
    std::string body, pointer, detail;
  };
  const std::vector<Bad> bad = {
      {R"({"clearcoat": -0.1})", "/clearcoat", R"("clearcoat" must be at least 0, got -0.1.)"},
      {R"({"clearcoat": 1.5})", "/clearcoat", R"("clearcoat" must be at most 1, got 1.5.)"},
      {R"({"clearcoat": "NaN"})", "/clearcoat", R"("clearcoat" must be a number, got the string "NaN".)"},
      {R"({"clearcoat": null})", "/clearcoat", R"("clearcoat" must be a number, got null.)"},
      {R"({"clearcoat": true})", "/clearcoat", R"("clearcoat" must be a number, got true.)"},
      {R"({"clearcoatRoughness": -0.1})", "/clearcoatRoughness", R"("clearcoatRoughness" must be at least 0, got -0.1.)"},
      {R"({"clearcoatRoughness": 1.5})", "/clearcoatRoughness", R"("clearcoatRoughness" must be at most 1, got 1.5.)"},
      {R"({"clearcoatRoughness": "NaN"})", "/clearcoatRoughness", R"("clearcoatRoughness" must be a number, got the string "NaN".)"},
      {R"({"clearcoatRoughness": null})", "/clearcoatRoughness", R"("clearcoatRoughness" must be a number, got null.)"},
      {R"({"sheenColor": [0.5, 0.5, 1.5]})", "/sheenColor/2", R"("sheenColor/2" must be at most 1, got 1.5.)"},
      {R"({"sheenColor": [-0.1, 0.5, 0.5]})", "/sheenColor/0", R"("sheenColor/0" must be at least 0, got -0.1.)"},
      {R"({"sheenColor": [0.5, "NaN", 0.5]})", "/sheenColor/1", R"("sheenColor/1" must be a number, got the string "NaN".)"},
      {R"({"sheenColor": [0.5, null, 0.5]})", "/sheenColor/1", R"("sheenColor/1" must be a number, got null.)"},
      {R"({"sheenColor": null})", "/sheenColor", R"("sheenColor" must be an array, got null.)"},
      {R"({"sheenColor": 0.5})", "/sheenColor", R"("sheenColor" must be an array, got 0.5.)"},
      {R"({"sheenRoughness": -0.1})", "/sheenRoughness", R"("sheenRoughness" must be at least 0, got -0.1.)"},
      {R"({"sheenRoughness": 1.5})", "/sheenRoughness", R"("sheenRoughness" must be at most 1, got 1.5.)"},
      {R"({"sheenRoughness": "NaN"})", "/sheenRoughness", R"("sheenRoughness" must be a number, got the string "NaN".)"},
      {R"({"sheenRoughness": null})", "/sheenRoughness", R"("sheenRoughness" must be a number, got null.)"},
      {R"({"ior": 0.9})", "/ior", R"("ior" must be at least 1, got 0.9.)"},
      {R"({"ior": 0})", "/ior", R"("ior" must be at least 1, got 0.)"},
      {R"({"ior": 10.5})", "/ior", R"("ior" must be at most 10, got 10.5.)"},
      {R"({"ior": "NaN"})", "/ior", R"("ior" must be a number, got the string "NaN".)"},
      {R"({"ior": null})", "/ior", R"("ior" must be a number, got null.)"},
      {R"({"specular": -0.1})", "/specular", R"("specular" must be at least 0, got -0.1.)"},
      {R"({"specular": 1.5})", "/specular", R"("specular" must be at most 1, got 1.5.)"},
      {R"({"specular": "NaN"})", "/specular", R"("specular" must be a number, got the string "NaN".)"},
      {R"({"specular": null})", "/specular", R"("specular" must be a number, got null.)"},
      {R"({"specular": [1]})", "/specular", R"("specular" must be a number, got an array.)"},
      {R"({"specularColor": [1, 1, 1]})", "/specularColor", ""},  // not read by the renderer
  };
  for (const Bad& b : bad) {
    Reply reply = api.patch(roughPath, b.body, s.token);
    checkProblem(reply, 400, "invalid-body", b.body, b.pointer);
    if (!b.detail.empty()) CHECK(reply.json.value("detail", "") == b.detail);
  }
  CHECK(api.get(s.path() + "/materials", s.token).json.at("materials") == list);

  // Clear coat 0 -> 1 on the rough sphere: only its pixels change (a scene with no coat or sheen
  // until now: the layers target must come on), and back to 0 gives the first frame exactly.
  constexpr int kWidth = 192, kHeight = 108;
  const std::vector<uint32_t> ids = materialIds(api, s, kWidth, kHeight);
  const std::vector<uint8_t> before = finalPixels(api, s, kWidth, kHeight);
  CHECK(finalPixels(api, s, kWidth, kHeight) == before);  // the frame is deterministic
  Reply coated = api.patch(roughPath, R"({"clearcoat": 1})", s.token);
  REQUIRE(coated.status == 200);
  CHECK(coated.json.at("clearcoat") == 1.0);
  CHECK(coated.json.at("clearcoatRoughness") == 0.0);
  CHECK(coated.json.at("roughness") == 1.0);  // the rest as it was
  const Changed coat = changedPixels(before, finalPixels(api, s, kWidth, kHeight), ids, rough);
  MESSAGE("clear coat: ", coat.inside, " of the sphere's ", coat.material, " pixels changed, ",
          coat.outside, " elsewhere");
  CHECK(coat.material > 50);
  CHECK(coat.inside * 4 > coat.material);  // a quarter of the sphere and more
  CHECK(coat.outside == 0);
  REQUIRE(api.patch(roughPath, R"({"clearcoat": 0})", s.token).status == 200);
  CHECK(finalPixels(api, s, kWidth, kHeight) == before);

  // Sheen on a cloth-rough sphere: its rim and lit side change.
  const std::string clothPath = s.path() + "/materials/" + std::to_string(cloth);
  Reply sheened = api.patch(clothPath, R"({"sheenColor": [1, 1, 1], "sheenRoughness": 0.5})", s.token);
  REQUIRE(sheened.status == 200);
  CHECK(sheened.json.at("sheenColor") == json{1.0, 1.0, 1.0});
  const Changed sheen = changedPixels(before, finalPixels(api, s, kWidth, kHeight), ids, cloth);
  MESSAGE("sheen: ", sheen.inside, " of the sphere's ", sheen.material, " pixels changed, ",
          sheen.outside, " elsewhere");
  CHECK(sheen.material > 50);
  CHECK(sheen.inside * 4 > sheen.material);
  CHECK(sheen.outside == 0);
  REQUIRE(api.patch(clothPath, R"({"sheenColor": [0, 0, 0]})", s.token).status == 200);
  CHECK(finalPixels(api, s, kWidth, kHeight) == before);

  // ior 3 (F0 0.25, not 0.04) brightens the glossy sphere's reflections; specular 0 then removes
  // the dielectric's reflection altogether.
  const std::string glossyPath = s.path() + "/materials/" + std::to_string(glossy);
  REQUIRE(api.patch(glossyPath, R"({"ior": 3})", s.token).status == 200);
  const std::vector<uint8_t> ior3 = finalPixels(api, s, kWidth, kHeight);
  const Changed ior = changedPixels(before, ior3, ids, glossy);
  REQUIRE(api.patch(glossyPath, R"({"ior": 1.5, "specular": 0})", s.token).status == 200);
  const Changed specular = changedPixels(before, finalPixels(api, s, kWidth, kHeight), ids, glossy);
  MESSAGE("ior 3: ", ior.inside, " of ", ior.material, " pixels changed (", ior.outside,
          " elsewhere); specular 0: ", specular.inside, " (", specular.outside, " elsewhere)");
  CHECK(ior.inside * 4 > ior.material);
  CHECK(ior.outside == 0);
  CHECK(specular.inside > 0);  // F0 0.04 -> 0: only the highlights move by more than 2/255
  CHECK(specular.outside == 0);
  REQUIRE(api.patch(glossyPath, R"({"specular": 1})", s.token).status == 200);
  CHECK(finalPixels(api, s, kWidth, kHeight) == before);

  // Every member, set at once: GET says them back, the snapshot carries them, a new session from
  // the snapshot has them and draws the same frame.
  Reply all = api.patch(roughPath,
                        R"({"clearcoat": 0.75, "clearcoatRoughness": 0.25, "sheenColor": [0.5, 0.25, 0.125],
                            "sheenRoughness": 0.625, "ior": 1.25, "specular": 0.5})",
                        s.token);
  REQUIRE(all.status == 200);
  CHECK(all.json.at("clearcoat") == 0.75);
  CHECK(all.json.at("clearcoatRoughness") == 0.25);
  CHECK(all.json.at("sheenColor") == json{0.5, 0.25, 0.125});
  CHECK(all.json.at("sheenRoughness") == 0.625);
  CHECK(all.json.at("ior") == 1.25);
  CHECK(all.json.at("specular") == 0.5);
  CHECK(api.get(s.path() + "/materials", s.token).json.at("materials").at(rough) == all.json);
  const std::vector<uint8_t> layered = finalPixels(api, s, kWidth, kHeight);
  Reply snapshot = api.get(s.path() + "/snapshot", s.token);
  REQUIRE(snapshot.status == 200);
  CHECK(snapshot.json.at("materials").at(rough) == all.json);
  Reply created = api.post("/v1/sessions", json{{"snapshot", snapshot.json}}.dump());
  REQUIRE(created.status == 201);
  TestSession copy{created.json.at("id"), created.json.at("token"), created.json};
  CHECK(api.get(copy.path() + "/materials", copy.token).json.at("materials").at(rough) == all.json);
  CHECK(finalPixels(api, copy, kWidth, kHeight) == layered);

  // A snapshot from before these members (without them) restores the model file's values: here
  // the extensions' defaults, and the first frame again.
  json old = snapshot.json;
  for (json& m : old.at("materials")) {
    for (const char* member :
         {"clearcoat", "clearcoatRoughness", "sheenColor", "sheenRoughness", "ior", "specular"}) {
      m.erase(member);
    }
  }
  REQUIRE(api.put(copy.path() + "/snapshot", old.dump(), copy.token).status == 200);
  CHECK(api.get(copy.path() + "/materials", copy.token).json.at("materials") == list);
  CHECK(finalPixels(api, copy, kWidth, kHeight) == before);
  // A bad member in a snapshot is named under its material.
  json wrong = snapshot.json;
  wrong["materials"][rough]["ior"] = 0.5;
  checkProblem(api.put(copy.path() + "/snapshot", wrong.dump(), copy.token), 400, "invalid-body",
               "snapshot ior 0.5", "/materials/" + std::to_string(rough) + "/ior");
  CHECK(validationMessages(api) == 0);
  checkStopsCleanly(server);
}
