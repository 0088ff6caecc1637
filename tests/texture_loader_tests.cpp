// Texture images through the loader: decoding (scene::decodeImage) and its limits, the glTF
// material's textures and factors as the loader child hands them over, and the bad images a model
// can bring (missing, too large, truncated, too many), each refused with the limit or the problem
// named.
#include <doctest/doctest.h>

#include <sys/resource.h>
#include <unistd.h>

#include <array>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <string>

#include "loader/loader.h"
#include "loader_support.h"
#include "scene/image_decode.h"
#include "scene/model_loader.h"
#include "zip_builder.h"

namespace fs = std::filesystem;
using namespace myriad;
using loader::ModelRejected;

namespace {

// DamagedHelmet, read where it lies (never copied into the repository): MYRIAD_TEST_ASSETS or the
// CMake cache's MYRIAD_TEST_ASSETS_DIR.
fs::path helmetDir() {
  const char* env = std::getenv("MYRIAD_TEST_ASSETS");
  return fs::path(env != nullptr ? env : MYRIAD_TEST_ASSETS_DIR) / "DamagedHelmet";
}

bool haveHelmet() {
  if (fs::exists(helmetDir() / "DamagedHelmet.glb") && fs::exists(helmetDir() / "DamagedHelmet.gltf")) {
    return true;
  }
  MESSAGE("DamagedHelmet not found under ", helmetDir().string(),
          " (set MYRIAD_TEST_ASSETS or -DMYRIAD_TEST_ASSETS_DIR): skipped");
  return false;
}

uint32_t crc32(std::string_view bytes) {
  uint32_t crc = 0xFFFFFFFFu;
  for (unsigned char c : bytes) {
    crc ^= c;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

void putBig(std::string& out, uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8) out += char((value >> shift) & 0xFF);
}

std::string chunk(std::string_view type, std::string_view data) {
  std::string out;
  putBig(out, uint32_t(data.size()));
  std::string body(type);
  body += data;
  out += body;
  putBig(out, crc32(body));
  return out;
}

// A PNG whose header says width x height (RGBA8) followed by a token IDAT: valid up to the first
// pixel row, a few dozen bytes whatever the size it claims.
std::string pngClaiming(uint32_t width, uint32_t height) {
  std::string ihdr;
  putBig(ihdr, width);
  putBig(ihdr, height);
  ihdr += std::string("\x08\x06\x00\x00\x00", 5);  // 8-bit RGBA, deflate, no filter, no interlace
  std::string png("\x89PNG\r\n\x1a\n", 8);
  png += chunk("IHDR", ihdr);
  png += chunk("IDAT", std::string("\x78\x9c\x03\x00\x00\x00\x00\x01", 8));
  png += chunk("IEND", "");
  return png;
}

std::string base64(std::string_view bytes) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8) | uint8_t(bytes[i + 2]);
    for (int k = 18; k >= 0; k -= 6) out += table[(v >> k) & 63];
  }
  if (i < bytes.size()) {
    uint32_t v = uint8_t(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= uint8_t(bytes[i + 1]) << 8;
    out += table[(v >> 18) & 63];
    out += table[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? table[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// A glTF of one triangle (embedded buffer) with `materials` materials, material m using the five
// images imageUris[5m .. 5m+4] in its five texture slots (fewer at the end).
std::string triangleGltf(const std::vector<std::string>& imageUris) {
  const float data[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, /* uv */ 0, 0, 1, 0, 0, 1};
  const std::string buffer(reinterpret_cast<const char*>(data), sizeof data);
  const size_t materials = std::max<size_t>(1, (imageUris.size() + 4) / 5);
  std::string images, textures, mats, meshes, nodes, sceneNodes;
  for (size_t i = 0; i < imageUris.size(); ++i) {
    images += std::string(i ? "," : "") + "{\"uri\":\"" + imageUris[i] + "\"}";
    textures += std::string(i ? "," : "") + "{\"source\":" + std::to_string(i) + "}";
  }
  const char* slots[5] = {"\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":%}}",
                          "\"emissiveTexture\":{\"index\":%}", "\"normalTexture\":{\"index\":%}",
                          "\"occlusionTexture\":{\"index\":%}", nullptr};
  for (size_t m = 0; m < materials; ++m) {
    std::string members;
    for (size_t k = 0; k < 4; ++k) {
      const size_t image = 5 * m + k;
      if (image >= imageUris.size()) break;
      std::string slot = slots[k];
      slot.replace(slot.find('%'), 1, std::to_string(image));
      members += (members.empty() ? "" : ",") + slot;
    }
    if (5 * m + 4 < imageUris.size()) {
      // The fifth goes in as metallic-roughness (inside pbrMetallicRoughness with the first).
      const std::string mr = ",\"metallicRoughnessTexture\":{\"index\":" + std::to_string(5 * m + 4) + "}";
      members.insert(members.find("}}") + 1, mr);
    }
    mats += std::string(m ? "," : "") + "{" + members + "}";
    meshes += std::string(m ? "," : "") +
              "{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"material\":" +
              std::to_string(m) + "}]}";
    nodes += std::string(m ? "," : "") + "{\"mesh\":" + std::to_string(m) + "}";
    sceneNodes += std::string(m ? "," : "") + std::to_string(m);
  }
  return "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[" + sceneNodes +
         "]}],\"nodes\":[" + nodes + "],\"meshes\":[" + meshes + "],\"materials\":[" + mats +
         "],\"textures\":[" + textures + "],\"images\":[" + images +
         "],\"buffers\":[{\"byteLength\":60,\"uri\":\"data:application/octet-stream;base64," +
         base64(buffer) +
         "\"}],\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},"
         "{\"buffer\":0,\"byteOffset\":36,\"byteLength\":24}],\"accessors\":["
         "{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
         "\"min\":[0,0,0],\"max\":[1,1,0]},"
         "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC2\"}]}";
}

// Resident memory of this process (kB in /proc/self/status, as bytes).
uint64_t residentBytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.starts_with("VmRSS:")) return std::stoull(line.substr(6)) * 1024;
  }
  return 0;
}

