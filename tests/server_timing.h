// The Server-Timing header split into its entries, for the server and api tests.
#pragma once

#include <string>
#include <vector>

namespace myriad::test {

// "gbuffer;dur=1.2, sun;dur=0.5" -> {"gbuffer;dur=1.2", "sun;dur=0.5"}: split on commas, leading
// spaces dropped; each test parses the entries as strictly as it needs.
std::vector<std::string> serverTimingEntries(const std::string& header);

}  // namespace myriad::test
