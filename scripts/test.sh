#!/usr/bin/env bash
# Install what the tests need (Debian 12), build everything, and run every test through CTest:
# unit, GPU image (validation layers on), HTTP and model tests against the real server, and the
# container test (tests/container: needs root; it builds docker/Dockerfile with buildah, which takes
# minutes cold). Extra arguments go to ctest, e.g. scripts/test.sh -R gpu, or -LE container to
# leave the container test out.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh --with-test-tools --container-test
preset=${MYRIAD_PRESET:-release}
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" -j"$(nproc)"
ctest --preset "$preset" "$@"
