# Extra ctest entries for the shells area (included from tests/CMakeLists.txt): the
# moon07_shell_transport example at a reduced path count (~3 s) and its bad-argument handling.
if(TARGET moon07_shell_transport OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/moon07_shell_transport.cpp))
  set(_m7 $<TARGET_FILE:moon07_shell_transport>)
  set(_m7out ${CMAKE_CURRENT_BINARY_DIR}/moon07_out)
  # Shell stepping with a table from 5000 explicit glass-sphere paths reproduces the explicit
  # mean-square displacement of chained r = 8 R spheres within 5 % (measured: 1.2 %), and the
  # NMF (rank 5) reconstructs the k-NN density within 10 % (measured: 4.5 %); the Fig. 6 shadow-ray
  # estimate of the light reaching a small cone light agrees with counting hits.
  add_test(NAME moon07_shell_transport_json
           COMMAND ${CMAKE_COMMAND} -DEXE=${_m7} "-DARGS=--paths;5000;--threads;2;--out;${_m7out}"
                   "-DCHECKS=max_msd_rel_diff <= 0.05;nmf_error <= 0.1;msd_explicit_last > 64;abs(direct_hits - direct_nee) <= 4 * (direct_hits_se + direct_nee_se)"
                   -DEXPECT_FILE=${_m7out}/moon07_shells.shel
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  add_test(NAME moon07_shell_transport_bad_fraction COMMAND ${_m7} --fraction 0.5 --out ${_m7out})
  set_tests_properties(moon07_shell_transport_bad_fraction PROPERTIES PASS_REGULAR_EXPRESSION "fraction")
  set_tests_properties(moon07_shell_transport_json moon07_shell_transport_bad_fraction
                       PROPERTIES LABELS "example;shells")
endif()
