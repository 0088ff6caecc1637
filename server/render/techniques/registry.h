// The lighting techniques, one per name of protocol::kTechniques and in that order, so that
// render::Technique indexes both. registry.cpp is the only place that lists them.
#pragma once

#include <memory>
#include <vector>

#include "render/techniques/technique.h"

namespace myriad::render {

// One of each technique, index = render::Technique. Creates every pipeline up front, so a device
// that cannot run one fails at start-up, not on the first frame that asks for it.
std::vector<std::unique_ptr<LightingTechnique>> createTechniques(const TechniqueSetup& setup);

}  // namespace myriad::render
