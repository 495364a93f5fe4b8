# V4L2 under the shim vs the iceoryx client: frame latency and CPU per frame (docs/benchmarks.md).
add_executable(v4l2_latency ${CMAKE_CURRENT_SOURCE_DIR}/v4l2_latency.cpp)
target_link_libraries(v4l2_latency PRIVATE doppel::camera doppel::demo_scene CLI11::CLI11 doppel::build_options)
target_compile_definitions(v4l2_latency PRIVATE SHIM_LIBRARY="$<TARGET_FILE:doppel_shim>"
                           V4L2_MODULE="$<TARGET_FILE:doppel_v4l2>")
add_dependencies(v4l2_latency doppel_shim doppel_v4l2)
add_test(NAME v4l2_latency_smoke COMMAND v4l2_latency --frames 20 --fps 60)
set_tests_properties(v4l2_latency_smoke PROPERTIES LABELS "bench;camera;shim" RESOURCE_LOCK roudi)