std::string rejection(const std::function<void()>& load, std::string* reason) {
  try {
    load();
  } catch (const ModelRejected& e) {
    *reason = e.reason;
    return e.what();
  }
  *reason = "";
  return "";
}

// A 1x1 RGBA PNG (valid, opaque red), as a data URI.
std::string onePixelPngUri() {
  static const std::string uri = [] {
    // Built with a stored (uncompressed) deflate block: zlib header, one final stored block of the
    // 5 bytes of the single row (filter 0 + RGBA), Adler-32.
    const std::string row("\x00\xff\x00\x00\xff", 5);
    std::string zlib("\x78\x01", 2);
    zlib += std::string("\x01\x05\x00\xfa\xff", 5);
    zlib += row;
    uint32_t a = 1, b = 0;
    for (unsigned char c : row) a = (a + c) % 65521, b = (b + a) % 65521;
    putBig(zlib, (b << 16) | a);
    std::string ihdr;
    putBig(ihdr, 1);
    putBig(ihdr, 1);
    ihdr += std::string("\x08\x06\x00\x00\x00", 5);
    std::string png("\x89PNG\r\n\x1a\n", 8);
    png += chunk("IHDR", ihdr) + chunk("IDAT", zlib) + chunk("IEND", "");
    return "data:image/png;base64," + base64(png);
  }();
  return uri;
}

}  // namespace

