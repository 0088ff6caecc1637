// Writes, as one JSON array on stdout, bodies and what protocol::validate() says of them, for
// differential.py to hold python3-jsonschema's verdicts against. The bodies: tests/protocol/
// cases.json, every example of protocol/examples/, and systematic mutations of each example (every
// member and item replaced by values of other types and out-of-range numbers, removed, or joined by
// an unknown member), so both validators meet every keyword on every path of every schema.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "protocol/schema_bundle.h"
#include "protocol/validate.h"

using nlohmann::json;
namespace protocol = myriad::protocol;

namespace {

json readJson(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::stringstream text;
  text << in.rdbuf();
  return json::parse(text.str());
}

class Exporter {
 public:
  void add(const std::string& schema, const json& body) {
    auto error = protocol::validate(schema, body);
    json entry = {{"schema", schema}, {"body", body}, {"valid", !error}};
    if (error) {
      entry["pointer"] = error->pointer;
      entry["message"] = error->message;
    }
    out_.push_back(std::move(entry));
  }

  // Every mutation of `node` (at `at` inside `root`), then of its children.
  void mutate(const std::string& schema, const json& root, const json::json_pointer& at) {
    static const json kReplacements = json::parse(
        R"(["x", "", true, null, {}, [], 0, -1, 0.5, 1.5, 2, 65, -1000001, 10001,
            4294967296, 9007199254740992, 1e300, -1e300, [0, 0, 0], [0.5, 0.5], [1, 2, 3, 4]])");
    const json& node = root.at(at);
    for (const json& replacement : kReplacements) {
      json copy = root;
      copy[at] = replacement;
      add(schema, copy);
    }
    if (node.is_object()) {
      json copy = root;
      copy[at]["unknownMember"] = 1;
      add(schema, copy);
      for (const auto& [key, value] : node.items()) {
        (void)value;
        json without = root;
        without[at].erase(key);
        add(schema, without);
        mutate(schema, root, at / key);
      }
    }
    if (node.is_array() && !node.empty()) {
      json longer = root;
      longer[at].push_back(node.back());
      add(schema, longer);
      json shorter = root;
      shorter[at].erase(shorter[at].size() - 1);
      add(schema, shorter);
      // The first items stand for the rest: same schema for every item.
      for (size_t i = 0; i < node.size() && i < 2; ++i) mutate(schema, root, at / i);
    }
  }

  const json& cases() const { return out_; }

 private:
  json out_ = json::array();
};

}  // namespace

int main() {
  try {
    Exporter exporter;
    for (const json& c : readJson(MYRIAD_PROTOCOL_CASES)) exporter.add(c["schema"], c["body"]);
    for (std::string_view name : protocol::schemaNames()) {
      if (name == "defs") continue;
      std::string schema(name);
      // The example of protocol/examples/, or the schema's own (newer schemas carry it inline).
      const std::string file = std::string(MYRIAD_PROTOCOL_DIR) + "/examples/" + schema + ".json";
      json example = std::filesystem::exists(file) ? readJson(file)
                                                   : protocol::schema(name)["examples"].at(0);
      exporter.add(schema, example);
      exporter.mutate(schema, example, json::json_pointer());
    }
    std::cout << exporter.cases().dump() << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "myriad_protocol_export: " << e.what() << "\n";
    return 1;
  }
}
