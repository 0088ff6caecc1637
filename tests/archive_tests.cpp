// Uploads of several files through the loader child: zip archives and file sets (multipart) load
// exactly what the library loads from the same files on disk, and every hostile archive is refused
// with a reason and a sentence naming the problem, under the limits of loader/archive.h.
#include <doctest/doctest.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "loader/archive.h"
#include "loader/loader.h"
#include "loader_support.h"
#include "zip_builder.h"

namespace fs = std::filesystem;
using namespace myriad;
using loader::ModelRejected;
using test::makeZip;
using test::readFile;
using test::requireSameScene;
using test::ZipEntry;

namespace {

const fs::path kModels = test::assimpModels();

// DamagedHelmet as .glb and as .gltf + .bin + images, where the machine has it.
fs::path helmetDirectory() {
  for (const char* candidate : {"../shared/assets/DamagedHelmet", "../../shared/assets/DamagedHelmet",
                                "/work/shared/assets/DamagedHelmet"}) {
    if (fs::exists(fs::path(candidate) / "DamagedHelmet.gltf")) return candidate;
  }
  return {};
}

// The files of `directory` named, as zip entries under `folder`.
std::vector<ZipEntry> entriesOf(const fs::path& directory, const std::vector<std::string>& names,
                                const std::string& folder = "") {
  std::vector<ZipEntry> entries;
  for (const std::string& name : names) entries.push_back({folder + name, readFile(directory / name)});
  return entries;
}

struct Refusal {
  std::string reason;
  std::string sentence;
};

Refusal refusalOf(const std::string& zip, const std::string& entry = "",
                  const loader::LoadLimits& limits = {}) {
  try {
    loader::loadModelArchive(zip, "upload.zip", entry, limits);
  } catch (const ModelRejected& e) {
    return {e.reason, e.what()};
  }
  FAIL("the archive loaded");
  return {};
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

const std::string kTriangleObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

}  // namespace

TEST_CASE("archive: a zip of a model and its files loads what the library loads from disk") {
  struct Case {
    fs::path directory;
    std::vector<std::string> files;  // the model first
  };
  const std::vector<Case> cases = {
      {kModels / "OBJ", {"spider.obj", "spider.mtl", "SpiderTex.jpg", "drkwood2.jpg", "engineflare1.jpg",
                             "wal67ar_small.jpg", "wal69ar_small.jpg"}},
      {kModels / "glTF2/BoxTextured-glTF", {"BoxTextured.gltf", "BoxTextured0.bin", "CesiumLogoFlat.png"}},
  };
  for (const Case& c : cases) {
    if (!fs::exists(c.directory / c.files.front())) continue;
    CAPTURE(c.files.front());
    const scene::Scene fromDisk = loader::loadModelFile(c.directory / c.files.front());
    // In a folder of the archive, the model found without naming it.
    const std::string zip = makeZip(entriesOf(c.directory, c.files, "model/"));
    requireSameScene(loader::loadModelArchive(zip, "model.zip", ""), fromDisk);
    // Named by its entry, too.
    requireSameScene(loader::loadModelArchive(zip, "model.zip", "model/" + c.files.front()), fromDisk);
    // And as a set of files (a multipart upload).
    scene::MemoryFiles files;
    for (const std::string& name : c.files) files.emplace(name, readFile(c.directory / name));
    requireSameScene(loader::loadModelFiles(files, ""), fromDisk);
  }
}

TEST_CASE("archive: DamagedHelmet as .gltf + .bin + images in a zip equals the .glb") {
  const fs::path helmet = helmetDirectory();
  if (helmet.empty()) {
    MESSAGE("DamagedHelmet not found beside the checkout: skipped");
    return;
  }
  const std::string zip = makeZip(entriesOf(
      helmet, {"DamagedHelmet.gltf", "DamagedHelmet.bin", "Default_AO.jpg", "Default_albedo.jpg",
               "Default_emissive.jpg", "Default_metalRoughness.jpg", "Default_normal.jpg"}));
  const scene::Scene fromZip = loader::loadModelArchive(zip, "helmet.zip", "");
  const scene::Scene fromGlb =
      loader::loadModelBytes(readFile(helmet / "DamagedHelmet.glb"), "DamagedHelmet.glb");
  requireSameScene(fromZip, fromGlb);
  CHECK(fromZip.meshes.size() == 1);
}

TEST_CASE("archive: a model that refers to a file the upload lacks is refused naming the file") {
  const fs::path box = kModels / "glTF2/BoxTextured-glTF";
  if (!fs::exists(box)) return;
  const Refusal missing = refusalOf(makeZip(entriesOf(box, {"BoxTextured.gltf"})));
  CHECK(missing.reason == "parse");
  CHECK(contains(missing.sentence, "BoxTextured0.bin"));

  const auto withBufferUri = [&box](const std::string& uri) {
    std::string gltf = readFile(box / "BoxTextured.gltf");
    const size_t at = gltf.find("BoxTextured0.bin");
    REQUIRE(at != std::string::npos);
    gltf.replace(at, std::string("BoxTextured0.bin").size(), uri);
    return gltf;
  };
  const std::string bin = readFile(box / "BoxTextured0.bin");
  const std::string png = readFile(box / "CesiumLogoFlat.png");
  // A buffer that reaches out of the archive with "..", or names an absolute path, finds nothing,
  // even where that file exists on the server. (Assimp then tries the bare file name beside the
  // model, which is inside the upload; the archive here has no such file.)
  for (const std::string& uri : std::vector<std::string>{"../BoxTextured0.bin", "/etc/passwd", "../../../../etc/passwd",
                                (box / "BoxTextured0.bin").string()}) {
    CAPTURE(uri);
    const Refusal escape =
        refusalOf(makeZip({{"BoxTextured.gltf", withBufferUri(uri)}, {"data/BoxTextured0.bin", bin}}));
    CHECK(escape.reason == "parse");
  }
  // ".." that stays inside the upload is an ordinary relative path.
  const scene::Scene inside = loader::loadModelArchive(
      makeZip({{"inner/BoxTextured.gltf", withBufferUri("../data/BoxTextured0.bin")},
               {"data/BoxTextured0.bin", bin}, {"inner/CesiumLogoFlat.png", png}}),
      "box.zip", "");
  CHECK(inside.meshes.size() == 1);
}

TEST_CASE("archive: hostile entries are refused with the entry named") {
  struct Case {
    std::vector<ZipEntry> entries;
    std::string reason;
    std::string named;
  };
  const std::vector<Case> cases = {
      {{{"../evil.obj", kTriangleObj}}, "unsupported", "'../evil.obj'"},
      {{{"a/../../evil.obj", kTriangleObj}}, "unsupported", "leaves the archive"},
      {{{"/etc/evil.obj", kTriangleObj}}, "unsupported", "'/etc/evil.obj'"},
      {{{"C:\\evil.obj", kTriangleObj}}, "unsupported", "absolute path"},
      {{{"model.obj", kTriangleObj}, {"link.mtl", "/etc/passwd", true}}, "unsupported", "symbolic link"},
      {{{"model.obj", kTriangleObj}, {"sub/../model.obj", kTriangleObj}}, "unsupported", "twice"},
      {{{"a.obj", kTriangleObj}, {"b.obj", kTriangleObj}}, "unsupported", "name one with the entry parameter"},
      {{{"readme.txt", "hello"}}, "unsupported", "none of its 1 files is a model format"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.entries.front().path);
    const Refusal refusal = refusalOf(makeZip(c.entries));
    CHECK(refusal.reason == c.reason);
    CHECK_MESSAGE(contains(refusal.sentence, c.named), refusal.sentence);
  }
  // A named entry the archive lacks.
  const Refusal noEntry = refusalOf(makeZip({{"a.obj", kTriangleObj}}), "b.obj");
  CHECK(noEntry.reason == "unsupported");
  CHECK(contains(noEntry.sentence, "'b.obj'"));
  // Not a zip at all.
  CHECK(refusalOf("PK\x03\x04 but not really a zip archive").reason == "parse");
}

TEST_CASE("archive: limits on entries, bytes and compression ratio are refused naming the limit") {
  loader::LoadLimits limits;
  limits.archive.maxEntries = 3;
  std::vector<ZipEntry> many = {{"model.obj", kTriangleObj}};
  for (int i = 0; i < 3; ++i) many.push_back({"extra" + std::to_string(i) + ".txt", "x"});
  Refusal refusal = refusalOf(makeZip(many), "", limits);
  CHECK(refusal.reason == "too-large");
  CHECK(contains(refusal.sentence, "maxArchiveEntries"));

  limits = {};
  limits.archive.maxBytes = 1 << 20;
  refusal = refusalOf(makeZip({{"model.obj", kTriangleObj}, {"big.bin", std::string(2 << 20, 'x'), false, false}}),
                      "", limits);
  CHECK(refusal.reason == "too-large");
  CHECK(contains(refusal.sentence, "maxArchiveBytes"));

  // A deflate bomb: 256 MiB of zeros in about 250 KiB. Refused from the directory, before any
  // byte is inflated, with the default limits.
  const std::string bomb = makeZip({{"model.obj", std::string(256u << 20, '\0')}});
  CHECK(bomb.size() < (1u << 20));
  refusal = refusalOf(bomb);
  CHECK(refusal.reason == "too-large");
  CHECK(contains(refusal.sentence, "maxCompressionRatio"));
}

TEST_CASE("archive: the file set wire format is checked like an archive") {
  const loader::ArchiveLimits limits;
  scene::MemoryFiles files = {{"model.obj", kTriangleObj}, {"textures/a.png", "png"}};
  const std::string wire = loader::encodeFileSet(files);
  CHECK(loader::decodeFileSet(wire, "set", limits) == files);
  // Every truncation, and a trailing byte, is a parse error; never a crash or an over-read.
  for (size_t size = 0; size < wire.size(); ++size) {
    CAPTURE(size);
    CHECK_THROWS_AS(loader::decodeFileSet(wire.substr(0, size), "set", limits), scene::ModelLoadError);
  }
  CHECK_THROWS_AS(loader::decodeFileSet(wire + "x", "set", limits), scene::ModelLoadError);
  // A path that leaves the set.
  CHECK_THROWS_AS(loader::decodeFileSet(loader::encodeFileSet({{"../x.obj", kTriangleObj}}), "set", limits),
                  scene::ModelLoadError);
}

TEST_CASE("archive: member paths are normalized within the upload; lookups fall back to ASCII case") {
  CHECK(scene::normalizeMemberPath("a/b.png") == "a/b.png");
  CHECK(scene::normalizeMemberPath("./a//b.png") == "a/b.png");
  CHECK(scene::normalizeMemberPath("a\\textures\\b.png") == "a/textures/b.png");
  CHECK(scene::normalizeMemberPath("a/../b.png") == "b.png");
  for (const char* bad : {"", "/", "/a.png", "\\a.png", "../a.png", "a/../../b.png", "C:/a.png",
                          "c:\\a.png", ".", "a/..", "a\nb.png"}) {
    CAPTURE(bad);
    CHECK_FALSE(scene::normalizeMemberPath(bad).has_value());
  }
  const scene::MemoryFiles files = {{"tex/Wood.PNG", "1"}, {"model.obj", "2"}, {"A.bin", "3"}, {"a.bin", "4"}};
  std::string found;
  REQUIRE(scene::findMember(files, "tex/wood.png", &found) != nullptr);
  CHECK(found == "tex/Wood.PNG");
  CHECK(*scene::findMember(files, "./model.obj") == "2");
  CHECK(*scene::findMember(files, "a.bin") == "4");        // exact match first
  CHECK(scene::findMember(files, "A.BIN") == nullptr);     // two case-insensitive matches: none
  CHECK(scene::findMember(files, "../model.obj") == nullptr);
  CHECK(scene::modelEntryOf(files, "", "upload") == "model.obj");
}

// fuzz_upload_files (tests/fuzz) found: "./::::" normalized to "::::", which a second
// normalization refused as a drive path; so the server accepted a multipart filename such as
// "./C:/model.obj" that the loader child then refused. The input replayed, then the rule.
TEST_CASE("archive: fuzz regression: a normalized member path normalizes to itself") {
  const std::string input = std::string(".\\./") + std::string(49, ':') + "./\xd8)";
  CHECK_FALSE(scene::normalizeMemberPath(input).has_value());  // it was "::::.../\xd8)"
  const std::optional<std::string> kept = scene::normalizeMemberPath("./a/./b:/../c.obj");
  REQUIRE(kept == "a/c.obj");
  CHECK(scene::normalizeMemberPath(*kept) == kept);
  for (const char* drive : {"./C:/a.obj", "x/../C:/a.obj", ".\\c:\\a.obj"}) {
    CAPTURE(drive);
    CHECK_FALSE(scene::normalizeMemberPath(drive).has_value());
  }
  CHECK(scene::normalizeMemberPath("a/C:/b.obj") == "a/C:/b.obj");  // a ':' further in is a name
  CHECK_THROWS_AS(loader::decodeFileSet(loader::encodeFileSet({{"C:/a.obj", kTriangleObj}}), "set",
                                        loader::ArchiveLimits{}),
                  scene::ModelLoadError);
}
