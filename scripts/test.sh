#!/usr/bin/env bash
# Install what the tests need (Debian 12), build everything, and run every test through CTest:
# unit, GPU image (validation layers on), HTTP and model tests against the real server, the web
# client in headless Chromium (tests/browser), and the
# container test (tests/container: needs root; it builds docker/Dockerfile with buildah, which takes
# minutes cold). Extra arguments go to ctest, e.g. scripts/test.sh -R gpu, or -LE container to
# leave the container test out.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh --with-test-tools --container-test
# The browser test's one npm package (playwright-core, pinned by its package-lock.json); again
# only when node_modules is missing or older than the lock file. It never downloads a browser.
browser_dir=tests/browser
if [[ ! -f $browser_dir/node_modules/.package-lock.json ||
      $browser_dir/package-lock.json -nt $browser_dir/node_modules/.package-lock.json ]]; then
  (cd "$browser_dir" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund)
fi
preset=${MYRIAD_PRESET:-release}
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" -j"$(nproc)"
ctest --preset "$preset" "$@"
