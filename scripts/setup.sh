#!/usr/bin/env bash
# Installs every Debian package fast-dynamic-vision needs, then configures and builds it.
# Idempotent: packages already present are skipped by apt; the build is incremental.
#
#   scripts/setup.sh                 # install + Release build of `fdv` and the Python package
#   FDV_BUILD=all scripts/setup.sh   # ... and everything else: tests, benchmarks, ROS node, fuzz
#   BUILD_DIR=build-asan FDV_SANITIZE=ON FDV_BUILD=all scripts/setup.sh   # ASan+UBSan build
#   FDV_SKIP_INSTALL=1 scripts/setup.sh                     # build only
#   FDV_BUILD_BENCH=OFF scripts/setup.sh                    # without the benchmark programs
#   CC=clang CXX=clang++ FDV_SANITIZE=ON FDV_FUZZ=ON FDV_BUILD=all BUILD_DIR=build-fuzz scripts/setup.sh
#                                  # clang, ASan+UBSan, and the libFuzzer targets (fuzz/run.sh)
#   FDV_TARGETS="core_test pipeline_test" scripts/setup.sh  # build only these targets
set -euo pipefail
cd "$(dirname "$0")/.."

# The demo needs only the program (and users of build/python the extension): building the tests
# and benchmarks too would more than double the first command's time (docs/BUILDING.md).
TARGETS=()
case "${FDV_BUILD:-demo}" in
  all) ;;
  demo) TARGETS=(--target fdv_cli)
        [ "${FDV_SANITIZE:-OFF}" = "ON" ] || TARGETS+=(fdv_python) ;;  # no package under ASan
  *) echo "setup: FDV_BUILD must be 'demo' or 'all', got '${FDV_BUILD}'" >&2; exit 2 ;;
esac

PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libopencv-dev libceres-dev libyaml-cpp-dev libcli11-dev
  nlohmann-json3-dev libspdlog-dev libfmt-dev liblz4-dev libzstd-dev libpng-dev
  libflatbuffers-dev flatbuffers-compiler libsqlite3-dev libtinyxml2-dev
  libhdf5-dev hdf5-filter-plugin hdf5-filter-plugin-blosc-serial python3-h5py
  libgtest-dev libgmock-dev libbenchmark-dev
  librosbag-storage-dev libroslz4-dev libbz2-dev libsensor-msgs-dev libnav-msgs-dev
  libgeometry-msgs-dev libfastcdr-dev
  # ROS 1 (cmake/fdv_ros1.cmake): the node's roscpp and message headers, gencpp for ros/msg, the
  # .msg files our messages use, roscore + rosbag play/record for the node's tests, rosrun/rospack
  libroscpp-dev libtopic-tools-dev python3-gencpp python3-genmsg ros-std-msgs ros-geometry-msgs
  libstd-msgs-dev libvisualization-msgs-dev libdiagnostic-msgs-dev librosbag-dev ros-core
  python3-rosbag rosbash rospack-tools
  # the fdv Python package (python/), for Debian's /usr/bin/python3
  python3-dev pybind11-dev python3-numpy python3-matplotlib python3-pytest
  # `pip install .` into a venv, offline (docs/PYTHON.md "pip"; .ci/run)
  python3-venv python3-pip python3-setuptools python3-wheel
)
# The fuzz build: clang with its libFuzzer and sanitizer runtimes; python3 builds the seed corpora.
[ "${FDV_FUZZ:-OFF}" = "ON" ] && PACKAGES+=(clang libclang-rt-14-dev python3)
# The ThreadSanitizer build (docs/BUILDING.md): clang and its TSan runtime; GCC's shared one,
# preloaded into python3 for the Python threads test.
[ "${FDV_SANITIZE:-OFF}" = "thread" ] && PACKAGES+=(clang libclang-rt-14-dev libtsan2)

if [ "${FDV_SKIP_INSTALL:-0}" != "1" ]; then
  missing=()
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    echo "setup: installing ${missing[*]}"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
  fi
fi

BUILD_DIR="${BUILD_DIR:-build}"
BUILD_TYPE="${BUILD_TYPE:-Release}"
cmake -S . -B "$BUILD_DIR" -G Ninja \
  -DCMAKE_BUILD_TYPE="$BUILD_TYPE" \
  -DFDV_WERROR="${FDV_WERROR:-OFF}" \
  -DFDV_SANITIZE="${FDV_SANITIZE:-OFF}" \
  -DFDV_BUILD_BENCH="${FDV_BUILD_BENCH:-ON}" \
  -DFDV_FUZZ="${FDV_FUZZ:-OFF}" >/dev/null
# FDV_TARGETS names the targets outright (a sanitizer stage that runs a few tests builds only those).
# shellcheck disable=SC2206  # FDV_TARGETS is a list
[ -n "${FDV_TARGETS:-}" ] && TARGETS=(--target ${FDV_TARGETS})
cmake --build "$BUILD_DIR" -j "$(nproc)" "${TARGETS[@]}"
echo "setup: built into $BUILD_DIR"
