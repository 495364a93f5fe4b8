# Lockstep speed (issue 15): a 1 kHz single-threaded controller on the default robot, simulated
# seconds per wall second under doppel --lockstep and in real time, in one run (docs/benchmarks.md).
if(TARGET lockstep_controller)
  doppel_bus_tool(lockstep_speed)
  target_compile_definitions(lockstep_speed PRIVATE DOPPEL_RUN="$<TARGET_FILE:doppel-run>"
                             LOCKSTEP_CONTROLLER="$<TARGET_FILE:lockstep_controller>")
  add_dependencies(lockstep_speed doppel-run doppel_shim lockstep_controller)
endif()

if(TARGET lockstep_speed)
  # A short run under ctest so the tool cannot rot; the figures come from full runs.
  add_test(NAME lockstep_speed_smoke COMMAND lockstep_speed --seconds 0.5)
  set_tests_properties(lockstep_speed_smoke PROPERTIES LABELS "bench;lockstep")
endif()
