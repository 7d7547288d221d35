# Shared checker for example programs that print one JSON object on the last line of stdout.
# Runs EXE with ARGS, reads the top-level numeric fields of that JSON line, and requires every
# entry of CHECKS, an awk boolean expression over those field names (plus abs()), to hold, e.g.
#   "abs(R - 0.26741) <= 3 * R_stderr + 0.002"   "fraction >= 0.62"
# Optional: EXPECT_STDERR (regex that must occur on stderr), EXPECT_FILE (a path that must exist
# afterwards; removed before the run). awk does the floating-point work (CMake has none); awk is
# part of every Debian base system (mawk, priority required).
# Usage: cmake -DEXE=.. "-DARGS=a;b" "-DCHECKS=expr1;expr2" [-DEXPECT_STDERR=..] [-DEXPECT_FILE=..]
#              -P check_json.cmake
if(EXPECT_FILE)
  file(REMOVE "${EXPECT_FILE}")
endif()
execute_process(COMMAND ${EXE} ${ARGS} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${EXE} exited with ${rc}: ${err}")
endif()
string(STRIP "${out}" out)
string(REGEX REPLACE ".*\n" "" last "${out}")
string(JSON n ERROR_VARIABLE jerr LENGTH "${last}")
if(jerr)
  message(FATAL_ERROR "last stdout line is not a JSON object: '${last}' (${jerr})")
endif()
set(awk_vars)
math(EXPR last_index "${n} - 1")
foreach(i RANGE ${last_index})
  string(JSON key MEMBER "${last}" ${i})
  string(JSON type TYPE "${last}" ${key})
  if(type STREQUAL "NUMBER")
    string(JSON v GET "${last}" ${key})
    list(APPEND awk_vars -v "${key}=${v}")
  endif()
endforeach()
foreach(expr IN LISTS CHECKS)
  execute_process(COMMAND awk ${awk_vars}
                          "function abs(x) { return x < 0 ? -x : x } BEGIN { exit (${expr}) ? 0 : 1 }"
                  RESULT_VARIABLE ok ERROR_VARIABLE awk_err)
  if(NOT ok EQUAL 0)
    message(FATAL_ERROR "check failed: ${expr} ${awk_err}\nJSON: ${last}")
  endif()
  message(STATUS "ok: ${expr}")
endforeach()
if(EXPECT_STDERR AND NOT err MATCHES "${EXPECT_STDERR}")
  message(FATAL_ERROR "expected '${EXPECT_STDERR}' on stderr, got: ${err}")
endif()
if(EXPECT_FILE AND NOT EXISTS "${EXPECT_FILE}")
  message(FATAL_ERROR "${EXPECT_FILE} was not written")
endif()
