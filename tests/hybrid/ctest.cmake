# Extra ctest entries for the hybrid area (included from tests/CMakeLists.txt): a tiny run of the
# Meng15 hybrid example (small sphere of grains) reports its speedups; bad arguments exit with 2.
if(TARGET meng15_hybrid_convergence OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/meng15_hybrid_convergence.cpp))
  add_test(NAME meng15_hybrid_tiny
           COMMAND $<TARGET_FILE:meng15_hybrid_convergence> --spp 2 --radius 10 --width 32 --threads 2
                   --out ${CMAKE_CURRENT_BINARY_DIR}/meng15_hybrid_tiny)
  set_tests_properties(meng15_hybrid_tiny PROPERTIES PASS_REGULAR_EXPRESSION "\"ept_vpt_pa_1_speedup\":[0-9.e+-]+,"
                       LABELS "example;hybrid")
  add_test(NAME meng15_hybrid_bad_spp COMMAND $<TARGET_FILE:meng15_hybrid_convergence> --spp 1)
  set_tests_properties(meng15_hybrid_bad_spp PROPERTIES WILL_FAIL TRUE LABELS "example;hybrid")
endif()
