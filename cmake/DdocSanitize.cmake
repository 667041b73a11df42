# Compiler flags of the reliability builds (docs/reliability.md), applied to every target.
#
# DDOC_SANITIZE: AddressSanitizer (with leak detection) + UndefinedBehaviorSanitizer, and UBSan
#   halts on the first report (-fno-sanitize-recover), so a report fails the test that caused it.
# DDOC_FUZZ: the parser libraries (ddoc_app_core, ddoc_mujoco) get libFuzzer's coverage
#   instrumentation (DDOC_FUZZ_FLAGS, added in tools/fuzz); tools/fuzz links its targets with
#   -fsanitize=fuzzer. Clang only. (On every target the instrumentation doubled the run time of
#   the Eigen-heavy tests on top of ASan + UBSan.)
# The Python module is not built under the sanitizers: python3 itself is not instrumented, so
# importing it would need LD_PRELOAD of libasan.
if(DDOC_FUZZ AND NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
  message(FATAL_ERROR "DDOC_FUZZ=ON needs clang (libFuzzer): configure a fresh build directory "
                      "with CC=clang CXX=clang++ (Debian: apt-get install clang libclang-rt-14-dev)")
endif()
if(DDOC_FUZZ AND NOT DDOC_SANITIZE)
  message(STATUS "ddoc: DDOC_FUZZ=ON turns DDOC_SANITIZE on (fuzzing without ASan/UBSan finds "
                 "crashes only)")
  set(DDOC_SANITIZE ON CACHE BOOL "" FORCE)
endif()
if(DDOC_SANITIZE)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    message(FATAL_ERROR "DDOC_SANITIZE=ON needs GCC or clang")
  endif()
  # UBSan's per-access pointer checks are left out: ASan traps the out-of-bounds and null
  # accesses they catch, C++17's aligned new gives Eigen its alignment, and with them the
  # Eigen-heavy code ran 3.4x slower (docs/reliability.md, "Sanitizer build").
  set(DDOC_SANITIZE_FLAGS -fsanitize=address,undefined -fno-sanitize-recover=undefined
                          -fno-sanitize=alignment,null,object-size,pointer-overflow
                          -fno-omit-frame-pointer)
  add_compile_options(${DDOC_SANITIZE_FLAGS})
  add_link_options(-fsanitize=address,undefined)
  if(DDOC_BUILD_PYTHON)
    message(STATUS "ddoc: DDOC_SANITIZE=ON: the Python module is not built (python3 is not "
                   "instrumented)")
    set(DDOC_BUILD_PYTHON OFF CACHE BOOL "" FORCE)
  endif()
endif()
if(DDOC_FUZZ)
  set(DDOC_FUZZ_FLAGS -fsanitize=fuzzer-no-link)
endif()
