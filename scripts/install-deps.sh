#!/usr/bin/env bash
# The one place that names Myriad's dependencies. Debian 12 (bookworm) packages only.
# Usage: scripts/install-deps.sh [--with-test-tools]   (run as root, or with sudo available)
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
  doctest-dev
)
test_packages=(
  assimp-testmodels        # /usr/share/assimp/models: real (and deliberately broken) models
  curl
)

packages=("${build_packages[@]}")
if [[ "${1:-}" == "--with-test-tools" ]]; then
  packages+=("${test_packages[@]}")
fi

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