TEST_CASE("textures: decodeImage reads PNG and JPEG and checks the header before decoding") {
  const std::string pixel = onePixelPngUri();
  std::string png;
  {
    // Decode our own base64 back (the data URI's payload) through a loaded model instead of by
    // hand: a 1x1 red PNG must come back as one red RGBA8 pixel.
    const std::string gltf = triangleGltf({pixel});
    const scene::Scene scene = loader::loadModelBytes(gltf, "one.gltf");
    REQUIRE(scene.images.size() == 1);
    CHECK(scene.images[0].width == 1);
    CHECK(scene.images[0].height == 1);
    CHECK(scene.images[0].rgba == std::vector<uint8_t>{255, 0, 0, 255});
    REQUIRE(scene.materials.size() == 1);
    CHECK(scene.materials[0].baseColorTexture.image == 0);
  }

  // A 30,000 x 30,000 PNG: refused from its header, without allocating its 3.4 GB.
  const std::string huge = pngClaiming(30000, 30000);
  const uint64_t before = residentBytes();
  try {
    scene::decodeImage(huge, "huge.png", {}, scene::ImageLimits{}.maxDecodedBytes);
    FAIL("a 30000 x 30000 PNG decoded");
  } catch (const scene::ModelLoadError& e) {
    CHECK(e.kind() == scene::ModelLoadError::Kind::tooLarge);
    CHECK(std::string(e.what()).find("30000 x 30000") != std::string::npos);
    CHECK(std::string(e.what()).find("texture dimension limit of 8192") != std::string::npos);
  }
  const uint64_t after = residentBytes();
  MESSAGE("RSS across the 30000 x 30000 PNG: ", before >> 10, " KiB -> ", after >> 10, " KiB");
  CHECK(after <= before + (1u << 20));

  // Within the dimension limit but over what is left of the model's byte budget.
  try {
    scene::decodeImage(pngClaiming(4096, 4096), "big.png", {}, 1u << 20);
    FAIL("a PNG over the byte budget decoded");
  } catch (const scene::ModelLoadError& e) {
    CHECK(e.kind() == scene::ModelLoadError::Kind::tooLarge);
    CHECK(std::string(e.what()).find("decoded image bytes per model") != std::string::npos);
  }
  // None of the formats (a DDS header).
  try {
    scene::decodeImage(std::string("DDS |\x7c\0\0\0\x07\x10\0\0", 12), "bricks.dds", {},
                       1u << 20);
    FAIL("a DDS decoded");
  } catch (const scene::ModelLoadError& e) {
    CHECK(e.kind() == scene::ModelLoadError::Kind::unsupported);
    CHECK(std::string(e.what()).find("bricks.dds") != std::string::npos);
  }

  if (!haveHelmet()) return;
  const std::string jpeg = test::readFile(helmetDir() / "Default_albedo.jpg");
  const scene::Image albedo = scene::decodeImage(jpeg, "albedo", {}, uint64_t(1) << 30);
  CHECK(albedo.width == 2048);
  CHECK(albedo.height == 2048);
  CHECK(albedo.rgba.size() == size_t(2048) * 2048 * 4);
  // A truncated JPEG (the first half): refused, never shown half grey.
  try {
    scene::decodeImage(std::string_view(jpeg).substr(0, jpeg.size() / 2), "half.jpg", {},
                       uint64_t(1) << 30);
    FAIL("a truncated JPEG decoded");
  } catch (const scene::ModelLoadError& e) {
    CHECK(e.kind() == scene::ModelLoadError::Kind::parse);
    CHECK(std::string(e.what()).find("corrupt or truncated") != std::string::npos);
  }
}

TEST_CASE("textures: DamagedHelmet's material and images, as a .glb and as a zip of its files") {
  if (!haveHelmet()) return;
  const fs::path dir = helmetDir();
  auto check = [](const scene::Scene& scene) {
    REQUIRE(scene.materials.size() == 1);
    const scene::Material& m = scene.materials[0];
    REQUIRE(scene.images.size() == 5);
    for (const scene::Image& image : scene.images) {
      CHECK(image.width == 2048);
      CHECK(image.height == 2048);
    }
    for (size_t slot = 0; slot < scene::Material::kTextureSlots; ++slot) {
      CAPTURE(slot);
      CHECK(m.texture(slot).present());
    }
    // Five slots, five different images.
    std::set<uint32_t> distinct;
    for (size_t slot = 0; slot < scene::Material::kTextureSlots; ++slot) distinct.insert(m.texture(slot).image);
    CHECK(distinct.size() == 5);
    CHECK(m.emissive == glm::vec3(1.0f));
    CHECK(m.doubleSided == false);
    CHECK(m.alphaMode == scene::AlphaMode::opaque);
  };
  const scene::Scene glb =
      loader::loadModelBytes(test::readFile(dir / "DamagedHelmet.glb"), "DamagedHelmet.glb");
  check(glb);
  const std::string gltf = test::readFile(dir / "DamagedHelmet.gltf");
  std::vector<test::ZipEntry> entries = {{"helmet/DamagedHelmet.gltf", gltf},
                                         {"helmet/DamagedHelmet.bin", test::readFile(dir / "DamagedHelmet.bin")}};
  for (const char* image : {"Default_albedo.jpg", "Default_metalRoughness.jpg", "Default_emissive.jpg",
                            "Default_AO.jpg", "Default_normal.jpg"}) {
    entries.push_back({std::string("helmet/") + image, test::readFile(dir / image), false, false});
  }
  const scene::Scene zipped = loader::loadModelArchive(test::makeZip(entries), "helmet.zip", "");
  check(zipped);
  // The albedo of the zip is the JPEG on disk, decoded.
  const scene::Image albedo =
      scene::decodeImage(test::readFile(dir / "Default_albedo.jpg"), "albedo", {}, uint64_t(1) << 30);
  CHECK(zipped.images[zipped.materials[0].baseColorTexture.image].rgba == albedo.rgba);
  // From disk as a library model: the .gltf reads the images beside it.
  check(loader::loadModelFile(dir / "DamagedHelmet.gltf"));

  // A missing referenced image: a 422 naming it.
  std::vector<test::ZipEntry> missing;
  for (const test::ZipEntry& e : entries) {
    if (e.path.find("Default_AO") == std::string::npos) missing.push_back(e);
  }
  std::string reason;
  const std::string message = rejection(
      [&] { loader::loadModelArchive(test::makeZip(missing), "helmet.zip", ""); }, &reason);
  CHECK(reason == "parse");
  CHECK_MESSAGE(message.find("Default_AO.jpg") != std::string::npos, message);
  CHECK_MESSAGE(message.find("missing") != std::string::npos, message);

  // A truncated JPEG in the set.
  std::vector<test::ZipEntry> truncated = entries;
  for (test::ZipEntry& e : truncated) {
    if (e.path.find("Default_emissive") != std::string::npos) e.data.resize(e.data.size() / 3);
  }
  const std::string truncation = rejection(
      [&] { loader::loadModelArchive(test::makeZip(truncated), "helmet.zip", ""); }, &reason);
  CHECK(reason == "parse");
  CHECK_MESSAGE(truncation.find("Default_emissive.jpg") != std::string::npos, truncation);
  CHECK_MESSAGE(truncation.find("truncated") != std::string::npos, truncation);
}

