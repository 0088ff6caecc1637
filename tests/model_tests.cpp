// Every OBJ and glTF 2.0 model shipped with Assimp's test set (good, odd and deliberately broken),
// each through a real server: it either serves a frame, or refuses at start-up with one line naming
// the file. A crash, a hang or a garbled refusal fails.
#include <doctest/doctest.h>
#include <httplib.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/png.h"
#include "server_process.h"

namespace fs = std::filesystem;
using myriad::test::ExitStatus;
using myriad::test::ServerProcess;

namespace {

std::vector<fs::path> testModels() {
  std::vector<fs::path> models;
  for (const char* root : {"/usr/share/assimp/models/OBJ", "/usr/share/assimp/models/glTF2"}) {
    if (!fs::is_directory(root)) continue;
    for (const fs::directory_entry& entry : fs::recursive_directory_iterator(root)) {
      if (!entry.is_regular_file()) continue;
      std::string ext = entry.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
      if (ext == ".obj" || ext == ".gltf" || ext == ".glb") models.push_back(entry.path());
    }
  }
  std::sort(models.begin(), models.end());
  return models;
}

std::vector<std::string> nonEmptyLines(const std::string& text) {
  std::vector<std::string> lines;
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    if (end > start) lines.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return lines;
}

}  // namespace

TEST_CASE("models: every Assimp test model is served or cleanly refused") {
  const std::vector<fs::path> models = testModels();
  if (models.empty()) {
    MESSAGE("no models under /usr/share/assimp/models (install assimp-testmodels); skipped");
    return;
  }

  int served = 0, refused = 0, failed = 0, withValidationMessages = 0;
  for (const fs::path& model : models) {
    const std::string name = model.filename().string();
    CAPTURE(model.string());
    bool ok = false;
    // Start-up includes Vulkan with validation on lavapipe and the parse of the model.
    ServerProcess server({"--model", model.string(), "--lights", "16"}, std::chrono::seconds(180));
    const std::string log = server.stderrText();
    CAPTURE(log);

    switch (server.start()) {
      case ServerProcess::Start::Listening: {
        httplib::Client client(server.host(), server.port());
        client.set_read_timeout(180, 0);
        httplib::Result res = client.Get("/v1/frame?width=160&height=120");
        bool frameOk = false;
        if (res && res->status == 200) {
          auto image = myriad::encode::decodePng(
              {reinterpret_cast<const uint8_t*>(res->body.data()), res->body.size()});
          frameOk = image.width == 160 && image.height == 120;
        }
        CHECK_MESSAGE(frameOk, "no 160x120 frame; status ", res ? res->status : -1);
        uint32_t validationMessages = 0;
        if (httplib::Result info = client.Get("/v1/info"); info && info->status == 200) {
          validationMessages = nlohmann::json::parse(info->body)["validation"]["messages"];
        }
        CHECK(validationMessages == 0);
        if (validationMessages != 0) ++withValidationMessages;
        std::optional<ExitStatus> status = server.stop(std::chrono::seconds(60));
        CHECK_MESSAGE(status.has_value(), "did not exit after SIGTERM");
        if (status) CHECK(status->describe() == "exit 0");
        if (frameOk) ++served;
        ok = frameOk && validationMessages == 0 && status && status->cleanExit();
        break;
      }
      case ServerProcess::Start::Exited: {
        std::optional<ExitStatus> status = server.waitForExit(std::chrono::seconds(1));
        REQUIRE(status.has_value());
        const std::vector<std::string> lines = nonEmptyLines(server.stderrText());
        CHECK_MESSAGE(status->exited, "crashed: ", status->describe());
        CHECK(status->code != 0);
        CHECK_MESSAGE(lines.size() == 1, "want one line on stderr");
        const bool namesFile = !lines.empty() && lines.back().find(name) != std::string::npos;
        CHECK_MESSAGE(namesFile, "the message does not name ", name);
        ok = status->exited && status->code != 0 && lines.size() == 1 && namesFile;
        if (ok) {
          ++refused;
          MESSAGE("refused: ", lines.back());
        }
        break;
      }
      case ServerProcess::Start::TimedOut:
        FAIL_CHECK("hung: no URL and no exit within the start-up timeout");
        break;
    }
    if (!ok) ++failed;
  }
  std::printf(
      "models: %zu tried, %d served a frame (%d of them with validation messages), %d refused "
      "cleanly, %d failed\n",
      models.size(), served, withValidationMessages, refused, failed);
  CHECK(failed == 0);
}
