# Cross build for 64-bit Arm on Debian (multiarch): Debian's g++-aarch64-linux-gnu compiles, the arm64
# packages in /usr/lib/aarch64-linux-gnu are linked, and qemu-user runs the tests (scripts/test_aarch64.sh).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
# No -L: the arm64 loader and libraries installed by multiarch (libc6:arm64) are found at their own paths.
# The cross toolchain's older libc in /usr/aarch64-linux-gnu mixed with them hangs the first pthread_create.
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64-static)
# The host's libraries are never the target's: pkg-config and find_package look at arm64 folders only.
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)
set(CMAKE_IGNORE_PATH /usr/lib/x86_64-linux-gnu /usr/lib/x86_64-linux-gnu/cmake)