namespace {

void putLittle(std::string& out, uint32_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out += char((value >> (8 * i)) & 0xFF);
}

// An uncompressed (type 2) or run-length (type 10) 24-bit TGA of `width` x `height`, rows
// bottom first (the format's default origin); `body` is the pixel data as the file holds it.
std::string tga(uint8_t type, uint32_t width, uint32_t height, std::string_view body) {
  std::string out{char(0), char(0), char(type), 0, 0, 0, 0, 0, 0, 0, 0, 0};
  putLittle(out, width, 2);
  putLittle(out, height, 2);
  out += char(24);
  out += char(0);
  out += body;
  return out;
}

std::vector<uint8_t> rgba(std::initializer_list<std::array<uint8_t, 3>> pixels) {
  std::vector<uint8_t> out;
  for (const auto& p : pixels) out.insert(out.end(), {p[0], p[1], p[2], 255});
  return out;
}

scene::ModelLoadError::Kind refusedKind(std::string_view bytes, std::string* what,
                                        uint64_t budget = 1u << 20) {
  try {
    scene::decodeImage(bytes, "t", {}, budget);
  } catch (const scene::ModelLoadError& e) {
    *what = e.what();
    return e.kind();
  }
  *what = "decoded";
  return scene::ModelLoadError::Kind::empty;
}

}  // namespace

