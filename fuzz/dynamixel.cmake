# libFuzzer target for the Protocol 1.0 parser and the device models behind BusDevices.
# The dynamixel sources are compiled again here with coverage and sanitizers, so the regular
# doppel_dynamixel library (linked by bus and gateway) stays uninstrumented.
file(GLOB dynamixel_fuzz_sources CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/libs/dynamixel/src/*.cpp)
add_library(doppel_dynamixel_fuzz STATIC ${dynamixel_fuzz_sources})
target_include_directories(doppel_dynamixel_fuzz PUBLIC ${PROJECT_SOURCE_DIR}/libs/dynamixel/include)
target_compile_options(doppel_dynamixel_fuzz PRIVATE -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer)
target_link_libraries(doppel_dynamixel_fuzz PUBLIC doppel::base PRIVATE doppel::build_options)

add_executable(protocol1_parser_fuzz ${CMAKE_CURRENT_SOURCE_DIR}/protocol1_parser_fuzz.cpp)
target_link_libraries(protocol1_parser_fuzz PRIVATE doppel_dynamixel_fuzz doppel::build_options)
target_compile_options(protocol1_parser_fuzz PRIVATE -fsanitize=fuzzer,address,undefined -fno-omit-frame-pointer)
target_link_options(protocol1_parser_fuzz PRIVATE -fsanitize=fuzzer,address,undefined)
