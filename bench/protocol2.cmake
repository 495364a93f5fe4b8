# Protocol 2.0 end-to-end benchmarks against the real doppel executable (figures in docs/protocol2.md,
# copied to docs/benchmarks.md): per-instruction latency and the Bit-Bots control cycle.
foreach(tool p2_bus_latency p2_bitbots_cycle)
  doppel_bus_tool(${tool})
endforeach()
target_link_libraries(p2_bus_latency PRIVATE util)  # openpty
target_compile_definitions(p2_bitbots_cycle PRIVATE DOPPEL_BENCH_DIR="${CMAKE_CURRENT_SOURCE_DIR}")

# Short runs under ctest so the tools cannot rot; the real figures come from full (>= 60 s) runs.
add_test(NAME p2_bus_latency_smoke COMMAND p2_bus_latency --quick)
add_test(NAME p2_bitbots_cycle_smoke COMMAND p2_bitbots_cycle --quick)
set_tests_properties(p2_bus_latency_smoke p2_bitbots_cycle_smoke PROPERTIES LABELS bench RUN_SERIAL TRUE)
