# Cross toolchain for Debian multiarch arm64 (aarch64-linux-gnu).
#   dpkg --add-architecture arm64 && apt-get install crossbuild-essential-arm64 qemu-user \
#     libasound2-dev:arm64 libgpiod-dev:arm64 libinih-dev:arm64 libcmocka-dev:arm64 zlib1g-dev:arm64
#   cmake -S . -B build/cross-arm64 -DCMAKE_TOOLCHAIN_FILE=boards/toolchains/arm64.cmake -DHAPTIC_CALIB=OFF
# (scripts/cross-test does this for arm64). ctest runs the tests under qemu-aarch64
# through CMAKE_CROSSCOMPILING_EMULATOR.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

# Multiarch: headers in /usr/include, libraries in /usr/lib/aarch64-linux-gnu; the
# cross libc lives in /usr/aarch64-linux-gnu. Never pick up build-machine programs' libs.
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)

# pkg-config must see only the arm64 .pc files.
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

# No "-L /usr/aarch64-linux-gnu": with the multiarch libc6:arm64 installed (a dependency
# of the :arm64 -dev packages) qemu finds /lib/ld-linux-*.so.* and the multiarch
# libraries itself; forcing the cross-toolchain's libc prefix as well made
# pthread_create hang under qemu 7.2 (two glibc copies in one process).
set(CMAKE_CROSSCOMPILING_EMULATOR "qemu-aarch64")
