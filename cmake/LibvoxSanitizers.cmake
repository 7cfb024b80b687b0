# Sanitizer and fuzzer builds (issue 10; docs/fuzzing.md). Both are for testing only: a build
# with either is not meant to be installed.
#
# LIBVOX_SANITIZE: every target (libraries, tools, tests) with AddressSanitizer (LeakSanitizer
# included) and UndefinedBehaviorSanitizer; undefined behaviour aborts (-fno-sanitize-recover),
# so a test that triggers it fails. GCC or clang. scripts/test-sanitizers.sh runs the tests on it.
#
# LIBVOX_BUILD_FUZZERS: the libFuzzer harnesses in fuzz/ (clang only, needs LIBVOX_SANITIZE): the
# libraries get libFuzzer's coverage instrumentation (-fsanitize=fuzzer-no-link), the harnesses
# link libFuzzer (-fsanitize=fuzzer). The tools and tests of the same build stay usable, so one
# clang build serves both the sanitizer tests and the fuzzers.
option(LIBVOX_SANITIZE "Build everything with AddressSanitizer and UndefinedBehaviorSanitizer" OFF)
option(LIBVOX_BUILD_FUZZERS "Build the libFuzzer harnesses in fuzz/ (clang; needs LIBVOX_SANITIZE)" OFF)

if(LIBVOX_BUILD_FUZZERS)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "LIBVOX_BUILD_FUZZERS needs clang, for libFuzzer: configure with -DCMAKE_CXX_COMPILER=clang++ "
                        "(Debian: clang libclang-rt-14-dev)")
  endif()
  if(NOT LIBVOX_SANITIZE)
    message(FATAL_ERROR "LIBVOX_BUILD_FUZZERS needs LIBVOX_SANITIZE=ON: the fuzzers find bugs through the sanitizers")
  endif()
endif()

if(LIBVOX_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
                      # Stack traces with file and line at a fraction of -g's build time.
                      $<IF:$<CXX_COMPILER_ID:Clang>,-gline-tables-only,-g1>
                      # Third-party headers whose undefined behaviour is not libvox's (reasons inside).
                      $<$<CXX_COMPILER_ID:Clang>:-fsanitize-ignorelist=${CMAKE_CURRENT_LIST_DIR}/ubsan-ignorelist.txt>)
  add_link_options(-fsanitize=address,undefined)
endif()

# What every sanitized test runs with (the CTest ENVIRONMENT of tests/ and fuzz/): leaks checked
# with the suppressions in cmake/lsan-suppressions.txt (leaks inside third-party libraries that
# libvox cannot free), stack traces for undefined behaviour. intercept_tls_get_addr=0: clang 14's
# LeakSanitizer, tracking dynamic TLS through __tls_get_addr, reads a bogus block for the main
# thread once the image module (dlopen) has decoded a texture there, and its tracer dies with
# SIGSEGV at exit (test_attribute_encode's ColourBeatsStbDxtHighQuality); without the
# interception dynamic TLS blocks are heap blocks to it like any other.
set(LIBVOX_SANITIZER_ENVIRONMENT
  "ASAN_OPTIONS=detect_leaks=1:check_initialization_order=1:strict_init_order=1:intercept_tls_get_addr=0"
  "LSAN_OPTIONS=suppressions=${CMAKE_CURRENT_LIST_DIR}/lsan-suppressions.txt:print_suppressions=0"
  "UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1")
# The same without leak checking, for the OpenGL tests (label gl): Mesa's driver, loaded with
# dlopen and gone by exit, leaks on every context (128 bytes from a realloc in "<unknown
# module>", which no suppression can name). ASan and UBSan still check them.
string(REPLACE "detect_leaks=1" "detect_leaks=0" LIBVOX_SANITIZER_ENVIRONMENT_WITHOUT_LEAKS "${LIBVOX_SANITIZER_ENVIRONMENT}")