TEST_CASE("textures: TGA, BMP and GIF decode through stb_image, their header checked first; PSD is refused") {
  // TGA, 2 x 2, bottom row first in the file (B, G, R bytes): red green / blue white on screen.
  const std::string rawTga = tga(2, 2, 2, std::string("\xff\0\0\xff\xff\xff" "\0\0\xff\0\xff\0", 12));
  CHECK(scene::decodeImage(rawTga, "raw.tga", {}, 1u << 20).rgba ==
        rgba({{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 255}}));
  // Run-length TGA: one packet repeating a pixel twice.
  const std::string rleTga = tga(10, 2, 1, std::string("\x81\x10\x20\x30", 4));
  CHECK(scene::decodeImage(rleTga, "rle.tga", {}, 1u << 20).rgba ==
        rgba({{0x30, 0x20, 0x10}, {0x30, 0x20, 0x10}}));
  // BMP, 2 x 1, 24 bits: a file header, a BITMAPINFOHEADER, one row padded to 4 bytes.
  std::string bmp = "BM";
  putLittle(bmp, 14 + 40 + 8, 4);
  putLittle(bmp, 0, 4);
  putLittle(bmp, 14 + 40, 4);
  for (uint32_t v : {40u, 2u, 1u}) putLittle(bmp, v, 4);
  putLittle(bmp, 1, 2);
  putLittle(bmp, 24, 2);
  for (int i = 0; i < 6; ++i) putLittle(bmp, 0, 4);
  bmp += std::string("\0\0\xff\xff\0\0\0\0", 8);  // red, blue, padding
  CHECK(scene::decodeImage(bmp, "two.bmp", {}, 1u << 20).rgba == rgba({{255, 0, 0}, {0, 0, 255}}));
  // GIF, 2 x 1, a two-colour table (red, blue), LZW codes clear 0 1 end in 3 bits each.
  const std::string gif("GIF89a\x02\0\x01\0\x80\0\0" "\xff\0\0\0\0\xff"
                        "\x2c\0\0\0\0\x02\0\x01\0\0" "\x02\x02\x44\x0a\0\x3b", 35);
  CHECK(scene::decodeImage(gif, "two.gif", {}, 1u << 20).rgba == rgba({{255, 0, 0}, {0, 0, 255}}));
  // PSD, 2 x 1, RGB, 8 bits, raw planes.
  std::string psd = "8BPS";
  putBig(psd, 0x00010000u);  // version 1, then the first 2 reserved bytes
  putBig(psd, 0);            // 4 more reserved bytes
  psd += std::string("\0\x03", 2);  // channels
  putBig(psd, 1);            // height
  putBig(psd, 2);            // width
  psd += std::string("\0\x08\0\x03", 4);  // depth 8, RGB
  for (int i = 0; i < 3; ++i) putBig(psd, 0);  // colour mode, resources, layers: empty
  psd += std::string("\0\0", 2);             // raw
  psd += std::string("\x0a\x0b" "\x14\x15" "\x1e\x1f", 6);  // R, G, B planes
  // Refused as a format this server does not read (image_decode_stb.cpp says why).
  std::string what;
  CHECK(refusedKind(psd, &what) == scene::ModelLoadError::Kind::unsupported);
  CHECK_MESSAGE(what.find("'t' is none of PNG, JPEG, TGA, BMP and GIF") != std::string::npos, what);

  // A TGA cut short: refused, never decoded with its missing pixels as zeros.
  CHECK(refusedKind(std::string_view(rawTga).substr(0, rawTga.size() - 2), &what) ==
        scene::ModelLoadError::Kind::parse);
  CHECK_MESSAGE(what.find("truncated") != std::string::npos, what);
  // A TGA header claiming 30,000 x 30,000 pixels: the dimension limit, from the header, with
  // nothing allocated; one within the dimensions but over the byte budget: the budget.
  const uint64_t before = residentBytes();
  CHECK(refusedKind(tga(2, 30000, 30000, "\x01\x02\x03"), &what) ==
        scene::ModelLoadError::Kind::tooLarge);
  CHECK_MESSAGE(what.find("texture dimension limit of 8192") != std::string::npos, what);
  CHECK(residentBytes() <= before + (1u << 20));
  CHECK(refusedKind(tga(2, 4096, 4096, "\x01\x02\x03"), &what) ==
        scene::ModelLoadError::Kind::tooLarge);
  CHECK_MESSAGE(what.find("decoded image bytes per model") != std::string::npos, what);

  // The Collada duck's own texture, a 512 x 512 TGA, as Debian ships it.
  const fs::path duckTexture = "/usr/share/assimp/models/Collada/duckCM.tga";
  if (!fs::exists(duckTexture)) return;
  const scene::Image duck =
      scene::decodeImage(test::readFile(duckTexture), "duckCM.tga", {}, uint64_t(1) << 30);
  CHECK(duck.width == 512);
  CHECK(duck.height == 512);
  std::set<uint32_t> colours;
  for (size_t i = 0; i < duck.rgba.size(); i += 4) {
    colours.insert(uint32_t(duck.rgba[i]) << 16 | uint32_t(duck.rgba[i + 1]) << 8 | duck.rgba[i + 2]);
  }
  MESSAGE("duckCM.tga: ", colours.size(), " distinct colours");
  CHECK(colours.size() > 200);  // a colour map of smooth gradients: 403
}

TEST_CASE("textures: the Collada duck and an OBJ with a TGA map arrive textured from the loader child") {
  const fs::path duckFile = "/usr/share/assimp/models/Collada/duck.dae";
  if (fs::exists(duckFile)) {
    const scene::Scene duck = loader::loadModelFile(duckFile);
    REQUIRE(duck.images.size() == 1);
    CHECK(duck.images[0].width == 512);
    CHECK(duck.images[0].name.find("duckCM.tga") != std::string::npos);
    REQUIRE_FALSE(duck.materials.empty());
    CHECK(duck.materials[0].baseColorTexture.image == 0);
  }
  // A quad of an OBJ whose material maps a 2 x 2 TGA, written here (files beside each other, as
  // OBJ users have them).
  const fs::path dir = fs::temp_directory_path() / ("myriad-tga-obj-" + std::to_string(getpid()));
  fs::create_directories(dir);
  {
    std::ofstream(dir / "quad.obj") << "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                       "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl painted\n"
                                       "f 1/1 2/2 3/3 4/4\n";
    std::ofstream(dir / "quad.mtl") << "newmtl painted\nKd 1 1 1\nmap_Kd paint.tga\n";
    std::ofstream(dir / "paint.tga", std::ios::binary)
        << tga(2, 2, 2, std::string("\xff\0\0\xff\xff\xff" "\0\0\xff\0\xff\0", 12));
  }
  const scene::Scene quad = loader::loadModelFile(dir / "quad.obj");
  fs::remove_all(dir);
  REQUIRE(quad.images.size() == 1);
  CHECK(quad.images[0].rgba == rgba({{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 255}}));
  REQUIRE(quad.materials.size() >= 1);
  bool textured = false;
  for (const auto& m : quad.materials) textured = textured || m.baseColorTexture.image == 0;
  CHECK(textured);
  CHECK(test::noChildren());
}

