#!/usr/bin/env bash
# Installs every package relume needs to build, test and run, by Debian 12 package name.
# Idempotent: does nothing when everything is already installed.
#   scripts/install-deps.sh [--fuzz]
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config git clang-format libssl-dev
  # core, calibration, processing
  libeigen3-dev libgeographiclib-dev liberfa-dev libopencv-dev libopencv-contrib-dev libembree-dev libraw-dev
  # storage, config, CLI, logs, reports
  libsqlite3-dev libtiff-dev libyaml-cpp-dev libcli11-dev libspdlog-dev nlohmann-json3-dev
  # `relume session import`: the stills' EXIF (time, exposure, aperture, ISO)
  libexiv2-dev
  # the Python module (python/, docs/python.md) and its tests
  pybind11-dev python3-dev python3-numpy python3-pytest
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # images from outside relume: a scene rendered by Blender Cycles, EXIF written by exiv2, imported
  # and processed (scripts/blender_dataset.sh, tests/apps/blender_dataset_test.cc)
  blender exiv2
  # the HTML report is checked by loading it in headless Chromium
  chromium
  # `relume batch --slurm` is tested on a one-node Slurm cluster the test starts (tests/batch/)
  slurm-wlm munge
  # device backends and their simulated devices
  libgphoto2-dev libusb-1.0-0-dev libopenni2-dev libaravis-dev aravis-tools umockdev libumockdev-dev
)

# `install-deps.sh --fuzz`: also clang and its libFuzzer runtime, for scripts/fuzz.sh only (the
# tests build with GCC and fuzz through relume's own driver).
if [ "${1:-}" = "--fuzz" ]; then
  PACKAGES+=(clang libclang-rt-14-dev)
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages are installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then
    SUDO="sudo"
  else
    echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2
    exit 1
  fi
fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
