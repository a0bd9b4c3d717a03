#!/usr/bin/env bash
# Makes the aarch64 cross build's tools and sysroot (docs/BUILDING.md "aarch64"): Debian's cross
# toolchain and qemu-user installed, and the arm64 builds of every dependency downloaded and
# unpacked into SYSROOT, not installed (libopencv-dev:arm64 and libceres-dev:arm64 are not
# co-installable with their amd64 builds: apt would remove those).
#
#   scripts/arm64_sysroot.sh SYSROOT      # as root, or a user with sudo; idempotent
#
# The packages are kept in SYSROOT.debs.
#
# A SYSROOT that this script completed (its .complete stamp) is left as it is.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
sysroot=$(realpath -m "${1:?usage: scripts/arm64_sysroot.sh SYSROOT}")
[ -e "$sysroot/.complete" ] && { echo "arm64 sysroot: $sysroot is complete"; exit 0; }
SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"

# 1. The build machine's tools: the cross compiler, and qemu to run the tests.
if ! dpkg --print-foreign-architectures | grep -qx arm64; then
  $SUDO dpkg --add-architecture arm64
fi
$SUDO apt-get update -qq -o Acquire::Retries=3
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq -o Acquire::Retries=3 --no-install-recommends \
  g++-aarch64-linux-gnu qemu-user > /dev/null

# 2. The packages, downloaded only, into SYSROOT.debs (kept: a second run downloads what is new).
#    The libraries the build finds (cmake/fdv_dependencies.cmake), with what apt would install
#    for them; the ROS 1 bag storage and messages (a test writes bags), which apt cannot plan
#    beside the amd64 ones, with their library dependencies by name; and the
#    architecture-independent headers those reach into.
DEPS="libopencv-dev libceres-dev libyaml-cpp-dev libspdlog-dev libfmt-dev libflatbuffers-dev
      libsqlite3-dev liblz4-dev libzstd-dev libpng-dev libtinyxml2-dev libhdf5-dev libgtest-dev
      libgmock-dev"
ROS="librosbag-storage-dev libroslz4-dev libbz2-dev libfastcdr-dev libsensor-msgs-dev libnav-msgs-dev
     libgeometry-msgs-dev"
HDRS="pluginlib-dev libclass-loader-dev librcutils-dev librcpputils-dev libament-index-cpp-dev
      libroslib-dev libboost-dev libboost1.74-dev libeigen3-dev libcli11-dev nlohmann-json3-dev"
arm64() { sed 's/$/:arm64/'; }
# Of NAMES on standard input, those apt has in architecture $1 (one apt-cache call for all).
have() {
  # shellcheck disable=SC2046
  apt-cache show --no-all-versions $(cat) 2>/dev/null |
    awk -v arch="$1" '/^Package:/ {p = $2} /^Architecture:/ && $2 == arch {print p}' | sort -u
}
debs=$sysroot.debs
mkdir -p "$debs" && chmod a+rwx "$debs"   # apt downloads as its own user
cd "$debs"
# shellcheck disable=SC2046  # word lists
planned=$(apt-get install -s $(printf '%s:arm64 ' $DEPS) | awk '/^Inst .*:arm64/ {print $2}' | sed 's/:arm64$//')
# shellcheck disable=SC2046
named=$(apt-cache depends --recurse --no-recommends --no-suggests --no-conflicts --no-breaks \
          --no-replaces --no-enhances $(printf '%s:arm64 ' $ROS) |
        grep -E '^(lib|pluginlib)' | sed 's/:arm64$//'; printf '%s\n' $HDRS)
wanted=$(printf '%s\n' $planned $named | sort -u)
as_arm64=$(echo "$wanted" | arm64 | have arm64)
as_all=$(comm -23 <(echo "$wanted") <(echo "$as_arm64") | have all)
missing=()
for p in $as_arm64; do compgen -G "${p}_*_arm64.deb" > /dev/null || missing+=("$p:arm64"); done
for p in $as_all; do compgen -G "${p}_*_all.deb" > /dev/null || missing+=("$p"); done
# A dropped connection to the mirror is retried rather than failing the build.
[ ${#missing[@]} -eq 0 ] || apt-get download -q -o Acquire::Retries=3 "${missing[@]}" > /dev/null
echo "arm64 sysroot: $(ls ./*.deb | wc -l) packages, $(du -sh . | cut -f1)"

# 3. Unpacked: what dpkg's maintainer scripts would have done is done here.
rm -rf "$sysroot" && mkdir -p "$sysroot"
for d in ./*.deb; do dpkg -x "$d" "$sysroot"; done
if [ -d "$sysroot/lib" ] && [ ! -L "$sysroot/lib" ]; then   # merged /usr, as Debian's
  cp -a "$sysroot/lib/." "$sysroot/usr/lib/" && rm -rf "$sysroot/lib"
fi
ln -sfn usr/lib "$sysroot/lib"
multiarch=$sysroot/usr/lib/aarch64-linux-gnu
# BLAS, LAPACK and HDF5's flavour are chosen by update-alternatives on a real install.
ln -sf blas/libblas.so.3 "$multiarch/libblas.so.3" && ln -sf libblas.so.3 "$multiarch/libblas.so"
ln -sf lapack/liblapack.so.3 "$multiarch/liblapack.so.3" && ln -sf liblapack.so.3 "$multiarch/liblapack.so"
ln -sf hdf5-serial.pc "$multiarch/pkgconfig/hdf5.pc"
# CMake packages that name files by absolute path (Ceres' BLAS and LAPACK, Fast-CDR's library and
# prefix): into the sysroot.
grep -rlE '(["; ]/usr/lib/aarch64-linux-gnu/|_IMPORT_PREFIX "/usr")' "$multiarch/cmake" "$sysroot/usr/share" \
    --include='*.cmake' |
  xargs -r sed -i -E -e 's#(["; ])/usr/lib/aarch64-linux-gnu/#\1${CMAKE_SYSROOT}/usr/lib/aarch64-linux-gnu/#g' \
                     -e 's#_IMPORT_PREFIX "/usr"\)#_IMPORT_PREFIX "${CMAKE_SYSROOT}/usr")#'
# FlatBuffers' CMake package wants its compiler: the build machine's runs.
ln -sf /usr/bin/flatc "$sysroot/usr/bin/flatc"
touch "$sysroot/.complete"
echo "arm64 sysroot: $sysroot ($(du -sh "$sysroot" | cut -f1)); build with" \
     "-DCMAKE_TOOLCHAIN_FILE=$repo/cmake/aarch64-linux-gnu.cmake -DFDV_ARM64_SYSROOT=$sysroot"
