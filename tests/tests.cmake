# Every tests/test_*.c is one unit-test program (label "unit", also run under the
# sanitizers); every tests/cli/*.sh drives the gaussvid program (label "cli").
set(GV_SHARED_DATA ${CMAKE_SOURCE_DIR}/../shared/data)

# The test programs get the OpenBLAS kernels the gaussvid program chooses for itself
# (src/cli/main.c): on a CPU whose model OpenBLAS does not know it falls back to SSE3 kernels,
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

file(GLOB GV_UNIT_TESTS CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/tests/test_*.c)
foreach(src ${GV_UNIT_TESTS})
  get_filename_component(name ${src} NAME_WE)
  add_executable(${name} ${src})
  target_include_directories(${name} PRIVATE ${CMAKE_SOURCE_DIR}/src ${CMAKE_SOURCE_DIR}/tests)
  target_link_libraries(${name} PRIVATE gaussvid_lib)
  add_test(NAME ${name} COMMAND ${name})
  set_tests_properties(${name} PROPERTIES LABELS unit
    ENVIRONMENT "${GV_TEST_BLAS_CORE};GV_SHARED_DATA=${GV_SHARED_DATA};GV_TMP=${CMAKE_BINARY_DIR}/test-tmp/${name}")
endforeach()

# Every tests/itest_*.c is an integration-test program (label "integration": real training
# runs, too slow for the sanitizer build, which runs only the label "unit").
file(GLOB GV_INTEGRATION_TESTS CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/tests/itest_*.c)
foreach(src ${GV_INTEGRATION_TESTS})
  get_filename_component(name ${src} NAME_WE)
  add_executable(${name} ${src})
  target_include_directories(${name} PRIVATE ${CMAKE_SOURCE_DIR}/src ${CMAKE_SOURCE_DIR}/tests)
  target_link_libraries(${name} PRIVATE gaussvid_lib)
  add_test(NAME ${name} COMMAND ${name})
  set_tests_properties(${name} PROPERTIES LABELS integration
    ENVIRONMENT "${GV_TEST_BLAS_CORE};GV_SHARED_DATA=${GV_SHARED_DATA};GV_TMP=${CMAKE_BINARY_DIR}/test-tmp/${name}")
endforeach()

file(GLOB GV_CLI_TESTS CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/tests/cli/*.sh)
foreach(script ${GV_CLI_TESTS})
  get_filename_component(name ${script} NAME_WE)
  add_test(NAME cli_${name} COMMAND bash ${script} $<TARGET_FILE:gaussvid>)
  set_tests_properties(cli_${name} PROPERTIES LABELS cli
    ENVIRONMENT "${GV_TEST_BLAS_CORE};GV_SHARED_DATA=${GV_SHARED_DATA};GV_TMP=${CMAKE_BINARY_DIR}/test-tmp/cli_${name}")
endforeach()
