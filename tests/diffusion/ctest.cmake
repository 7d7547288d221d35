# Extra ctest entries for the diffusion area (included from tests/CMakeLists.txt): the
# diffusion_profiles example must reject bad arguments with a message, and a tiny run must finish
# and print its JSON totals (numbers are checked in tests/diffusion/*.cpp, not here).
if(TARGET diffusion_profiles OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/diffusion_profiles.cpp))
  add_test(NAME diffusion_profiles_bad_paths COMMAND $<TARGET_FILE:diffusion_profiles> --paths 10)
  set_tests_properties(diffusion_profiles_bad_paths PROPERTIES PASS_REGULAR_EXPRESSION "--paths = 10"
                       LABELS "example;diffusion")
  add_test(NAME diffusion_profiles_unknown_argument COMMAND $<TARGET_FILE:diffusion_profiles> --albedo 0.5)
  set_tests_properties(diffusion_profiles_unknown_argument PROPERTIES WILL_FAIL TRUE LABELS "example;diffusion")
  add_test(NAME diffusion_profiles_tiny
           COMMAND $<TARGET_FILE:diffusion_profiles> --paths 4000 --out ${CMAKE_CURRENT_BINARY_DIR}/diffusion_profiles_tiny)
  set_tests_properties(diffusion_profiles_tiny PROPERTIES PASS_REGULAR_EXPRESSION "\"R_improved\":0.18680"
                       LABELS "example;diffusion")
endif()
