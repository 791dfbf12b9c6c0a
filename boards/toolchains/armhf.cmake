# Cross toolchain for Debian multiarch armhf (arm-linux-gnueabihf).
#   dpkg --add-architecture armhf && apt-get install crossbuild-essential-armhf qemu-user \
#     libasound2-dev:armhf libgpiod-dev:armhf libinih-dev:armhf libcmocka-dev:armhf zlib1g-dev:armhf
#   cmake -S . -B build/cross-armhf -DCMAKE_TOOLCHAIN_FILE=boards/toolchains/armhf.cmake -DHAPTIC_CALIB=OFF
# (scripts/cross-test does this for arm64). ctest runs the tests under qemu-arm
# through CMAKE_CROSSCOMPILING_EMULATOR.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-linux-gnueabihf-gcc)
set(CMAKE_CXX_COMPILER arm-linux-gnueabihf-g++)
set(CMAKE_LIBRARY_ARCHITECTURE arm-linux-gnueabihf)

# Multiarch: headers in /usr/include, libraries in /usr/lib/arm-linux-gnueabihf; the
# cross libc lives in /usr/arm-linux-gnueabihf. Never pick up build-machine programs' libs.
set(CMAKE_FIND_ROOT_PATH /usr/arm-linux-gnueabihf)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)

# pkg-config must see only the armhf .pc files.
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/arm-linux-gnueabihf/pkgconfig:/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

# No "-L /usr/arm-linux-gnueabihf": with the multiarch libc6:armhf installed (a dependency
# of the :armhf -dev packages) qemu finds /lib/ld-linux-*.so.* and the multiarch
# libraries itself; forcing the cross-toolchain's libc prefix as well made
# pthread_create hang under qemu 7.2 (two glibc copies in one process).
set(CMAKE_CROSSCOMPILING_EMULATOR "qemu-arm")
