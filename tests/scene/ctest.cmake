# Crash-safe writers: SIGKILL a writer loop at seeded random moments; targets stay whole.
add_test(NAME crash_safe_writers
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/scene/crash_writers.sh $<TARGET_FILE:test_scene>
                 ${CMAKE_CURRENT_BINARY_DIR}/crash_writers_work 12 20261201)
set_tests_properties(crash_safe_writers PROPERTIES LABELS "unit;scene;crash" TIMEOUT 300
  PASS_REGULAR_EXPRESSION "every target whole after each")
