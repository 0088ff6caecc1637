// The CLI's multipart/x-mixed-replace reader (client/cli/multipart.h), which reads a stream from
// a server it cannot trust (any URL the user gives).
//
// Input: the Content-Type header value up to the first '\n', then the response body.
// Promises checked: multipartBoundary and MultipartReader throw nothing but std::runtime_error;
// the reader gives the same parts, in the same order, whether the body arrives in one piece,
// byte by byte or in uneven chunks (network reads split anywhere); a part with a Content-Length
// has a body of exactly that length.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_support.h"
#include "multipart.h"

namespace cli = myriad::cli;
using myriad::fuzz::broken;
using myriad::fuzz::require;

namespace {

struct Outcome {
  std::vector<cli::MultipartPart> parts;
  bool failed = false;  // threw std::runtime_error
  bool finished = false;
};

// Feeds `body` in pieces of the sizes `chunk(i)` returns for piece i.
template <typename ChunkSize>
Outcome read(const std::string& boundary, std::string_view body, ChunkSize chunk) {
  Outcome outcome;
  cli::MultipartReader reader(boundary);
  try {
    size_t at = 0;
    for (size_t i = 0; at < body.size(); ++i) {
      const size_t n = std::min(body.size() - at, chunk(i));
      for (auto& part : reader.feed(body.substr(at, n))) outcome.parts.push_back(std::move(part));
      at += n;
    }
  } catch (const std::runtime_error&) {
    outcome.failed = true;
  }
  outcome.finished = reader.finished();
  return outcome;
}

// A feed that throws loses the parts completed within it, so after a failure only the failure
// itself must agree.
bool same(const Outcome& a, const Outcome& b) {
  if (a.failed || b.failed) return a.failed == b.failed;
  if (a.finished != b.finished || a.parts.size() != b.parts.size()) return false;
  for (size_t i = 0; i < a.parts.size(); ++i) {
    if (a.parts[i].headers != b.parts[i].headers || a.parts[i].body != b.parts[i].body) return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const size_t newline = input.find('\n');
  if (newline == std::string_view::npos) {
    (void)cli::multipartBoundary(std::string(input));
    return 0;
  }
  std::optional<std::string> boundary;
  try {
    boundary = cli::multipartBoundary(std::string(input.substr(0, newline)));
  } catch (const std::exception& e) {
    broken(std::string("multipartBoundary threw: ") + e.what());
  }
  if (!boundary) return 0;
  const std::string_view body = input.substr(newline + 1);

  const Outcome whole = read(*boundary, body, [&](size_t) { return body.size(); });
  const Outcome bytes = read(*boundary, body, [](size_t) { return size_t(1); });
  // Uneven pieces of 1..13 bytes, so splits land everywhere relative to the delimiter.
  const Outcome uneven = read(*boundary, body, [](size_t i) { return 1 + (i * 7) % 13; });
  require(same(whole, bytes), "parts differ when the body arrives byte by byte");
  require(same(whole, uneven), "parts differ when the body arrives in uneven pieces");

  for (const cli::MultipartPart& part : whole.parts) {
    auto length = part.headers.find("content-length");
    if (length != part.headers.end()) {
      require(std::to_string(part.body.size()) == length->second ||
                  std::stoull(length->second) == part.body.size(),
              "a part's body is not its Content-Length long");
    }
  }
  return 0;
}
