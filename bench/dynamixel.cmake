# Protocol 1.0 codec and device-dispatch benchmarks (figures in docs/benchmarks.md).
add_executable(codec_bench ${CMAKE_CURRENT_SOURCE_DIR}/codec_bench.cpp)
target_link_libraries(codec_bench PRIVATE doppel::dynamixel benchmark::benchmark_main doppel::build_options)

# A short run under ctest so the benchmark cannot rot; the real figures come from full runs.
add_test(NAME codec_bench_smoke COMMAND codec_bench --benchmark_min_time=0.01)
set_tests_properties(codec_bench_smoke PROPERTIES LABELS "bench;dynamixel")