TEST_CASE("textures: a 30,000 x 30,000 PNG and too many images are refused, naming the limit") {
  // The huge PNG in a glTF upload (a data URI): refused in the child from the header alone.
  rusage before{};
  getrusage(RUSAGE_CHILDREN, &before);
  std::string reason;
  const std::string huge = rejection(
      [&] {
        loader::loadModelBytes(triangleGltf({"data:image/png;base64," + base64(pngClaiming(30000, 30000))}),
                               "huge.gltf");
      },
      &reason);
  CHECK(reason == "too-large");
  CHECK_MESSAGE(huge.find("texture dimension limit of 8192") != std::string::npos, huge);
  rusage after{};
  getrusage(RUSAGE_CHILDREN, &after);
  // ru_maxrss of the children is the largest any reaped child reached: unchanged, or small.
  MESSAGE("largest loader child RSS so far: ", after.ru_maxrss / 1024, " MiB");
  if (after.ru_maxrss > before.ru_maxrss) CHECK(after.ru_maxrss < 256 * 1024);

  // 257 images (52 materials of five textures each, on 52 triangles).
  std::vector<std::string> uris(scene::ImageLimits{}.maxImages + 1, onePixelPngUri());
  const std::string many = rejection([&] { loader::loadModelBytes(triangleGltf(uris), "many.gltf"); },
                                     &reason);
  CHECK(reason == "too-large");
  CHECK_MESSAGE(many.find("more than 256 images (the image count limit)") != std::string::npos, many);
  // At the limit it loads.
  uris.pop_back();
  const scene::Scene scene = loader::loadModelBytes(triangleGltf(uris), "enough.gltf");
  CHECK(scene.images.size() == 256);

  // A .gltf upload alone that names a separate image: it cannot carry it.
  const std::string single = rejection(
      [&] { loader::loadModelBytes(triangleGltf({"wood.png"}), "single.gltf"); }, &reason);
  CHECK(reason == "unsupported");
  CHECK_MESSAGE(single.find("'wood.png'") != std::string::npos, single);
  CHECK(test::noChildren());
}

TEST_CASE("textures: KHR_texture_transform and samplers arrive as the file gives them") {
  const fs::path file = test::assimpModels() / "glTF2/textureTransform/TextureTransformTest.gltf";
  if (!fs::exists(file)) {
    MESSAGE("no glTF2/textureTransform under the assimp models: skipped");
    return;
  }
  const scene::Scene scene = loader::loadModelFile(file);
  struct Expected {
    glm::vec2 offset{0.0f};
    float rotation = 0.0f;
    glm::vec2 scale{1.0f};
  };
  // The file's own values (TextureTransformTest.gltf, the materials' baseColorTexture extensions).
  const std::map<std::string, Expected> expected = {
      {"Offset U", {{0.5f, 0.0f}}},        {"Offset V", {{0.0f, 0.5f}}},
      {"Offset UV", {{0.5f, 0.5f}}},       {"Rotation", {{0.0f, 0.0f}, 0.39269908f}},
      {"Scale", {{0.0f, 0.0f}, 0.0f, {1.5f, 1.5f}}},
      {"All", {{-0.2f, -0.1f}, 0.3f, {1.5f, 1.5f}}}, {"Correct", {}}};
  int checked = 0;
  for (const scene::Material& m : scene.materials) {
    auto it = expected.find(m.name);
    if (it == expected.end()) continue;
    CAPTURE(m.name);
    const scene::TextureRef& t = m.baseColorTexture;
    REQUIRE(t.present());
    CHECK(t.offset.x == doctest::Approx(it->second.offset.x).epsilon(1e-4));
    CHECK(t.offset.y == doctest::Approx(it->second.offset.y).epsilon(1e-4));
    CHECK(t.rotation == doctest::Approx(it->second.rotation).epsilon(1e-4));
    CHECK(t.scale.x == doctest::Approx(it->second.scale.x).epsilon(1e-4));
    CHECK(t.scale.y == doctest::Approx(it->second.scale.y).epsilon(1e-4));
    ++checked;
    // Textures 0 and 1 have the file's one sampler (clamp to edge both ways, linear without
    // mipmaps); "Correct"'s texture has none: the defaults (repeat, linear, mipmapped).
    if (m.name == "Correct") {
      CHECK(t.sampler == scene::Sampler{});
      continue;
    }
    CHECK(t.sampler.wrapS == scene::Sampler::Wrap::clampToEdge);
    CHECK(t.sampler.wrapT == scene::Sampler::Wrap::clampToEdge);
    CHECK(t.sampler.magFilter == scene::Sampler::Filter::linear);
    CHECK(t.sampler.minFilter == scene::Sampler::Filter::linear);
    CHECK(!t.sampler.mipmaps);
  }
  CHECK(checked == 7);
}

