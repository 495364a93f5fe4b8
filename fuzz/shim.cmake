# libFuzzer target for what the preload library (shim/) parses: the port map, sysfs paths and the
# latency-timer text. The parser is compiled again here with coverage.
add_executable(shim_inputs_fuzz ${CMAKE_CURRENT_SOURCE_DIR}/shim_inputs_fuzz.cpp ${PROJECT_SOURCE_DIR}/programs/shim/src/port_map.cpp)
target_include_directories(shim_inputs_fuzz PRIVATE ${PROJECT_SOURCE_DIR}/programs/shim/include ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(shim_inputs_fuzz PRIVATE doppel::base doppel::build_options)
target_compile_options(shim_inputs_fuzz PRIVATE -fsanitize=fuzzer,address,undefined -fno-omit-frame-pointer)
target_link_options(shim_inputs_fuzz PRIVATE -fsanitize=fuzzer,address,undefined)
