# Compiler flags shared by every relume target: warnings are errors, optional sanitizers.
add_library(relume_compile_options INTERFACE)
target_compile_options(relume_compile_options INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
  -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough
  # Every target threads (std::thread), and some dependencies add -pthread anyway: one setting
  # everywhere keeps the shared precompiled headers valid (-pthread defines _REENTRANT).
  -pthread)
target_link_options(relume_compile_options INTERFACE -pthread)
if(RELUME_WERROR)
  target_compile_options(relume_compile_options INTERFACE -Werror)
endif()
if(RELUME_SANITIZE)
  # UBSan without four of its checks, whose instrumentation of every inlined Eigen/OpenCV
  # pointer access is most of its compile time (sh_fit.cc: 60 s -> 35 s at -O1, docs/ci.md):
  # null and object-size (ASan reports the dereference or overflow itself), alignment
  # (misaligned loads do not fault on x86; SSE ones would, and then crash the test) and
  # pointer-overflow. Signed overflow, shifts, division by zero, float-cast overflow, bounds,
  # bool/enum loads, vptr, return and unreachable stay checked.
  target_compile_options(relume_compile_options INTERFACE
    -fsanitize=address,undefined -fno-sanitize=alignment,null,object-size,pointer-overflow
    -fno-sanitize-recover=all -fno-omit-frame-pointer)
  target_link_options(relume_compile_options INTERFACE -fsanitize=address,undefined)
endif()

if(RELUME_LIBFUZZER)
  # Coverage for libFuzzer in every library the harnesses link (fuzz/CMakeLists.txt); the
  # harnesses themselves link the engine with -fsanitize=fuzzer. Needs clang.
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "RELUME_LIBFUZZER needs clang (scripts/fuzz.sh sets CXX=clang++)")
  endif()
  target_compile_options(relume_compile_options INTERFACE -fsanitize=fuzzer-no-link)
endif()

# Precompiled headers (RELUME_PCH): the third-party headers almost every translation unit
# parses (Eigen, OpenCV core, nlohmann/json, the standard library; GoogleTest for tests; 1-2 s
# each). Measured on the 2-core machine, clean Release build at -j2 without ccache: 13.2 min
# (25.0 CPU-min) without, 12.0 min (22.4 CPU-min) with: -O3 code generation, not parsing, is
# most of the build. The sanitizer build uses them too (sh_fit.cc 35 s -> 30 s there). Two
# anchor targets compile them
# once per build flavour; every library reuses the first, every test the second. GCC accepts a
# reused header only when the macros it depends on match, which holds because relume's own
# definitions (RELUME_BINARY, RELUME_HAVE_*, ...) appear in no third-party header.
set(RELUME_PCH_HEADERS
  <algorithm> <array> <chrono> <cmath> <cstdint> <filesystem> <functional> <limits> <map> <memory>
  <optional> <span> <string> <string_view> <vector>
  <Eigen/Core> <Eigen/Geometry> <opencv2/core.hpp> <nlohmann/json.hpp>)
# Called once the dependencies are found (CMakeLists.txt).
function(relume_add_pch_anchors)
  if(NOT RELUME_PCH)
    return()
  endif()
  add_library(relume_pch_library STATIC ${PROJECT_SOURCE_DIR}/cmake/pch_anchor.cc)
  # Position-independent like every library that reuses its header (relume_add_library).
  set_target_properties(relume_pch_library PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_link_libraries(relume_pch_library PRIVATE relume_compile_options Eigen3::Eigen opencv_core
                        nlohmann_json::nlohmann_json)
  target_precompile_headers(relume_pch_library PRIVATE ${RELUME_PCH_HEADERS})
  add_library(relume_pch_test STATIC ${PROJECT_SOURCE_DIR}/cmake/pch_anchor.cc)
  target_link_libraries(relume_pch_test PRIVATE relume_compile_options Eigen3::Eigen opencv_core
                        nlohmann_json::nlohmann_json GTest::gmock GTest::gtest)
  target_precompile_headers(relume_pch_test PRIVATE ${RELUME_PCH_HEADERS} <gtest/gtest.h>)
endfunction()

# relume_add_library(NAME SOURCES ... DEPS ...): one static library per layer.
function(relume_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  # -fPIC: the Python module (python/) is a shared object that links these static libraries.
  set_target_properties(${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PUBLIC ${ARG_DEPS} PRIVATE relume_compile_options ${ARG_PRIVATE_DEPS})
  if(RELUME_PCH)
    target_precompile_headers(${name} REUSE_FROM relume_pch_library)
  endif()
endfunction()

# relume_add_test(NAME SOURCES ... DEPS ... [LABELS ...] [WHOLE_SUITES SUITE ...] [TEST_PREFIX P]):
# one GoogleTest executable, its tests discovered into CTest (each WHOLE_SUITES suite as one test),
# their CTest names prefixed with P when given (`batch.` lets `ctest -R batch` find a layer's tests).
function(relume_add_test name)
  cmake_parse_arguments(ARG "" "TEST_PREFIX" "SOURCES;DEPS;LABELS;WHOLE_SUITES" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gmock GTest::gtest_main relume_compile_options)
  if(RELUME_PCH)
    target_precompile_headers(${name} REUSE_FROM relume_pch_test)
  endif()
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  # A suite whose SetUpTestSuite is expensive (a rendered room, a captured session) runs as one
  # CTest test, in one process, so the setup is paid once instead of once per case.
  set(filter "")
  foreach(suite ${ARG_WHOLE_SUITES})
    add_test(NAME ${ARG_TEST_PREFIX}${suite}.all COMMAND ${name} --gtest_filter=${suite}.*
             WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
    set_tests_properties(${ARG_TEST_PREFIX}${suite}.all PROPERTIES LABELS "${ARG_LABELS}")
    string(APPEND filter ":${suite}.*")
  endforeach()
  if(filter)
    string(SUBSTRING "${filter}" 1 -1 filter)
    gtest_discover_tests(${name}
      WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
      TEST_PREFIX "${ARG_TEST_PREFIX}"
      TEST_FILTER "-${filter}"
      PROPERTIES LABELS "${ARG_LABELS}"
      DISCOVERY_TIMEOUT 60)
  else()
    gtest_discover_tests(${name}
      WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
      TEST_PREFIX "${ARG_TEST_PREFIX}"
      PROPERTIES LABELS "${ARG_LABELS}"
      DISCOVERY_TIMEOUT 60)
  endif()
endfunction()

# relume_add_benchmark(NAME SOURCES ... DEPS ...): a Google Benchmark executable, plus a
# CTest smoke run (label "benchmark") that proves it runs; its numbers are not asserted.
function(relume_add_benchmark name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  if(NOT RELUME_BUILD_BENCHMARKS)
    return()
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} benchmark::benchmark relume_compile_options)
  add_test(NAME ${name}.smoke COMMAND ${name} --benchmark_min_time=0.01)
  set_tests_properties(${name}.smoke PROPERTIES LABELS benchmark)
endfunction()
