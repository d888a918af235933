# Runs one command and checks its exit code exactly, and optionally its output.
#
#   cmake -DCOMMAND=<program> [-DARGS=a|b|c] -DEXPECT_EXIT=<n>
#         [-DSTDOUT_REGEX=<re>] [-DSTDERR_REGEX=<re>] [-DSTDERR_EMPTY=1]
#         [-DJSON_INTS=key=value,key=value]   (stdout is one JSON object)
#         [-DOUTPUT_FILE=<path> [-DOUTPUT_REGEX=<re>] [-DOUTPUT_HEX_REGEX=<re>]]
#                                        (file the command must write; the hex regex is
#                                         matched against its bytes in lower-case hex)
#         -P run_cli.cmake
#
# Arguments are separated by '|' so that paths and regexes keep their ';'.
cmake_minimum_required(VERSION 3.25)

if(NOT DEFINED COMMAND OR NOT DEFINED EXPECT_EXIT)
  message(FATAL_ERROR "run_cli.cmake: COMMAND and EXPECT_EXIT are required")
endif()
set(argv "")
if(DEFINED ARGS AND NOT ARGS STREQUAL "")
  string(REPLACE "|" ";" argv "${ARGS}")
endif()
if(DEFINED OUTPUT_FILE)
  file(REMOVE "${OUTPUT_FILE}")
endif()

execute_process(
  COMMAND "${COMMAND}" ${argv}
  RESULT_VARIABLE exit_code
  OUTPUT_VARIABLE out
  ERROR_VARIABLE err
  TIMEOUT 60)

set(report "command: ${COMMAND} ${argv}\nexit code: ${exit_code}\nstdout:\n${out}\nstderr:\n${err}")
if(NOT exit_code STREQUAL "${EXPECT_EXIT}")
  message(FATAL_ERROR "expected exit code ${EXPECT_EXIT}\n${report}")
endif()
if(DEFINED STDOUT_REGEX AND NOT out MATCHES "${STDOUT_REGEX}")
  message(FATAL_ERROR "stdout does not match '${STDOUT_REGEX}'\n${report}")
endif()
if(DEFINED STDERR_REGEX AND NOT err MATCHES "${STDERR_REGEX}")
  message(FATAL_ERROR "stderr does not match '${STDERR_REGEX}'\n${report}")
endif()
if(STDERR_EMPTY AND NOT err STREQUAL "")
  message(FATAL_ERROR "expected nothing on stderr\n${report}")
endif()

if(DEFINED JSON_INTS)
  string(REPLACE "," ";" pairs "${JSON_INTS}")
  foreach(pair IN LISTS pairs)
    string(REPLACE "=" ";" kv "${pair}")
    list(GET kv 0 key)
    list(GET kv 1 expected)
    string(JSON type ERROR_VARIABLE json_error TYPE "${out}" "${key}")
    if(json_error)
      message(FATAL_ERROR "JSON key '${key}': ${json_error}\n${report}")
    endif()
    if(NOT type STREQUAL "NUMBER")
      message(FATAL_ERROR "JSON key '${key}' is a ${type}, expected an integer\n${report}")
    endif()
    string(JSON value GET "${out}" "${key}")
    if(NOT value STREQUAL "${expected}")
      message(FATAL_ERROR "JSON key '${key}' is ${value}, expected ${expected}\n${report}")
    endif()
  endforeach()
endif()

if(DEFINED OUTPUT_FILE)
  if(NOT EXISTS "${OUTPUT_FILE}")
    message(FATAL_ERROR "expected the command to write ${OUTPUT_FILE}\n${report}")
  endif()
  if(DEFINED OUTPUT_REGEX)
    file(READ "${OUTPUT_FILE}" content)
    if(NOT content MATCHES "${OUTPUT_REGEX}")
      message(FATAL_ERROR "${OUTPUT_FILE} does not match '${OUTPUT_REGEX}'\n${report}")
    endif()
  endif()
  if(DEFINED OUTPUT_HEX_REGEX)
    file(READ "${OUTPUT_FILE}" hex HEX)
    if(NOT hex MATCHES "${OUTPUT_HEX_REGEX}")
      string(SUBSTRING "${hex}" 0 80 head)
      message(FATAL_ERROR "${OUTPUT_FILE} (hex ${head}...) does not match '${OUTPUT_HEX_REGEX}'\n${report}")
    endif()
  endif()
endif()
