# Cross toolchain for Debian multiarch arm64 (aarch64-linux-gnu).
#   dpkg --add-architecture arm64 && apt-get install crossbuild-essential-arm64 qemu-user \
#     libasound2-dev:arm64 libgpiod-dev:arm64 libinih-dev:arm64 libcmocka-dev:arm64 zlib1g-dev:arm64
#   cmake -S . -B build/cross-arm64 -DCMAKE_TOOLCHAIN_FILE=boards/toolchains/arm64.cmake -DHAPTIC_CALIB=OFF
# (scripts/cross-test does this for arm64). ctest runs the tests under qemu-aarch64
# through CMAKE_CROSSCOMPILING_EMULATOR.
set(HAPTIC_TRIPLE aarch64-linux-gnu)
set(HAPTIC_PROCESSOR aarch64)
set(HAPTIC_QEMU qemu-aarch64)
include(${CMAKE_CURRENT_LIST_DIR}/debian-multiarch.cmake)
