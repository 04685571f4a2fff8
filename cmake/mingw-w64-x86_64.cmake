# Cross-compiling for 64-bit Windows with MinGW-w64 (Debian: g++-mingw-w64-x86-64-posix,
# the POSIX-threads flavour, which std::thread and std::mutex need).
#
#   cmake -S . -B build/windows-template_debug \
#     -DCMAKE_TOOLCHAIN_FILE=cmake/mingw-w64-x86_64.cmake ...
#
# scripts/build_windows.sh sets up the rest (ONNX Runtime's import library).
# Every binary links libgcc, libstdc++ and winpthread statically, so the only
# DLLs it needs beside the system's are onnxruntime.dll and ardy_c.dll.
set(CMAKE_SYSTEM_NAME Windows)
set(CMAKE_SYSTEM_PROCESSOR x86_64)

set(MINGW_TRIPLE x86_64-w64-mingw32 CACHE STRING "MinGW-w64 target triple")
set(MINGW_THREADS posix CACHE STRING "Compiler flavour suffix: posix (std::thread) or win32")
find_program(CMAKE_C_COMPILER NAMES ${MINGW_TRIPLE}-gcc-${MINGW_THREADS} ${MINGW_TRIPLE}-gcc REQUIRED)
find_program(CMAKE_CXX_COMPILER NAMES ${MINGW_TRIPLE}-g++-${MINGW_THREADS} ${MINGW_TRIPLE}-g++ REQUIRED)
find_program(CMAKE_RC_COMPILER NAMES ${MINGW_TRIPLE}-windres windres)
find_program(CMAKE_AR NAMES ${MINGW_TRIPLE}-gcc-ar-${MINGW_THREADS} ${MINGW_TRIPLE}-ar)
find_program(CMAKE_RANLIB NAMES ${MINGW_TRIPLE}-gcc-ranlib-${MINGW_THREADS} ${MINGW_TRIPLE}-ranlib)

set(CMAKE_FIND_ROOT_PATH /usr/${MINGW_TRIPLE})
# Host programs (Python, the Linux Godot that dumps the extension interface)
# come from the host; libraries and headers from the MinGW root or from the
# explicit paths the project's cache variables give.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# onnxruntime_c_api.h writes "void*(ORT_API_CALL* Alloc)(...)" with ORT_API_CALL
# = _stdcall, which GCC predefines as an attribute it cannot parse in that
# place. The calling convention means nothing on x86_64, so it is spelled empty.
set(CMAKE_C_FLAGS_INIT "-U_stdcall -D_stdcall=")
set(CMAKE_CXX_FLAGS_INIT "-U_stdcall -D_stdcall=")

# No MinGW runtime DLL (libstdc++-6, libgcc_s_seh-1, libwinpthread-1) at run time.
set(CMAKE_EXE_LINKER_FLAGS_INIT "-static")
set(CMAKE_SHARED_LINKER_FLAGS_INIT "-static")
set(CMAKE_MODULE_LINKER_FLAGS_INIT "-static")
