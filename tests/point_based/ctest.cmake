# Extra ctest entries for the point_based area (included from tests/CMakeLists.txt): the Wang18
# example at quick quality with a lighter VPT reference. Seeds are fixed, so the run is
# deterministic; the bounds are what the method achieves (docs/wang18.md): single and double
# within 5 % of the VPT reference restricted to the same path space, multiple within 25 %
# (infinite-medium table), light reflected between events 10-40 % of all scattered light.
if(TARGET wang18_point_based OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/wang18_point_based.cpp))
  add_test(NAME wang18_point_based_json
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:wang18_point_based>
                   "-DARGS=--quality;quick;--vpt-spp;256;--threads;2;--out;${CMAKE_CURRENT_BINARY_DIR}/wang18_point_based"
                   "-DCHECKS=abs(rel_diff_single) < 0.05;abs(rel_diff_double) < 0.05;abs(rel_diff_multiple) < 0.25;bounced_share > 0.1;bounced_share < 0.4;volume_samples > 100000"
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  add_test(NAME wang18_point_based_bad_argument COMMAND $<TARGET_FILE:wang18_point_based> --vpt-spp 1)
  set_tests_properties(wang18_point_based_bad_argument PROPERTIES WILL_FAIL TRUE)
  set_tests_properties(wang18_point_based_json wang18_point_based_bad_argument PROPERTIES LABELS "example;point_based")
endif()
