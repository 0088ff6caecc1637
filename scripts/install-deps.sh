#!/usr/bin/env bash
# The one place that names Myriad's dependencies. Debian 12 (bookworm) packages only.
# Usage: scripts/install-deps.sh [--with-test-tools] [--container-test]   (root, or sudo available)
#   --with-test-tools   also what the test suites need
#   --container-test    the tools tests/container/container_test.sh needs to build and run
#                       docker/Dockerfile without a Docker engine (buildah, debootstrap, ...);
#                       given alone, only those (the server is then compiled inside the image)
set -euo pipefail

build_packages=(
  cmake g++ make pkg-config
  libvulkan-dev            # Vulkan loader + headers
  mesa-vulkan-drivers      # lavapipe: Vulkan on the CPU when there is no GPU
  vulkan-validationlayers  # VK_LAYER_KHRONOS_validation (--validate, every test)
  glslang-tools            # glslangValidator: GLSL -> SPIR-V at build time
  libglm-dev
  libassimp-dev
  libcpp-httplib-dev
  nlohmann-json3-dev
  libpng-dev
  libdeflate-dev           # PNG frames' deflate (server/encode/png_writer.cpp)
  zlib1g-dev               # PNG strips deflated in parallel, the npz's CRC-32
  libopenexr-dev           # format=exr (server/encode/exr.cpp) and the formats CTest's reader
  libspng-dev              # myriad-png-bench's libspng row (server/bench/png_bench.cpp)
  libturbojpeg0-dev        # JPEG frames and streams (TurboJPEG API)
  libvpx-dev               # VP8/VP9 video streams (libvpx, BSD), and their decoder in tests and bench
  libopenh264-dev          # H.264 video streams (codec=h264: OpenH264, BSD), and its decoder in tests
  libzip-dev               # zip uploads of a model with its files, read in the loader child
  libstb-dev               # stb_image's header: .hdr environment images, decoded in the loader child
  libssl-dev               # libcrypto: SHA-256 of session tokens in --state-dir
  libpq-dev                # libpq: --state-store postgresql:// (server/service/store_postgres.cpp)
  doctest-dev
)
test_packages=(
  assimp-testmodels        # /usr/share/assimp/models: real (and deliberately broken) models
  curl
  ffmpeg                   # video_players: ffmpeg/ffprobe open the WebM and MP4 streams by URL
  chromium                 # the browser test's headless browser (never a downloaded one)
  nodejs                   # runs the browser test (tests/browser, playwright-core)
  python3-jsonschema       # protocol-differential: a second JSON Schema validator to agree with ours
  clang                    # the fuzz preset's clang++ (tests/fuzz: libFuzzer harnesses)
  libclang-rt-14-dev       # libFuzzer and the ASan/UBSan runtimes clang links into the harnesses
  nginx                    # the front CTest runs deploy/nginx/myriad.conf (as the test's user)
  haproxy                  # the haproxy_* CTests run deploy/haproxy/myriad.cfg (as the test's user)
  postgresql               # store_postgres and chaos CTests start a cluster of their own (initdb)
  openssl                  # the front CTest makes its self-signed TLS certificate
  python3-yaml             # the k8s CTest parses the manifests
  docker-compose           # deploy_doc_commands: `config` checks docker/compose*.yaml (no engine)
  # python_client: client/python pip-installed offline into a venv (--system-site-packages,
  # --no-build-isolation), its pytest suite reading frames with numpy and Pillow
  python3-venv python3-pip python3-setuptools python3-wheel
  python3-numpy python3-pil python3-pytest
)
# npm installs the browser test's playwright-core. Only where no npm exists: NodeSource's nodejs
# bundles its own and conflicts with Debian's npm package.
if ! command -v npm >/dev/null 2>&1; then test_packages+=(npm); fi
# kubectl: the k8s CTest checks deploy/k8s with --dry-run=client. Debian's kubernetes-client only
# where no kubectl exists: a machine with Google's kubectl package (/usr/bin/kubectl, any version
# the test accepts) cannot install it (dpkg refuses to overwrite the file; CI failed on it).
if ! command -v kubectl >/dev/null 2>&1; then test_packages+=(kubernetes-client); fi
container_test_packages=(
  buildah                  # builds and runs the OCI image daemonless (--isolation chroot)
  podman                   # imports the bootstrapped base image into the local image store
  debootstrap              # makes debian:bookworm-slim from the apt archive (no registry needed)
  curl                     # talks to the server in the container from outside
  file                     # checks that /v1/frame is a PNG of the asked size
  python3                  # checks that the PNG is not one flat colour
)

with_test_tools=false
container_test=false
for arg in "$@"; do
  case "$arg" in
    --with-test-tools) with_test_tools=true ;;
    --container-test) container_test=true ;;
    *) echo "install-deps: unknown option \"$arg\" (see the usage line)" >&2; exit 2 ;;
  esac
done

packages=()
# The container test builds the server inside the image, so alone it needs no build packages here.
if $with_test_tools || ! $container_test; then packages+=("${build_packages[@]}"); fi
if $with_test_tools; then packages+=("${test_packages[@]}"); fi
if $container_test; then packages+=("${container_test_packages[@]}"); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#packages[@]} packages already installed"
  exit 0
fi

sudo=""
if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
