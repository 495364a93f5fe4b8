# Physics step rate (figures in docs/physics.md, copied to docs/benchmarks.md): one and six standing
# FUmanoid 2011 robots on the 2011 field with the ball, 1 ms step, on ODE and on Bullet.
add_executable(physics_bench ${CMAKE_CURRENT_SOURCE_DIR}/physics_bench.cpp)
target_link_libraries(physics_bench PRIVATE doppel::physics_engines doppel::dynamixel doppel::body benchmark::benchmark_main
                      doppel::build_options)
target_compile_definitions(physics_bench PRIVATE DOPPEL_ROBOTS_DIR="${PROJECT_SOURCE_DIR}/data/robots")

# A short run under ctest so the benchmark cannot rot; the real figures come from full runs.
add_test(NAME physics_bench_smoke COMMAND physics_bench --benchmark_min_time=0.01 --benchmark_filter=robots:1/)
set_tests_properties(physics_bench_smoke PROPERTIES LABELS "bench;physics")
