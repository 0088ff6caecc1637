// Filled in by issue 31 work.
#include <doctest/doctest.h>
