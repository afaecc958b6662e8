# One place that applies the language level, warnings and sanitizers to every tellus target.

function(tellus_apply_options target)
  target_compile_features(${target} PUBLIC cxx_std_23)
  set_target_properties(${target} PROPERTIES CXX_EXTENSIONS OFF)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wconversion -Wsign-conversion -Wshadow -Wnon-virtual-dtor
    -Wold-style-cast -Wcast-align -Wdouble-promotion -Wformat=2
    -Wimplicit-fallthrough)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    # g++ 12 reports false -Wrestrict positives inside std::string at -O2/-O3 (GCC bug 105329).
    # g++ only: clang has no -Wrestrict and rejects the unknown option under -Werror.
    target_compile_options(${target} PRIVATE -Wno-restrict)
  endif()
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 19)
    # libstdc++ 12 offers <expected> only when __cpp_concepts >= 202002L; clang before 19 says
    # 201907L although clang 16+ implements what the header needs (P0848, conditionally trivial
    # special members). Clang is the fuzzing compiler (TELLUS_FUZZ, the "fuzz" preset).
    target_compile_options(${target} PRIVATE -U__cpp_concepts -D__cpp_concepts=202002L)
  endif()
  if(TELLUS_UNITY_BUILD AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    # g++ warns when a class with external linkage defined in a header has a member or base of an
    # anonymous-namespace type; a unity batch includes the .cpp files, so it takes them for headers.
    target_compile_options(${target} PRIVATE -Wno-subobject-linkage)
  endif()
  # Same floating-point results on every platform: no fused multiply-add contraction (tile edges
  # must be bit-identical to what World Wind computes).
  target_compile_options(${target} PRIVATE -ffp-contract=off)
  if(TELLUS_WARNINGS_AS_ERRORS)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(TELLUS_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=${TELLUS_SANITIZE} -fno-omit-frame-pointer
                                             -fno-sanitize-recover=all)
    target_link_options(${target} PRIVATE -fsanitize=${TELLUS_SANITIZE})
    if(TELLUS_SANITIZE MATCHES "thread")
      # ThreadSanitizer does not model std::atomic_thread_fence (g++ refuses it with -Werror=tsan).
      # Asio fences handler memory only on top of its scheduler's mutexes, which TSan does see.
      target_compile_definitions(${target} PRIVATE BOOST_ASIO_DISABLE_FENCED_BLOCK)
    endif()
  endif()
endfunction()

# tellus_add_library(<module> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# Creates tellus_<module> with the alias tellus::<module>; include/ is public, src/ private.
function(tellus_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(tellus_${name} STATIC ${ARG_SOURCES})
  add_library(tellus::${name} ALIAS tellus_${name})
  target_include_directories(tellus_${name}
    PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(tellus_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  tellus_apply_options(tellus_${name})
endfunction()

# tellus_add_module(<module> SOURCES ... [PRIVATE_DEPS ...])
# A module loaded at run time with dlopen() and never linked: tellus_<module> is a MODULE library
# built from src/ that exports one extern "C" function table and nothing else (hidden visibility);
# tellus::<module>_api is an INTERFACE target with include/, the table's header, for the loader.
# Third-party libraries linked here (PRIVATE) are mapped only when the module is loaded.
function(tellus_add_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PRIVATE_DEPS" ${ARGN})
  add_library(tellus_${name}_api INTERFACE)
  add_library(tellus::${name}_api ALIAS tellus_${name}_api)
  target_include_directories(tellus_${name}_api INTERFACE ${CMAKE_CURRENT_SOURCE_DIR}/include)
  add_library(tellus_${name} MODULE ${ARG_SOURCES})
  target_include_directories(tellus_${name} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(tellus_${name} PRIVATE tellus_${name}_api ${ARG_PRIVATE_DEPS})
  set_target_properties(tellus_${name} PROPERTIES
    CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  if(NOT TELLUS_SANITIZE)
    # An unresolved symbol fails the link, not the first dlopen(). (Sanitized modules leave the
    # runtime's symbols to the executable, which clang does not link into shared objects.)
    target_link_options(tellus_${name} PRIVATE LINKER:--no-undefined)
  endif()
  tellus_apply_options(tellus_${name})
endfunction()

# tellus_add_test(<name> SOURCES ... LIBS ...): one GoogleTest executable per module. ctest labels
# come from the test suite's name, so one executable can hold several kinds of test:
#   suite name ends in ExtremesGl  -> labels "gl;extremes" (rendered extremes, under xvfb-run)
#   suite name ends in Extremes    -> labels "unit;extremes"
#   suite name ends in Integration -> label "integration"
#   suite name ends in Slow        -> labels "slow;integration"
#   suite name ends in Gl          -> label "gl" (run under xvfb-run by `make test`)
#   anything else                  -> label "unit"
function(tellus_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE
    TELLUS_TEST_DATA_DIR="${TELLUS_SOURCE_DATA_DIR}"
    TELLUS_TEST_SOURCE_DIR="${CMAKE_SOURCE_DIR}/tests"
    TELLUS_TEST_TMP_DIR="${CMAKE_BINARY_DIR}/test-tmp")
  tellus_apply_options(${name})
  # Several labels per test cannot go through gtest_discover_tests(PROPERTIES LABELS "a;b"): the
  # list is split into separate arguments on its way into the generated script (LABELS a, then a
  # property named b). So each kind's discovered tests are named in a variable (TEST_LIST) and a
  # small script included after the discovery sets their LABELS as a list.
  set(kinds ExtremesGl Extremes Integration Slow Gl Unit)
  set(labels "gl,extremes" "unit,extremes" integration "slow,integration" gl unit)
  set(exclude "")
  foreach(kind label IN ZIP_LISTS kinds labels)
    if(kind STREQUAL "Unit")
      string(SUBSTRING "${exclude}" 1 -1 exclude)
      set(filter "-${exclude}")
    elseif(kind STREQUAL "Gl")
      set(filter "*Gl.*-*ExtremesGl.*") # those have their own entry above
    else()
      set(filter "*${kind}.*")
    endif()
    string(APPEND exclude ":*${kind}.*")
    set(list_var ${name}_${kind}_TESTS)
    gtest_discover_tests(${name} TEST_FILTER "${filter}" TEST_LIST ${list_var}
                         PROPERTIES TIMEOUT 300 DISCOVERY_TIMEOUT 60)
    string(REPLACE "," ";" label_list "${label}")
    set(label_script ${CMAKE_CURRENT_BINARY_DIR}/${name}_${kind}_labels.cmake)
    file(WRITE ${label_script}
         "if(${list_var})\n  set_tests_properties(\${${list_var}} PROPERTIES LABELS \"${label_list}\")\nendif()\n")
    set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${label_script})
  endforeach()
endfunction()

# tellus_unity_skip(<file> ...): files (relative to the current source directory) that a unity build
# (TELLUS_UNITY_BUILD) compiles on their own, because a file-local name of theirs clashes with one
# of another file of the same target. Recorded by absolute path, so that the fuzz libraries, which
# compile some of the same files from fuzz/, leave them out of their batches as well. Renaming the
# clashing names (or sharing them through a header) takes a file off these lists.
function(tellus_unity_skip)
  foreach(f IN LISTS ARGN)
    get_filename_component(abs ${f} ABSOLUTE)
    set_source_files_properties(${abs} PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)
    set_property(GLOBAL APPEND PROPERTY TELLUS_UNITY_SKIPPED ${abs})
  endforeach()
endfunction()
