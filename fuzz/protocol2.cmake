# libFuzzer target for the Protocol 2.0 parser, the mixed P1/P2 framer and the P2 device models.
# Links the instrumented copy of the dynamixel sources that fuzz/dynamixel.cmake builds.
add_executable(protocol2_parser_fuzz ${CMAKE_CURRENT_SOURCE_DIR}/protocol2_parser_fuzz.cpp)
target_link_libraries(protocol2_parser_fuzz PRIVATE doppel_dynamixel_fuzz doppel::build_options)
target_compile_options(protocol2_parser_fuzz PRIVATE -fsanitize=fuzzer,address,undefined -fno-omit-frame-pointer)
target_link_options(protocol2_parser_fuzz PRIVATE -fsanitize=fuzzer,address,undefined)
