# libFuzzer target for URDF import: libs/urdf/src/urdf_import.cpp compiled again with coverage, before
# the regular libraries on the link line (as robot_file.cmake does).
add_library(doppel_urdf_fuzz STATIC ${PROJECT_SOURCE_DIR}/libs/urdf/src/urdf_import.cpp)
target_include_directories(doppel_urdf_fuzz PUBLIC ${PROJECT_SOURCE_DIR}/libs/urdf/include)
target_compile_options(doppel_urdf_fuzz PRIVATE -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer)
target_link_libraries(doppel_urdf_fuzz PUBLIC doppel::proto doppel::physics PkgConfig::URDFDOM PkgConfig::TINYXML
                      assimp::assimp PRIVATE doppel::build_options)

add_executable(urdf_fuzz ${CMAKE_CURRENT_SOURCE_DIR}/urdf_fuzz.cpp)
target_link_libraries(urdf_fuzz PRIVATE doppel_urdf_fuzz doppel::build_options)
target_compile_options(urdf_fuzz PRIVATE -fsanitize=fuzzer,address,undefined -fno-omit-frame-pointer)
target_link_options(urdf_fuzz PRIVATE -fsanitize=fuzzer,address,undefined)
