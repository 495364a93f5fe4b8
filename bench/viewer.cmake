# The web viewer's cost to the bus and simulation threads (docs/benchmarks.md "Viewer"): bus
# latency and missed simulation ticks with a headless-Chromium viewer open and closed, same run.
pkg_check_modules(HTTPLIB_BENCH REQUIRED IMPORTED_TARGET cpp-httplib)
doppel_bus_tool(viewer_load)
target_link_libraries(viewer_load PRIVATE PkgConfig::HTTPLIB_BENCH nlohmann_json::nlohmann_json)
add_test(NAME viewer_load_smoke COMMAND viewer_load --quick)
set_tests_properties(viewer_load_smoke PROPERTIES LABELS bench RUN_SERIAL TRUE SKIP_RETURN_CODE 77)

# Recording's cost (docs/benchmarks.md "Recording"): bus latency and missed simulation ticks with and
# without doppel --record, two runs side by side, phases alternating.
doppel_bus_tool(record_load)
target_link_libraries(record_load PRIVATE PkgConfig::HTTPLIB_BENCH nlohmann_json::nlohmann_json)
add_test(NAME record_load_smoke COMMAND record_load --quick)
set_tests_properties(record_load_smoke PROPERTIES LABELS bench RUN_SERIAL TRUE)

# Wire timing as users run doppel (docs/benchmarks.md "Wire timing as users run it"): physics, the
# camera with a subscriber and the polled viewer added one at a time, beside the bare configuration.
doppel_bus_tool(default_latency)
target_link_libraries(default_latency PRIVATE PkgConfig::HTTPLIB_BENCH nlohmann_json::nlohmann_json)
target_compile_definitions(default_latency PRIVATE DOPPEL_CAMERA_EXECUTABLE="$<TARGET_FILE:doppel-camera>")
add_dependencies(default_latency doppel-camera)
# The camera phases start RouDi (one per machine: CTest lock `roudi`).
add_test(NAME default_latency_smoke COMMAND default_latency --quick)
set_tests_properties(default_latency_smoke PROPERTIES LABELS bench RUN_SERIAL TRUE RESOURCE_LOCK roudi)
