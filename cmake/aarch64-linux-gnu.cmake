# Cross build for 64-bit ARM Linux (Jetson-class onboard computers) with Debian's cross toolchain
# (g++-aarch64-linux-gnu) and the arm64 dependencies unpacked into a sysroot folder:
#
#   cmake -S . -B build-arm64 -G Ninja -DCMAKE_TOOLCHAIN_FILE=cmake/aarch64-linux-gnu.cmake \
#         -DFDV_ARM64_SYSROOT=/path/to/arm64-sysroot -DCMAKE_BUILD_TYPE=Release
#
# docs/BUILDING.md says how to make the sysroot and what was checked.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# GCC fuses a * b + c into one FMA where the target has it (aarch64 does, baseline x86-64 not):
# off, so that the renderer's and the front end's own arithmetic rounds as on x86-64.
set(CMAKE_C_FLAGS_INIT -ffp-contract=off)
# -Wno-psabi: GCC's note that passing std::pair changed in GCC 10.1 concerns linking with code
# built by GCC 9 or older, which a build from one sysroot does not do.
set(CMAKE_CXX_FLAGS_INIT "-ffp-contract=off -Wno-psabi")

set(FDV_ARM64_SYSROOT "" CACHE PATH "arm64 root holding the dependencies' usr/include and usr/lib")
if(NOT FDV_ARM64_SYSROOT AND DEFINED ENV{FDV_ARM64_SYSROOT})
  set(FDV_ARM64_SYSROOT $ENV{FDV_ARM64_SYSROOT})
endif()
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES FDV_ARM64_SYSROOT)
if(FDV_ARM64_SYSROOT)
  set(CMAKE_SYSROOT ${FDV_ARM64_SYSROOT})
  set(CMAKE_FIND_ROOT_PATH ${FDV_ARM64_SYSROOT})
  # pkg-config (lz4, zstd, tinyxml2) reads the sysroot's .pc files, not the build machine's.
  set(ENV{PKG_CONFIG_SYSROOT_DIR} ${FDV_ARM64_SYSROOT})
  set(fdv_pc_dirs ${FDV_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu/pkgconfig
                  ${FDV_ARM64_SYSROOT}/usr/share/pkgconfig)
  string(REPLACE ";" ":" fdv_pc_dirs "${fdv_pc_dirs}")
  set(ENV{PKG_CONFIG_LIBDIR} ${fdv_pc_dirs})
  # CTest runs the test programs under Debian's qemu-user, with the sysroot's loader and libraries.
  set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64 -L ${FDV_ARM64_SYSROOT})
  # ldd for aarch64 programs: the sysroot's dynamic loader lists what it would load.
  set(FDV_LIST_SHARED_LIBRARIES ${CMAKE_CROSSCOMPILING_EMULATOR}
      ${FDV_ARM64_SYSROOT}/lib/ld-linux-aarch64.so.1 --list)
endif()
# Libraries and headers from the sysroot only; programs (flatc, pkg-config) from the build machine.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
