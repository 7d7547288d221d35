# Extra ctest entries for the aggregates area (included from tests/CMakeLists.txt): run the
# Meng15 aggregate examples. tests/ is added before examples/, so test for the example sources
# as well as the targets ($<TARGET_FILE:...> resolves at generate time).
if(TARGET meng15_fig5_shape_of_grains OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/meng15_fig5_shape_of_grains.cpp))
  # A tiny render writes its images and reports the grain count (hundreds of thousands).
  add_test(NAME meng15_fig5_tiny
           COMMAND $<TARGET_FILE:meng15_fig5_shape_of_grains> --spp 1 --grain-radius 0.01 --threads 2
                   --out ${CMAKE_CURRENT_BINARY_DIR}/meng15_fig5_tiny)
  set_tests_properties(meng15_fig5_tiny PROPERTIES PASS_REGULAR_EXPRESSION "\"grains\":[0-9][0-9][0-9][0-9][0-9]+,"
                       LABELS "example;aggregates")
  add_test(NAME meng15_fig5_bad_grain COMMAND $<TARGET_FILE:meng15_fig5_shape_of_grains> --grain rice --spp 1)
  set_tests_properties(meng15_fig5_bad_grain PROPERTIES PASS_REGULAR_EXPRESSION "--grain = 'rice'" LABELS "example;aggregates")
  add_test(NAME meng15_fig5_bad_grain_exit COMMAND $<TARGET_FILE:meng15_fig5_shape_of_grains> --grain rice --spp 1)
  set_tests_properties(meng15_fig5_bad_grain_exit PROPERTIES WILL_FAIL TRUE LABELS "example;aggregates")
endif()
if(TARGET meng15_fig6_ept_free_flight OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/meng15_fig6_ept_free_flight.cpp))
  # Issue 5 acceptance (Meng15 Fig. 6 bottom): EPT mean free path within 5 % of Eq. 4 for
  # each of the three grains (the JSON reports the largest relative error).
  add_test(NAME meng15_fig6_ept_means_within_5pc
           COMMAND $<TARGET_FILE:meng15_fig6_ept_free_flight> --threads 2 --out ${CMAKE_CURRENT_BINARY_DIR}/meng15_fig6_ept)
  set_tests_properties(meng15_fig6_ept_means_within_5pc PROPERTIES
                       PASS_REGULAR_EXPRESSION "\"max_rel_mean_error\":(0\\.0[0-4][0-9]*|[0-9.]+e-0[3-9])[,}]"
                       LABELS "example;aggregates")
endif()
if(TARGET meng15_fig9_fluence OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/meng15_fig9_fluence.cpp))
  # A small run completes and reports the four L1 distances (too few photons to judge them).
  add_test(NAME meng15_fig9_small
           COMMAND $<TARGET_FILE:meng15_fig9_fluence> --photons 1500 --threads 2 --out ${CMAKE_CURRENT_BINARY_DIR}/meng15_fig9_small)
  set_tests_properties(meng15_fig9_small PROPERTIES PASS_REGULAR_EXPRESSION "\"snow_L1_15\":[0-9.e-]+"
                       LABELS "example;aggregates")
  add_test(NAME meng15_fig9_bad_photons COMMAND $<TARGET_FILE:meng15_fig9_fluence> --photons 5)
  set_tests_properties(meng15_fig9_bad_photons PROPERTIES WILL_FAIL TRUE LABELS "example;aggregates")
endif()
