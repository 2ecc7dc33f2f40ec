#!/usr/bin/env bash
# Installs Sawyer's build and run dependencies from Debian 12 packages.
# Idempotent: packages already present are not touched, and apt is not called at all when
# everything is installed. Needs root (or sudo) only when something is missing.
set -euo pipefail

# python3-scipy, -pil and -pydicom: bench/real_slices.py and the RealSlices test (the real-CT
# check's case maker and scorer, in ../shared/realdata when it is there). valgrind: the
# performance gate (bench/perf_gate, the PerfGate test) counts instructions under callgrind, and
# its callgrind.h gives the build its stage marks.
PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev nlohmann-json3-dev libcli11-dev libgtest-dev libgmock-dev
  libopencv-dev libvtk9-dev libopenimageio-dev openimageio-tools libdeflate-dev
  libglfw3-dev libceres-dev libgdcm-dev libgdcm-tools libsqlite3-dev libxxhash-dev libcairo2-dev libimgui-dev
  libegl-dev libgl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri
  xvfb xauth poppler-utils chromium fonts-dejavu-core sqlite3 clang-format git
  blender python3-numpy python3-scipy python3-pil python3-pydicom
  valgrind
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

# node and npm for the glTF validator (tools/gltf): any install that gives the two commands.
command -v node >/dev/null 2>&1 || missing+=(nodejs)
command -v npm >/dev/null 2>&1 || missing+=(npm)

# The Khronos glTF validator, pinned by tools/gltf/package-lock.json (npm registry).
npm_tools() {
  if [ ! -d tools/gltf/node_modules/gltf-validator ]; then
    echo "install_deps: npm ci --prefix tools/gltf"
    npm ci --prefix tools/gltf --no-audit --no-fund --silent ||
      echo "install_deps: npm ci failed; ExportTools.KhronosValidatorFindsNoErrors will skip" >&2
  fi
  # The Kubernetes API schemas (kubernetes-models), pinned by tools/k8s/package-lock.json.
  if [ ! -d tools/k8s/node_modules/kubernetes-models ]; then
    echo "install_deps: npm ci --prefix tools/k8s"
    npm ci --prefix tools/k8s --no-audit --no-fund --silent ||
      echo "install_deps: npm ci failed; the K8sManifest tests will skip" >&2
  fi
}
cd "$(dirname "$0")/.."

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  npm_tools
  exit 0
fi

echo "install_deps: installing ${#missing[@]} missing packages: ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
npm_tools