namespace {

// Two triangles whose materials use extensions Assimp 5.2.5 does not read: the loader reads them
// from the file. The first node draws the file's second material, so Assimp meets the materials
// in the other order (it orders them as met); one material is unnamed.
std::string extensionsGltf() {
  const std::string pixel = onePixelPngUri();
  std::string gltf = triangleGltf({pixel, pixel, pixel, pixel, pixel});
  auto replace = [&](const std::string& from, const std::string& to) {
    const size_t at = gltf.find(from);
    REQUIRE(at != std::string::npos);
    gltf.replace(at, from.size(), to);
  };
  auto transform = [](const char* offset, const char* rotation, const char* scale,
                      const char* texCoord = "") {
    return std::string(",\"extensions\":{\"KHR_texture_transform\":{\"offset\":") + offset +
           ",\"rotation\":" + rotation + ",\"scale\":" + scale + texCoord + "}}";
  };
  // Every slot of the textured material gets its own transform.
  replace("\"baseColorTexture\":{\"index\":0}",
          "\"baseColorTexture\":{\"index\":0" + transform("[0.5,0.25]", "0.5", "[2,2]") + "}");
  replace("\"emissiveTexture\":{\"index\":1}",
          "\"emissiveTexture\":{\"index\":1" + transform("[0.1,0.2]", "0", "[3,0.5]") + "}");
  replace("\"normalTexture\":{\"index\":2}",
          "\"normalTexture\":{\"index\":2" + transform("[0,0.75]", "-1", "[1.5,1.5]") + "}");
  replace("\"occlusionTexture\":{\"index\":3}",
          "\"occlusionTexture\":{\"index\":3" + transform("[0.3,0]", "0.25", "[1,1]") + "}");
  replace("\"metallicRoughnessTexture\":{\"index\":4}",
          "\"metallicRoughnessTexture\":{\"index\":4" +
              transform("[0,0]", "0", "[4,4]", ",\"texCoord\":1") + "}");
  replace("{\"pbrMetallicRoughness\":",
          "{\"name\":\"textured\",\"emissiveFactor\":[1,0.5,0.25],\"extensions\":{"
          "\"KHR_materials_emissive_strength\":{\"emissiveStrength\":5},"
          "\"KHR_materials_sheen\":{\"sheenColorFactor\":[1,0.5,0.25],\"sheenRoughnessFactor\":0.25,"
          "\"sheenColorTexture\":{\"index\":0}},"
          "\"KHR_materials_clearcoat\":{\"clearcoatFactor\":0.5,\"clearcoatRoughnessFactor\":0.3},"
          "\"KHR_materials_transmission\":{\"transmissionFactor\":1},"
          "\"KHR_materials_ior\":{\"ior\":1.8},\"KHR_materials_specular\":{\"specularFactor\":0.5}},"
          "\"pbrMetallicRoughness\":");
  // A second, unnamed and unlit material on a second mesh, drawn by the first node.
  replace("\"materials\":[{", "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":"
          "[0.2,0.4,0.6,1]},\"extensions\":{\"KHR_materials_unlit\":{}}},{");
  replace("\"material\":0}]}", "\"material\":1}]},{\"primitives\":[{\"attributes\":"
          "{\"POSITION\":0,\"TEXCOORD_0\":1},\"material\":0}]}");
  replace("\"nodes\":[{\"mesh\":0}]", "\"nodes\":[{\"mesh\":0},{\"mesh\":1,\"translation\":[2,0,0]}]");
  replace("\"scenes\":[{\"nodes\":[0]}]", "\"scenes\":[{\"nodes\":[0,1]}]");
  replace("{\"asset\":{\"version\":\"2.0\"},",
          "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_materials_sheen\","
          "\"KHR_materials_clearcoat\",\"KHR_materials_transmission\","
          "\"KHR_materials_emissive_strength\",\"KHR_texture_transform\",\"KHR_materials_unlit\","
          "\"EXT_made_up\"],");
  return gltf;
}

}  // namespace

