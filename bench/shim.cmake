# What the serial-port shim (libdoppel_shim.so) costs a program (figures in docs/benchmarks.md).
add_executable(shim_bench ${CMAKE_CURRENT_SOURCE_DIR}/shim_bench.cpp)
target_link_libraries(shim_bench PRIVATE benchmark::benchmark_main doppel::build_options ${CMAKE_DL_LIBS})
target_compile_definitions(shim_bench PRIVATE SHIM_LIBRARY="$<TARGET_FILE:doppel_shim>")
add_dependencies(shim_bench doppel_shim)

# A short run under ctest so the benchmark cannot rot; the real figures come from full runs.
add_test(NAME shim_bench_smoke COMMAND shim_bench --benchmark_min_time=0.01)
set_tests_properties(shim_bench_smoke PROPERTIES LABELS "bench;shim")
