# Extra ctest entries for the optics area (included from tests/CMakeLists.txt): run the `mie`
# calculator. tests/ is added before examples/, so test for the example's source as well as the
# target ($<TARGET_FILE:mie> resolves at generate time).
if(TARGET mie OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/mie.cpp))
  # Bad input: exit code 2 with a message naming the argument.
  foreach(case IN ITEMS "x_zero|--x,0|--x = 0 must be" "x_nan|--x,nan|--x = nan must be"
                        "n_zero|--n,0,--x,1|--n = 0 must be" "k_negative|--k,-0.1,--x,1|--k = -0.1 must be"
                        "method_unknown|--method,foo,--x,1|--method = 'foo' is unknown"
                        "auto_needs_radius|--method,auto,--x,5|--method auto needs --radius-um")
    string(REPLACE "|" ";" parts "${case}")
    list(GET parts 0 name)
    list(GET parts 1 args)
    list(GET parts 2 message)
    string(REPLACE "," ";" args "${args}")
    add_test(NAME mie_bad_${name} COMMAND $<TARGET_FILE:mie> ${args})
    set_tests_properties(mie_bad_${name} PROPERTIES WILL_FAIL TRUE LABELS "example;optics")
    add_test(NAME mie_bad_${name}_message COMMAND $<TARGET_FILE:mie> ${args})
    set_tests_properties(mie_bad_${name}_message PROPERTIES PASS_REGULAR_EXPRESSION "${message}"
                         LABELS "example;optics")
  endforeach()
  # Wiscombe's MIEV0 case m = 0.75, x = 10 (tests/data/mie_reference.md): Qext = 2.232265,
  # S1(0) = 55.80662 - 9.758097 i.
  add_test(NAME mie_wiscombe_075 COMMAND $<TARGET_FILE:mie> --n 0.75 --k 0 --x 10 --angles 0,180)
  set_tests_properties(mie_wiscombe_075 PROPERTIES
                       PASS_REGULAR_EXPRESSION "\"qext\":2\\.23226[0-9]*,.*\"S1\":\\[\\[55\\.8066[0-9]*,-9\\.75809[0-9]*\\]"
                       LABELS "example;optics")
  # auto switches to GOA at r = 2 um.
  add_test(NAME mie_auto_goa COMMAND $<TARGET_FILE:mie> --n 1.33 --radius-um 2 --wavelength-um 0.6 --method auto)
  set_tests_properties(mie_auto_goa PROPERTIES PASS_REGULAR_EXPRESSION "\"method\":\"goa\"" LABELS "example;optics")
  add_test(NAME mie_auto_mie COMMAND $<TARGET_FILE:mie> --n 1.33 --radius-um 1.9 --wavelength-um 0.6 --method auto)
  set_tests_properties(mie_auto_mie PROPERTIES PASS_REGULAR_EXPRESSION "\"method\":\"mie\"" LABELS "example;optics")
endif()
