#!/usr/bin/env bash
# Installs every build and run dependency of orpe from Debian's archive. Idempotent: a machine that
# already has everything is left alone (one dpkg query, no network).
# --fuzz: also clang 14, its sanitizer/libFuzzer runtimes and OpenMP runtime, for the fuzz targets
# (cmake --preset fuzz; docs/FUZZING.md). The CI does not need them.
set -euo pipefail
PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config git
  libeigen3-dev libopencv-dev libopencv-contrib-dev
  libmatio-dev zlib1g-dev nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev
  libnanoflann-dev libtbb-dev libgtest-dev libgmock-dev libbenchmark-dev
  libassimp-dev libyaml-cpp-dev parallel
  # A real browser for the test that opens `orpe report`'s page (headless; docs/REPORT.md).
  chromium
  # ROS 1 bags as a dataset (io/dataset_rosbag.cpp, ORPE_WITH_ROSBAG; docs/DATASETS.md).
  librosbag-storage-dev libsensor-msgs-dev
  # LibTorch for src/orpe/nets (ORPE_WITH_TORCH; ~0.5 GB), and Debian's PyTorch for the export /
  # fixture / training scripts of scripts/nets (run with /usr/bin/python3). docs/NETWORKS.md.
  libtorch-dev python3-torch python3-torchvision
)
if [ "${1:-}" = --fuzz ]; then
  PACKAGES+=(clang-14 libclang-rt-14-dev libomp-14-dev)
fi
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO=sudo; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
