#include "render/techniques/registry.h"

#include <array>
#include <string_view>

#include "protocol/constants.h"

namespace myriad::render {

// Each technique's file defines its factory.
std::unique_ptr<LightingTechnique> createVolumes(const TechniqueSetup& setup);
std::unique_ptr<LightingTechnique> createTiled(const TechniqueSetup& setup);
std::unique_ptr<LightingTechnique> createClustered(const TechniqueSetup& setup);

namespace {

struct Entry {
  std::string_view name;
  std::unique_ptr<LightingTechnique> (*create)(const TechniqueSetup&);
};

// The techniques, in protocol::kTechniques' order. A new technique: its file, its name in
// protocol/constants.h (and the schema's enum), and one line here.
constexpr std::array kRegistry = {
    Entry{protocol::techniques::kVolumes, createVolumes},
    Entry{protocol::techniques::kTiled, createTiled},
    Entry{protocol::techniques::kClustered, createClustered},
};

constexpr bool namesInProtocolOrder() {
  if (kRegistry.size() != protocol::kTechniques.size()) return false;
  for (size_t i = 0; i < kRegistry.size(); ++i) {
    if (kRegistry[i].name != protocol::kTechniques[i]) return false;
  }
  return true;
}
static_assert(namesInProtocolOrder(),
              "the registry must list protocol::kTechniques, in order: Technique indexes both");

}  // namespace

std::vector<std::unique_ptr<LightingTechnique>> createTechniques(const TechniqueSetup& setup) {
  std::vector<std::unique_ptr<LightingTechnique>> techniques;
  for (const Entry& entry : kRegistry) techniques.push_back(entry.create(setup));
  return techniques;
}

}  // namespace myriad::render
