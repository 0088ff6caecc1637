#!/usr/bin/env bash
# Takes docs/web-client.png: starts myriad-server on a free port, opens the web client in
# headless Chromium (tests/browser's playwright-core) and saves the window once the stream shows.
# Usage: scripts/web-screenshot.sh [myriad-server binary] [server flags...]
#   (default binary: build/release/server/myriad-server, built by scripts/serve.sh or test.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
server=${1:-build/release/server/myriad-server}
shift || true
if [[ ! -x $server ]]; then
  echo "web-screenshot: no server binary at $server (build it: cmake --preset release && cmake --build --preset release)" >&2
  exit 1
fi
if [[ ! -x /usr/bin/chromium ]]; then
  echo "web-screenshot: /usr/bin/chromium is missing (scripts/install-deps.sh --with-test-tools)" >&2
  exit 1
fi
browser_dir=tests/browser
if [[ ! -f $browser_dir/node_modules/.package-lock.json ||
      $browser_dir/package-lock.json -nt $browser_dir/node_modules/.package-lock.json ]]; then
  (cd "$browser_dir" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund)
fi
flags=("$@")
if [[ ${#flags[@]} -eq 0 ]]; then flags=(--lights 500); fi
node "$browser_dir/web_screenshot.mjs" "$server" docs/web-client.png "${flags[@]}"
