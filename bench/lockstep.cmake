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

# What a lockstep cycle cannot cost less than on this machine besides the physics (issue 26):
# a process hand-over and the pty's bytes both ways, beside a null system call.
add_executable(lockstep_floor ${CMAKE_CURRENT_SOURCE_DIR}/lockstep_floor.cpp)
target_link_libraries(lockstep_floor PRIVATE benchmark::benchmark_main doppel::build_options)
add_test(NAME lockstep_floor_smoke COMMAND lockstep_floor --benchmark_min_time=0.01)
set_tests_properties(lockstep_floor_smoke PROPERTIES LABELS "bench;lockstep")
