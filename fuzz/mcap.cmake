# libFuzzer target for the MCAP reader: libs/mcap/src compiled again here with coverage and sanitizers,
# so the regular doppel_mcap library stays uninstrumented. Seed corpus: fuzz/make_mcap_corpus.py.
pkg_check_modules(ZSTD_FUZZ REQUIRED IMPORTED_TARGET libzstd)
pkg_check_modules(LZ4_FUZZ REQUIRED IMPORTED_TARGET liblz4)
find_package(ZLIB REQUIRED)
file(GLOB mcap_fuzz_sources CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/libs/mcap/src/*.cpp)
add_library(doppel_mcap_fuzz STATIC ${mcap_fuzz_sources})
target_include_directories(doppel_mcap_fuzz PUBLIC ${PROJECT_SOURCE_DIR}/libs/mcap/include)
target_compile_options(doppel_mcap_fuzz PRIVATE -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer)
target_link_libraries(doppel_mcap_fuzz PRIVATE PkgConfig::ZSTD_FUZZ PkgConfig::LZ4_FUZZ ZLIB::ZLIB doppel::build_options)

add_executable(mcap_reader_fuzz ${CMAKE_CURRENT_SOURCE_DIR}/mcap_reader_fuzz.cpp)
target_include_directories(mcap_reader_fuzz PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(mcap_reader_fuzz PRIVATE doppel_mcap_fuzz doppel::build_options)
target_compile_options(mcap_reader_fuzz PRIVATE -fsanitize=fuzzer,address,undefined -fno-omit-frame-pointer)
target_link_options(mcap_reader_fuzz PRIVATE -fsanitize=fuzzer,address,undefined)
