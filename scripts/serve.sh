#!/usr/bin/env bash
# Install what Myriad needs (Debian 12), build the release server (and the `myriad` CLI), and start it on the built-in
# scene. Extra arguments go to myriad-server, e.g. scripts/serve.sh --port 9000 --lights 1000
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
cmake --preset release >/dev/null
cmake --build --preset release --target myriad-server myriad -j"$(nproc)"   # the server and the CLI
exec build/release/server/myriad-server --host 127.0.0.1 --port 8080 "$@"
