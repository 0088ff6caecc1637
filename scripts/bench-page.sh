#!/usr/bin/env bash
# The page benchmark (tests/browser/page_bench.mjs): the web client in headless Chromium against a
# fresh myriad-server, view 1280x720, built-in scene, on the page as it opens by default (no query
# string: VP9 through WebCodecs) and on the JPEG stream (?stream=jpeg, also what the page falls
# back to without WebCodecs; --paths default,jpeg,fallback adds the fallback itself), both
# reported; measured in the page (client/web/perf.js): animated fps, fps while dragging the
# camera and the drag's render scales, input to first new picture, release-to-still, slider change-to-shown and
# release-to-still; first as the machine is, then with LOAD busy processes (`yes`, one core each;
# default 2) running beside it. Prints JSON.
# Not a test (it asserts nothing): run it on a machine otherwise idle and say what else ran.
# Usage: scripts/bench-page.sh [myriad-server binary] [page_bench options] [-- server flags]
#   e.g. scripts/bench-page.sh build/release/server/myriad-server --load 2 --json /tmp/page.json
set -euo pipefail
cd "$(dirname "$0")/.."
server=build/release/server/myriad-server
if [[ $# -gt 0 && $1 != -* ]]; then server=$1; shift; fi
if [[ ! -x $server ]]; then
  echo "bench-page: no server binary at $server (build it: cmake --preset release && cmake --build --preset release)" >&2
  exit 1
fi
if [[ ! -x /usr/bin/chromium ]]; then
  echo "bench-page: /usr/bin/chromium is missing (scripts/install-deps.sh --with-test-tools)" >&2
  exit 1
fi
browser_dir=tests/browser
if [[ ! -f $browser_dir/node_modules/.package-lock.json ||
      $browser_dir/package-lock.json -nt $browser_dir/node_modules/.package-lock.json ]]; then
  (cd "$browser_dir" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund)
fi
exec node "$browser_dir/page_bench.mjs" "$server" "$@"
