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
  # auto uses GOA from r = 2 um on only where GOA is valid (x >= 45 and 2 x |m - 1| >= 6):
  # r = 5 um at 0.6 um (x = 52) is GOA, r = 2 um (x = 21) and 1.9 um stay Mie.
  add_test(NAME mie_auto_goa COMMAND $<TARGET_FILE:mie> --n 1.33 --radius-um 5 --wavelength-um 0.6 --method auto)
  set_tests_properties(mie_auto_goa PROPERTIES PASS_REGULAR_EXPRESSION "\"method\":\"goa\"" LABELS "example;optics")
  add_test(NAME mie_auto_mie COMMAND $<TARGET_FILE:mie> --n 1.33 --radius-um 1.9 --wavelength-um 0.6 --method auto)
  set_tests_properties(mie_auto_mie PROPERTIES PASS_REGULAR_EXPRESSION "\"method\":\"mie\"" LABELS "example;optics")
  add_test(NAME mie_auto_mie_below_x45 COMMAND $<TARGET_FILE:mie> --n 1.33 --radius-um 2 --wavelength-um 0.6 --method auto)
  set_tests_properties(mie_auto_mie_below_x45 PROPERTIES PASS_REGULAR_EXPRESSION "\"method\":\"mie\"" LABELS "example;optics")
  # Issue 15: `auto` within 15 % of exact Mie's Qext and positive for each index at r = 2, 20,
  # 200 um, 0.55 um, through the JSON; valid for every output: 0 <= qsca <= qext, |g| <= 1. The
  # reference values are exact Mie (`mie --method mie`, this library's Lorenz-Mie, checked against
  # Wiscombe's MIEV0 in test_lorenz_mie.cpp).
  foreach(case IN ITEMS "1.0001|0|2|1.03648318e-05" "1.0001|0|20|0.001043919855" "1.0001|0|200|0.1032110605"
                        "1.05|0|2|2.029774829" "1.05|0|20|2.20550539" "1.05|0|200|1.996777606"
                        "1.33|0|2|2.012523906" "1.33|0|20|2.045457029" "1.33|0|200|2.010585657"
                        "1.33|1e-8|2|2.012524142" "1.33|1e-8|20|2.045457407" "1.33|1e-8|200|2.010586346"
                        "1.5|0.1|2|2.239610977" "1.5|0.1|20|2.052200835" "1.5|0.1|200|2.011395228"
                        "2.5|1|2|2.252171564" "2.5|1|20|2.057430635" "2.5|1|200|2.012069777"
                        "4|0.01|2|2.249734875" "4|0.01|20|2.049755088" "4|0.01|200|2.011349152"
                        "10|10|2|2.139275675" "10|10|20|2.049335832" "10|10|200|2.015343591"
                        "0.75|0|2|2.344529153" "0.75|0|20|2.034701892" "0.75|0|200|2.02266809"
                        "1.2|2|2|2.362452764" "1.2|2|20|2.066823815" "1.2|2|200|2.012768276")
    string(REPLACE "|" ";" parts "${case}")
    list(GET parts 0 n)
    list(GET parts 1 k)
    list(GET parts 2 r)
    list(GET parts 3 qmie)
    add_test(NAME mie_auto_vs_mie_n${n}_k${k}_r${r}
             COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:mie>
                     "-DARGS=--n;${n};--k;${k};--radius-um;${r};--wavelength-um;0.55;--method;auto;--angles;0,90,180"
                     "-DCHECKS=qext > 0;abs(qext - ${qmie}) <= 0.15 * ${qmie};qsca >= 0;qsca <= qext * (1 + 1e-9);abs(g) <= 1;qabs >= -1e-12"
                     -P ${CMAKE_CURRENT_SOURCE_DIR}/common/check_json.cmake)
    set_tests_properties(mie_auto_vs_mie_n${n}_k${k}_r${r} PROPERTIES LABELS "example;optics")
  endforeach()
  # GOA forced outside its range: computes, says so on stderr, flags it in the JSON.
  add_test(NAME mie_goa_invalid_warns
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:mie>
                   "-DARGS=--n;1.05;--radius-um;2;--wavelength-um;0.55;--method;goa;--angles;0"
                   "-DCHECKS=qext > 0;phase_shift < 6"
                   "-DEXPECT_STDERR=warning: GOA is outside its validity range"
                   -P ${CMAKE_CURRENT_SOURCE_DIR}/common/check_json.cmake)
  set_tests_properties(mie_goa_invalid_warns PROPERTIES LABELS "example;optics")
  add_test(NAME mie_goa_invalid_flag COMMAND $<TARGET_FILE:mie> --n 1.05 --radius-um 2 --wavelength-um 0.55 --method goa)
  set_tests_properties(mie_goa_invalid_flag PROPERTIES PASS_REGULAR_EXPRESSION "\"goa_valid\":false" LABELS "example;optics")
  # ... and refuses (exit code 2, message naming x and the phase shift) where Qext would be negative.
  add_test(NAME mie_goa_negative_refused COMMAND $<TARGET_FILE:mie> --n 1.0001 --radius-um 2 --wavelength-um 0.55 --method goa)
  set_tests_properties(mie_goa_negative_refused PROPERTIES WILL_FAIL TRUE LABELS "example;optics")
  add_test(NAME mie_goa_negative_refused_message COMMAND $<TARGET_FILE:mie> --n 1.0001 --radius-um 2 --wavelength-um 0.55 --method goa)
  set_tests_properties(mie_goa_negative_refused_message PROPERTIES
                       PASS_REGULAR_EXPRESSION "Qext = -2\\.0[0-9]* is invalid.*rho = 2 x \\|m - 1\\| = 0\\.0045[0-9]*" LABELS "example;optics")
endif()
