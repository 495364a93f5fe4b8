# End-to-end bus benchmarks against the real doppel executable (figures in docs/benchmarks.md).
foreach(tool bus_latency bus_throughput control_loop reopen_race flush_loss first_answer)
  doppel_bus_tool(${tool})
endforeach()
target_link_libraries(control_loop PRIVATE doppel::base)
target_link_libraries(bus_latency PRIVATE util)  # openpty

# Short runs under ctest so the tools cannot rot; the real figures come from full runs.
add_test(NAME bus_latency_smoke COMMAND bus_latency --quick)
add_test(NAME bus_throughput_smoke COMMAND bus_throughput --seconds 0.3)
add_test(NAME control_loop_smoke COMMAND control_loop --seconds 0.5 --reply-timeout-ms 2000)
add_test(NAME reopen_race_smoke COMMAND reopen_race --startups 20 --load 0)
add_test(NAME flush_loss_smoke COMMAND flush_loss --packets 200 --timing fast)
set_tests_properties(bus_latency_smoke bus_throughput_smoke control_loop_smoke reopen_race_smoke flush_loss_smoke
                     PROPERTIES LABELS bench RUN_SERIAL TRUE)

# doppel with its defaults starts RouDi (the camera): one at a time per machine (CTest lock `roudi`).
add_test(NAME first_answer_smoke COMMAND first_answer --starts 2)
set_tests_properties(first_answer_smoke PROPERTIES LABELS bench RUN_SERIAL TRUE RESOURCE_LOCK roudi)

# What serving a bus over loopback TCP (scripts/serve-network: ser2net, socat) adds to a round trip.
doppel_bus_tool(network_latency)
add_test(NAME network_latency_smoke COMMAND network_latency --quick)
set_tests_properties(network_latency_smoke PROPERTIES LABELS bench RUN_SERIAL TRUE SKIP_RETURN_CODE 77)
