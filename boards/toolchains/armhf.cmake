# Cross toolchain for Debian multiarch armhf (arm-linux-gnueabihf).
#   dpkg --add-architecture armhf && apt-get install crossbuild-essential-armhf qemu-user \
#     libasound2-dev:armhf libgpiod-dev:armhf libinih-dev:armhf libcmocka-dev:armhf zlib1g-dev:armhf
#   cmake -S . -B build/cross-armhf -DCMAKE_TOOLCHAIN_FILE=boards/toolchains/armhf.cmake -DHAPTIC_CALIB=OFF
# (scripts/cross-test does this for arm64). ctest runs the tests under qemu-arm
# through CMAKE_CROSSCOMPILING_EMULATOR.
set(HAPTIC_TRIPLE arm-linux-gnueabihf)
set(HAPTIC_PROCESSOR arm)
set(HAPTIC_QEMU qemu-arm)
include(${CMAKE_CURRENT_LIST_DIR}/debian-multiarch.cmake)
