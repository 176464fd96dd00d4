# Every tests/test_*.c is one unit-test program (label "unit", also run under the
# sanitizers); every tests/cli/*.sh drives the gaussvid program (label "cli").
# The shared scenes (courtyard, livingroom; docs/SCENES.md) are not in the repository: the
# tests that need them look in GV_SHARED_DATA/scenes and are skipped without them. It is
# data/ in the source tree (a copy or a link) unless GV_SHARED_DATA is set when CMake runs.
if(DEFINED ENV{GV_SHARED_DATA})
  set(GV_SHARED_DATA $ENV{GV_SHARED_DATA})
else()
  set(GV_SHARED_DATA ${CMAKE_SOURCE_DIR}/data)
endif()

# The test programs get the OpenBLAS kernels the gaussvid program chooses for itself
# (src/cli/runtime_env.c): on a CPU whose model OpenBLAS does not know it falls back to SSE3 kernels,
# whose results depend on the thread count (test_nn_core's 1- vs 2-thread check failed on
# such a machine). Read from the CPU's flags when the tests are configured; the default leaves
# OpenBLAS's own choice.
set(GV_TEST_BLAS_CORE "OPENBLAS_VERBOSE=0") # OpenBLAS's default: no message
if(EXISTS /proc/cpuinfo)
  file(READ /proc/cpuinfo GV_CPUINFO LIMIT 8192)
  if(GV_CPUINFO MATCHES " avx512f" AND GV_CPUINFO MATCHES " avx512bw" AND GV_CPUINFO MATCHES " avx512dq"
     AND GV_CPUINFO MATCHES " avx512vl")
    set(GV_TEST_BLAS_CORE "OPENBLAS_CORETYPE=SkylakeX")
  elseif(GV_CPUINFO MATCHES " avx2" AND GV_CPUINFO MATCHES " fma")
    set(GV_TEST_BLAS_CORE "OPENBLAS_CORETYPE=Haswell")
  endif()
endif()

# gv_add_test(NAME LABEL COMMAND...): one test with the shared data, its own scratch folder
# and the BLAS kernels above; exit status 77 (CHECK_SKIP, tests/check.h) reads as skipped.
function(gv_add_test name label)
  add_test(NAME ${name} COMMAND ${ARGN})
  set_tests_properties(${name} PROPERTIES LABELS ${label} SKIP_RETURN_CODE 77
    ENVIRONMENT "${GV_TEST_BLAS_CORE};GV_SHARED_DATA=${GV_SHARED_DATA};GV_TMP=${CMAKE_BINARY_DIR}/test-tmp/${name}")
endfunction()

# gv_add_test_programs(GLOB LABEL): every tests/GLOB C file is a test program of that label.
function(gv_add_test_programs pattern label)
  file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/tests/${pattern})
  foreach(src ${sources})
    get_filename_component(name ${src} NAME_WE)
    add_executable(${name} ${src})
    target_include_directories(${name} PRIVATE ${CMAKE_SOURCE_DIR}/src ${CMAKE_SOURCE_DIR}/tests)
    target_link_libraries(${name} PRIVATE gaussvid_lib)
    gv_add_test(${name} ${label} ${name})
  endforeach()
endfunction()

gv_add_test_programs(test_*.c unit)
# Every tests/itest_*.c is an integration-test program (label "integration": real training
# runs, too slow for the sanitizer build, which runs only the label "unit").
gv_add_test_programs(itest_*.c integration)

# The modules' order: no module includes a header of one above it (docs/LAYERS.md).
gv_add_test(layers layout bash ${CMAKE_SOURCE_DIR}/tests/layers.sh ${CMAKE_SOURCE_DIR})

# The browser test's helper: how much of a screenshot's rectangle is unlike a colour.
add_executable(png_unlike ${CMAKE_SOURCE_DIR}/tests/report/png_unlike.c)
target_link_libraries(png_unlike PRIVATE gaussvid_lib)

file(GLOB GV_CLI_TESTS CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/tests/cli/*.sh)
foreach(script ${GV_CLI_TESTS})
  get_filename_component(name ${script} NAME_WE)
  set(helpers "")
  if(name STREQUAL "report_browser")
    set(helpers $<TARGET_FILE:png_unlike>)
  endif()
  gv_add_test(cli_${name} cli bash ${script} $<TARGET_FILE:gaussvid> ${helpers})
endforeach()
