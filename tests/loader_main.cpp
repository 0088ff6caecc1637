// The loader tests' own main: the loader child is this test binary re-executed, so the child's
// entry point must run before doctest sees the arguments.
#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#include "loader/loader.h"

int main(int argc, char** argv) {
  if (myriad::loader::runChildIfRequested(argc, argv)) return 0;
  return doctest::Context(argc, argv).run();
}
