# libFuzzer target for robot files (protobuf text): the loader with its locations and limits
# (libs/proto/src) and the semantic checks of services/gateway/src/robot_config.cpp, compiled again here with
# coverage. Their objects come before the regular libraries on the link line, so the linker takes
# these instrumented copies and the libraries supply only the rest (generated protobuf code,
# device models, lenses, the body compiler).
add_library(doppel_robot_file_fuzz STATIC ${PROJECT_SOURCE_DIR}/services/gateway/src/robot_config.cpp
            ${PROJECT_SOURCE_DIR}/libs/proto/src/text_file.cpp ${PROJECT_SOURCE_DIR}/libs/proto/src/robot_file.cpp
            ${PROJECT_SOURCE_DIR}/libs/proto/src/session_file.cpp)
target_include_directories(doppel_robot_file_fuzz PUBLIC ${PROJECT_SOURCE_DIR}/services/gateway/include)
target_compile_definitions(doppel_robot_file_fuzz PRIVATE DOPPEL_SOURCE_ROBOTS_DIR="${PROJECT_SOURCE_DIR}/data/robots")
target_compile_options(doppel_robot_file_fuzz PRIVATE -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer)
target_link_libraries(doppel_robot_file_fuzz PUBLIC doppel::proto doppel::urdf doppel::body doppel::dynamixel doppel::bus
                      doppel::physics doppel::camera PRIVATE doppel::build_options)

add_executable(robot_file_fuzz ${CMAKE_CURRENT_SOURCE_DIR}/robot_file_fuzz.cpp)
target_link_libraries(robot_file_fuzz PRIVATE doppel_robot_file_fuzz doppel::build_options)
target_compile_options(robot_file_fuzz PRIVATE -fsanitize=fuzzer,address,undefined -fno-omit-frame-pointer)
target_link_options(robot_file_fuzz PRIVATE -fsanitize=fuzzer,address,undefined)
