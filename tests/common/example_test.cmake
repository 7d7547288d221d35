# One example run checked by tests/common/check_json.cmake (its last JSON line against CHECKS; the
# file EXPECT_FILE must exist when given), labelled LABELS (and TIMEOUT seconds when given);
# optionally a run with bad arguments BAD_ARGS under BAD_NAME that must print BAD_REGEX when given,
# else exit non-zero. Shared by the areas' ctest.cmake files.
function(grainlight_example_json_test)
  cmake_parse_arguments(_t "" "NAME;TARGET;EXPECT_FILE;BAD_NAME;BAD_REGEX;TIMEOUT" "ARGS;CHECKS;BAD_ARGS;LABELS" ${ARGN})
  set(_expect)
  if(_t_EXPECT_FILE)
    set(_expect -DEXPECT_FILE=${_t_EXPECT_FILE})
  endif()
  add_test(NAME ${_t_NAME}
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:${_t_TARGET}>
                   "-DARGS=${_t_ARGS}"
                   "-DCHECKS=${_t_CHECKS}"
                   ${_expect}
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  if(_t_TIMEOUT)
    set_tests_properties(${_t_NAME} PROPERTIES TIMEOUT ${_t_TIMEOUT})
  endif()
  if(_t_BAD_NAME)
    add_test(NAME ${_t_BAD_NAME} COMMAND $<TARGET_FILE:${_t_TARGET}> ${_t_BAD_ARGS})
    if(_t_BAD_REGEX)
      set_tests_properties(${_t_BAD_NAME} PROPERTIES PASS_REGULAR_EXPRESSION "${_t_BAD_REGEX}")
    else()
      set_tests_properties(${_t_BAD_NAME} PROPERTIES WILL_FAIL TRUE)
    endif()
  endif()
  set_tests_properties(${_t_NAME} ${_t_BAD_NAME} PROPERTIES LABELS "${_t_LABELS}")
endfunction()
