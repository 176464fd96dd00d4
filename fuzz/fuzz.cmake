# libFuzzer harnesses (docs/RELIABILITY.md), built only with -DGV_FUZZ=ON and clang:
#   CC=clang cmake -S . -B build-fuzz -DGV_FUZZ=ON && cmake --build build-fuzz --target fuzzers
# The library is compiled with coverage instrumentation (fuzzer-no-link) and the sanitizers;
# each fuzz/fuzz_NAME.c links it with libFuzzer's main. `make fuzz` runs them (fuzz/run.sh).
set(GV_FUZZ_FLAGS -O1 -g -Wno-unknown-warning-option -Wno-pass-failed -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
target_compile_options(gaussvid_lib PRIVATE ${GV_FUZZ_FLAGS} -fsanitize=fuzzer-no-link)
target_link_options(gaussvid_lib INTERFACE -fsanitize=address,undefined)

file(GLOB GV_FUZZ_SOURCES CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/fuzz/fuzz_*.c)
add_custom_target(fuzzers)
foreach(src ${GV_FUZZ_SOURCES})
  get_filename_component(name ${src} NAME_WE)
  add_executable(${name} EXCLUDE_FROM_ALL ${src})
  target_include_directories(${name} PRIVATE ${CMAKE_SOURCE_DIR}/src ${CMAKE_SOURCE_DIR}/fuzz)
  target_compile_options(${name} PRIVATE ${GV_FUZZ_FLAGS} -fsanitize=fuzzer)
  target_link_options(${name} PRIVATE -fsanitize=fuzzer)
  target_link_libraries(${name} PRIVATE gaussvid_lib)
  add_dependencies(fuzzers ${name})
endforeach()
