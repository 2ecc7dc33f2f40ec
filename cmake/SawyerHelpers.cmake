# Shared CMake helpers for Sawyer targets.

# One INTERFACE target carries the warning flags; every Sawyer target links it privately.
add_library(sawyer_warnings INTERFACE)
target_compile_options(sawyer_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow -Wno-unused-parameter>)
add_library(sawyer::warnings ALIAS sawyer_warnings)

# sawyer_add_library(<name> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# Creates sawyer_<name> with alias sawyer::<name>; public headers live in include/.
function(sawyer_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(sawyer_${name} STATIC ${ARG_SOURCES})
  add_library(sawyer::${name} ALIAS sawyer_${name})
  target_include_directories(sawyer_${name}
    PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(sawyer_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS} sawyer::warnings)
  set_target_properties(sawyer_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()

# sawyer_add_test(<name> [CLI] [LIBS ...]): tests/<name>_test.cpp, each TEST discovered by CTest on
# its own. CLI: the test runs the `sawyer` command line, so it waits for it to be built; the other
# test programs build from the libraries they link alone.
function(sawyer_add_test name)
  cmake_parse_arguments(ARG "CLI" "" "LIBS" ${ARGN})
  add_executable(${name}_test ${name}_test.cpp)
  target_link_libraries(${name}_test PRIVATE sawyer::test_util ${ARG_LIBS} GTest::gmock GTest::gtest GTest::gtest_main sawyer::warnings)
  if(ARG_CLI)
    add_dependencies(${name}_test sawyer)  # the test runs the command line
  endif()
  gtest_discover_tests(${name}_test
    WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR}
    DISCOVERY_TIMEOUT 60)
endfunction()
