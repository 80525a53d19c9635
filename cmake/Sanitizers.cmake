# TSUBU_SANITIZE: build everything (the core, the C++ tests, the Python extension) with gcc's or
# clang's sanitizers, e.g. -DTSUBU_SANITIZE=address,undefined or -DTSUBU_SANITIZE=thread.
# Empty (default): no sanitizer. Every report is fatal (-fno-sanitize-recover=all), so a test
# run under the sanitizers fails on the first report instead of printing it and going on.
# Frame pointers and -g keep the reports' stacks readable; the optimisation level is the build
# type's, so the vectorised loops that ship are the loops that are checked.
set(TSUBU_SANITIZE "" CACHE STRING
    "Sanitizers, comma-separated (address, undefined, float-cast-overflow, leak, thread); empty: none")

if(TSUBU_SANITIZE)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    message(FATAL_ERROR "TSUBU_SANITIZE needs gcc or clang, not ${CMAKE_CXX_COMPILER_ID}")
  endif()
  string(REPLACE "," ";" _tsubu_sanitizers "${TSUBU_SANITIZE}")
  foreach(_s IN LISTS _tsubu_sanitizers)
    if(NOT _s MATCHES "^(address|undefined|float-cast-overflow|leak|thread)$")
      message(FATAL_ERROR "TSUBU_SANITIZE: unknown sanitizer '${_s}' "
                          "(address, undefined, float-cast-overflow, leak, thread)")
    endif()
  endforeach()
  if("thread" IN_LIST _tsubu_sanitizers AND ("address" IN_LIST _tsubu_sanitizers OR "leak" IN_LIST _tsubu_sanitizers))
    message(FATAL_ERROR "TSUBU_SANITIZE: thread cannot be combined with address or leak")
  endif()
  set(_tsubu_sanitize_flags -fsanitize=${TSUBU_SANITIZE} -fno-sanitize-recover=all
      -fno-omit-frame-pointer -g)
  include(CheckCXXSourceCompiles)
  set(CMAKE_REQUIRED_FLAGS "-fsanitize=${TSUBU_SANITIZE}")
  set(CMAKE_REQUIRED_LINK_OPTIONS "-fsanitize=${TSUBU_SANITIZE}")
  string(MAKE_C_IDENTIFIER "TSUBU_SANITIZE_WORKS_${TSUBU_SANITIZE}" _tsubu_sanitize_check)
  check_cxx_source_compiles("int main() { return 0; }" ${_tsubu_sanitize_check})
  unset(CMAKE_REQUIRED_FLAGS)
  unset(CMAKE_REQUIRED_LINK_OPTIONS)
  if(NOT ${_tsubu_sanitize_check})
    message(FATAL_ERROR "TSUBU_SANITIZE=${TSUBU_SANITIZE}: the compiler cannot build and link with it")
  endif()
  # Directory-wide (not a usage requirement of tsubu::core), so an installed package never asks
  # its users for the sanitizer runtimes.
  add_compile_options(${_tsubu_sanitize_flags})
  add_link_options(-fsanitize=${TSUBU_SANITIZE})
  message(STATUS "tsubu: sanitizers ${TSUBU_SANITIZE}")
endif()
