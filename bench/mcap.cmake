# MCAP writer throughput per chunk compression (figures in docs/benchmarks.md).
add_executable(mcap_bench ${CMAKE_CURRENT_SOURCE_DIR}/mcap_bench.cpp)
target_link_libraries(mcap_bench PRIVATE doppel::mcap doppel::proto benchmark::benchmark_main doppel::build_options)

# A short run under ctest so the benchmark cannot rot; the real figures come from full runs.
add_test(NAME mcap_bench_smoke COMMAND mcap_bench --benchmark_min_time=0.01)
set_tests_properties(mcap_bench_smoke PROPERTIES LABELS "bench;mcap")
