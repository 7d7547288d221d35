# Extra ctest entries for the packing area (included from tests/CMakeLists.txt): run the
# `packing` example. tests/ is added before examples/, so test for the example's source as well
# as the target ($<TARGET_FILE:packing> resolves at generate time).
if(TARGET packing OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/packing.cpp))
  # A rate outside (0, 0.64) is an error: exit code 2 and a message naming --fraction.
  add_test(NAME packing_bad_fraction COMMAND $<TARGET_FILE:packing> --fraction 0.7 --spheres 100)
  set_tests_properties(packing_bad_fraction PROPERTIES WILL_FAIL TRUE LABELS "example;packing")
  add_test(NAME packing_bad_fraction_message COMMAND $<TARGET_FILE:packing> --fraction 0 --spheres 100)
  set_tests_properties(packing_bad_fraction_message PROPERTIES PASS_REGULAR_EXPRESSION "--fraction = 0 is outside"
                       LABELS "example;packing")
  add_test(NAME packing_bad_spheres COMMAND $<TARGET_FILE:packing> --fraction 0.5 --spheres -3)
  set_tests_properties(packing_bad_spheres PROPERTIES WILL_FAIL TRUE LABELS "example;packing")
  # Issue 4 acceptance: f = 0.63, N = 2000 reaches >= 0.62 without overlaps, and the mean outer
  # chord agrees with the exact 4R(1-f)/(3f) within 2 %; the written tile loads back.
  add_test(NAME packing_acceptance_063
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:packing>
                   "-DARGS=--fraction;0.63;--spheres;2000;--seed;1;--quality;quick;--out;${CMAKE_CURRENT_BINARY_DIR}/packing_acceptance_063.gltile"
                   -DEXPECT_FILE=${CMAKE_CURRENT_BINARY_DIR}/packing_acceptance_063.gltile
                   "-DCHECKS=fraction >= 0.62;min_center_distance_over_diameter >= 1;abs(mean_chord / dixmier_mean_chord - 1) <= 0.02;spheres == 2000"
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  # A request above what the packer reaches at a fast growth rate: stops at jamming, reports
  # the rate achieved, still no overlaps.
  add_test(NAME packing_jammed_request
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:packing>
                   "-DARGS=--fraction;0.639;--spheres;300;--seed;2;--growth-rate;1"
                   -DEXPECT_STDERR=jammed
                   "-DCHECKS=fraction >= 0.5;fraction < 0.639;min_center_distance_over_diameter >= 1;abs(mean_chord / dixmier_mean_chord - 1) <= 0.05"
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  set_tests_properties(packing_acceptance_063 packing_jammed_request PROPERTIES LABELS "example;packing")
endif()
