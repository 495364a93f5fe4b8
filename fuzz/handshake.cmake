# libFuzzer target for the session handshake's input: the frame decoder and the request checks
# (services/handshake/src), compiled again here with coverage; the generated protobuf code from doppel::proto.
add_executable(handshake_frame_fuzz ${CMAKE_CURRENT_SOURCE_DIR}/handshake_frame_fuzz.cpp
               ${PROJECT_SOURCE_DIR}/services/handshake/src/framing.cpp ${PROJECT_SOURCE_DIR}/services/handshake/src/request.cpp)
target_include_directories(handshake_frame_fuzz PRIVATE ${PROJECT_SOURCE_DIR}/services/handshake/include ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(handshake_frame_fuzz PRIVATE doppel::control doppel::proto doppel::build_options)
target_compile_options(handshake_frame_fuzz PRIVATE -fsanitize=fuzzer,address,undefined -fno-omit-frame-pointer)
target_link_options(handshake_frame_fuzz PRIVATE -fsanitize=fuzzer,address,undefined)
