# Shared body of the Debian multiarch cross toolchains (arm64.cmake, armhf.cmake).
# The including file sets HAPTIC_TRIPLE (GNU triple), HAPTIC_PROCESSOR and HAPTIC_QEMU.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR ${HAPTIC_PROCESSOR})
set(CMAKE_C_COMPILER ${HAPTIC_TRIPLE}-gcc)
set(CMAKE_CXX_COMPILER ${HAPTIC_TRIPLE}-g++)
set(CMAKE_LIBRARY_ARCHITECTURE ${HAPTIC_TRIPLE})

# Multiarch: headers in /usr/include, libraries in /usr/lib/<triple>; the cross libc
# lives in /usr/<triple>. Never pick up build-machine programs' libs.
set(CMAKE_FIND_ROOT_PATH /usr/${HAPTIC_TRIPLE})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)

# pkg-config must see only the target architecture's .pc files.
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/${HAPTIC_TRIPLE}/pkgconfig:/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

# No "-L /usr/<triple>": with the multiarch libc6:<arch> installed (a dependency of the
# :<arch> -dev packages) qemu finds /lib/ld-linux-*.so.* and the multiarch libraries
# itself; forcing the cross-toolchain's libc prefix as well made pthread_create hang
# under qemu 7.2 (two glibc copies in one process).
set(CMAKE_CROSSCOMPILING_EMULATOR "${HAPTIC_QEMU}")
