// Shared by the libFuzzer harnesses: how a harness says "this must never happen". A harness
// reports a broken promise (an undocumented exception, a result that breaks the parser's own
// contract) by printing it and aborting, which libFuzzer records as a crash with the input.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string_view>

namespace myriad::fuzz {

[[noreturn]] inline void broken(std::string_view what) {
  std::fprintf(stderr, "fuzz: broken promise: %.*s\n", int(what.size()), what.data());
  std::abort();
}

inline void require(bool condition, std::string_view what) {
  if (!condition) broken(what);
}

}  // namespace myriad::fuzz