TEST_CASE("textures: glTF material extensions Assimp does not read arrive from the file") {
  const scene::Scene scene = loader::loadModelBytes(extensionsGltf(), "extensions.gltf");
  REQUIRE(scene.materials.size() == 2);
  const scene::Material* textured = nullptr;
  const scene::Material* unlit = nullptr;
  for (const scene::Material& m : scene.materials) (m.name == "textured" ? textured : unlit) = &m;
  REQUIRE(textured != nullptr);
  REQUIRE(unlit != nullptr);
  // KHR_materials_emissive_strength.
  CHECK(textured->emissiveStrength == 5.0f);
  CHECK(textured->emissive == glm::vec3(1.0f, 0.5f, 0.25f));
  CHECK(!textured->unlit);
  // KHR_materials_ior and KHR_materials_specular's factor (not listed in extensionsUsed: read anyway).
  CHECK(textured->ior == 1.8f);
  CHECK(textured->specular == 0.5f);
  CHECK(unlit->ior == 1.5f);
  CHECK(unlit->specular == 1.0f);
  // KHR_materials_clearcoat's and _sheen's factors (their textures are named as ignored, below).
  CHECK(textured->clearcoat == 0.5f);
  CHECK(textured->clearcoatRoughness == doctest::Approx(0.3f));
  CHECK(textured->sheenColor == glm::vec3(1.0f, 0.5f, 0.25f));
  CHECK(textured->sheenRoughness == 0.25f);
  CHECK(textured->layered());
  CHECK(unlit->clearcoat == 0.0f);
  CHECK(unlit->sheenColor == glm::vec3(0.0f));
  CHECK(!unlit->layered());
  // KHR_materials_unlit, on the unnamed material (its factors tell it apart).
  CHECK(unlit->unlit);
  CHECK(unlit->emissiveStrength == 1.0f);
  CHECK(unlit->baseColor.b == doctest::Approx(0.6f));
  // KHR_texture_transform on every slot, each its own (a texCoord of 1 is sampled with set 0: the
  // only one vertices carry).
  struct Expected {
    const scene::TextureRef& ref;
    glm::vec2 offset;
    float rotation;
    glm::vec2 scale;
  };
  const Expected expected[] = {
      {textured->baseColorTexture, {0.5f, 0.25f}, 0.5f, {2.0f, 2.0f}},
      {textured->emissiveTexture, {0.1f, 0.2f}, 0.0f, {3.0f, 0.5f}},
      {textured->normalTexture, {0.0f, 0.75f}, -1.0f, {1.5f, 1.5f}},
      {textured->occlusionTexture, {0.3f, 0.0f}, 0.25f, {1.0f, 1.0f}},
      {textured->metallicRoughnessTexture, {0.0f, 0.0f}, 0.0f, {4.0f, 4.0f}},
  };
  for (const Expected& e : expected) {
    REQUIRE(e.ref.present());
    CHECK(e.ref.offset.x == doctest::Approx(e.offset.x));
    CHECK(e.ref.offset.y == doctest::Approx(e.offset.y));
    CHECK(e.ref.rotation == doctest::Approx(e.rotation));
    CHECK(e.ref.scale.x == doctest::Approx(e.scale.x));
    CHECK(e.ref.scale.y == doctest::Approx(e.scale.y));
    CHECK(e.ref.texCoord == 0);
  }
  // What the file uses and Myriad does not honour, by name, sorted: whole extensions, and the
  // part of an honoured one that is not read (a sheen colour texture).
  CHECK(scene.ignoredExtensions ==
        std::vector<std::string>{"EXT_made_up", "KHR_materials_sheen (sheenColorTexture)",
                                 "KHR_materials_transmission"});
  // In this process too (the child's scene went over the wire).
  const scene::Scene local = scene::loadModelFromMemory(extensionsGltf(), "extensions.gltf");
  CHECK(local.ignoredExtensions == scene.ignoredExtensions);
  CHECK(test::noChildren());
}
