#!/usr/bin/env bash
# Install what the tests need (Debian 12), build everything, and run every test through CTest:
# unit, GPU image (validation layers on), HTTP and model tests against the real server, the web
# client in headless Chromium (tests/browser), Myriad judged against three.js in the same Chromium
# (tests/judge), the served OpenAPI document (tests/openapi), the libFuzzer harnesses for 30 s each
# (tests/fuzz: the fuzz preset, built here when clang is), and the container test (tests/container:
# needs root; it builds docker/Dockerfile with buildah, which takes minutes cold). Extra arguments
# go to ctest, e.g. scripts/test.sh -R gpu, or -LE container to leave the container test out.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh --with-test-tools --container-test
# The npm packages of the browser test (playwright-core), of the openapi test (an OpenAPI 3.1
# validator and ajv), of the judge (three.js and playwright-core) and of the k8s_schema test
# (kubernetes-models: the Kubernetes OpenAPI schemas, compiled), each pinned by its folder's
# package-lock.json; installed only when node_modules is missing or older than the lock file.
# Nothing downloads a browser.
for npm_dir in tests/browser tests/openapi tests/judge tests/k8s-schema; do
  if [[ ! -f $npm_dir/node_modules/.package-lock.json ||
        $npm_dir/package-lock.json -nt $npm_dir/node_modules/.package-lock.json ]]; then
    (cd "$npm_dir" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund)
  fi
done
preset=${MYRIAD_PRESET:-release}
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" -j"$(nproc)"
# The libFuzzer harnesses (tests/fuzz, clang), which the CTest `fuzz` runs for a bounded time each;
# without clang that test skips.
if command -v clang++ >/dev/null 2>&1; then
  cmake --preset fuzz >/dev/null
  cmake --build --preset fuzz -j"$(nproc)"
fi
ctest --preset "$preset" "$@"
