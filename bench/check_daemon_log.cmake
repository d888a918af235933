# service_latency --daemon-log: the daemon it starts logs at info, with a timing summary
# every second, to the file given, whose path may hold a ' (written into the daemon's
# YAML config as a single-quoted scalar). Run by CTest (bench.service_latency_daemon_log):
#   cmake -DTOOL=<service_latency> -DDAEMON=<tetcollided> -DDIR=<scratch dir> -P this
file(REMOVE_RECURSE "${DIR}")
file(MAKE_DIRECTORY "${DIR}")
set(log "${DIR}/it's a log.txt")
execute_process(
  COMMAND "${TOOL}" --daemon "${DAEMON}" --frames 1500 --lockstep --daemon-threads 1
          --daemon-log "${log}"
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "service_latency exited with ${rc}:\n${out}\n${err}")
endif()
if(NOT EXISTS "${log}")
  message(FATAL_ERROR "no daemon log at ${log}:\n${out}\n${err}")
endif()
file(READ "${log}" text)
foreach(expected "[info] tetcollided ready" "torus_in_box/torus: registered topology version 1"
                 "torus_in_box: " " frames in " "compute p50 ")
  string(FIND "${text}" "${expected}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "the daemon log lacks '${expected}':\n${text}")
  endif()
endforeach()
