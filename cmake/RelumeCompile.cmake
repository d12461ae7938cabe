# Compiler flags shared by every relume target: warnings are errors, optional sanitizers.
add_library(relume_compile_options INTERFACE)
target_compile_options(relume_compile_options INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
  -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough)
if(RELUME_WERROR)
  target_compile_options(relume_compile_options INTERFACE -Werror)
endif()
if(RELUME_SANITIZE)
  target_compile_options(relume_compile_options INTERFACE
    -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
  target_link_options(relume_compile_options INTERFACE -fsanitize=address,undefined)
endif()

# relume_add_library(NAME SOURCES ... DEPS ...): one static library per layer.
function(relume_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PUBLIC ${ARG_DEPS} PRIVATE relume_compile_options ${ARG_PRIVATE_DEPS})
endfunction()

# relume_add_test(NAME SOURCES ... DEPS ... [LABELS ...]): one GoogleTest executable,
# its tests discovered into CTest.
function(relume_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gmock GTest::gtest_main relume_compile_options)
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  gtest_discover_tests(${name}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    PROPERTIES LABELS "${ARG_LABELS}"
    DISCOVERY_TIMEOUT 60)
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
