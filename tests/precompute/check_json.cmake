# Run EXE with ARGS, take the last line of stdout as JSON and check keys. EXPECT is a list of
# key=value:tolerance entries; |json[key] - value| <= tolerance is evaluated with awk (CMake has
# no floating-point arithmetic). Usage: cmake -DEXE=.. -DARGS=a;b -DEXPECT=k=v:t;.. -P check_json.cmake
execute_process(COMMAND ${EXE} ${ARGS} OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${EXE} failed (${rc}): ${err}")
endif()
string(STRIP "${out}" out)
string(REGEX REPLACE ".*\n" "" last "${out}")
foreach(item IN LISTS EXPECT)
  if(NOT item MATCHES "^([^=]+)=([^:]+):(.+)$")
    message(FATAL_ERROR "bad EXPECT entry '${item}'")
  endif()
  set(key ${CMAKE_MATCH_1})
  set(ref ${CMAKE_MATCH_2})
  set(tol ${CMAKE_MATCH_3})
  string(JSON val ERROR_VARIABLE jerr GET "${last}" ${key})
  if(jerr)
    message(FATAL_ERROR "no key '${key}' in JSON line: ${last}")
  endif()
  execute_process(COMMAND awk -v v=${val} -v r=${ref} -v t=${tol}
                          "BEGIN { d = v - r; if (d < 0) d = -d; exit (d <= t) ? 0 : 1 }"
                  RESULT_VARIABLE cmp)
  if(NOT cmp EQUAL 0)
    message(FATAL_ERROR "${key} = ${val}, expected ${ref} +- ${tol}\nJSON: ${last}")
  endif()
  message(STATUS "${key} = ${val} (expected ${ref} +- ${tol})")
endforeach()
