# Camera benchmarks (figures in docs/camera.md, copied to docs/benchmarks.md):
#   camera_render   render rate per pixel format, resolution and thread count, six-robot scene
#   camera_latency  publish -> subscriber-holds-frame latency, iceoryx (busy poll, WaitSet) and the
#                   same frame over a Unix domain socket, at several frame sizes, in one run
add_executable(camera_render ${CMAKE_CURRENT_SOURCE_DIR}/camera_render.cpp)
target_link_libraries(camera_render PRIVATE doppel::camera doppel::demo_scene benchmark::benchmark_main doppel::build_options)
add_executable(camera_latency ${CMAKE_CURRENT_SOURCE_DIR}/camera_latency.cpp)
target_link_libraries(camera_latency PRIVATE doppel::camera doppel::demo_scene doppel::base benchmark::benchmark Threads::Threads
                      doppel::build_options)

# Short runs under ctest so the benchmarks cannot rot; camera_latency starts RouDi in-process.
add_test(NAME camera_render_smoke
         COMMAND camera_render --benchmark_min_time=0.01 --benchmark_filter=yuyv/640x480/threads:1)
add_test(NAME camera_latency_smoke COMMAND camera_latency --benchmark_min_time=0.01 --benchmark_filter=320x240)
set_tests_properties(camera_render_smoke camera_latency_smoke PROPERTIES LABELS "bench;camera")
set_tests_properties(camera_latency_smoke PROPERTIES RESOURCE_LOCK roudi)
