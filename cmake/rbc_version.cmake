# SPDX-License-Identifier: GPL-3.0-or-later
# The version string of a build (core/version.hpp): the project version, plus "+g<hash>" from git
# when the source tree is a checkout not exactly at the tag v<version>, plus "-dirty" when its
# tracked files differ from that commit. The one place this string is computed: the build runs
# this script (core/CMakeLists.txt, target rbc_version) and setup.py runs it for the Python
# package's metadata.
#
# Script mode: cmake -DRBC_VERSION_BASE=0.1.0 -DRBC_SOURCE_DIR=<source root>
#                    [-DRBC_VERSION_TEMPLATE=<.cpp.in> -DRBC_VERSION_OUTPUT=<.cpp>]
#                    -P cmake/rbc_version.cmake
# With RBC_VERSION_OUTPUT it writes that file from the template (left untouched, so nothing
# recompiles, while the string is unchanged); without, it prints the string on stdout.
# include()d, it only defines rbc_version_string().

function(rbc_version_string base source_dir out_var)
  set(version "${base}")
  find_package(Git QUIET)
  if(GIT_FOUND)
    # Only a checkout whose top is this source tree (not a parent project's repository).
    # safe.directory: the build may run as another user than the checkout's owner.
    set(git ${GIT_EXECUTABLE} -c safe.directory=${source_dir} -C ${source_dir})
    execute_process(COMMAND ${git} rev-parse --show-toplevel RESULT_VARIABLE rc
                    OUTPUT_VARIABLE top OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    if(rc EQUAL 0)
      file(REAL_PATH "${top}" top)
      file(REAL_PATH "${source_dir}" src)
    endif()
    if(rc EQUAL 0 AND top STREQUAL src)
      execute_process(COMMAND ${git} rev-parse --short HEAD RESULT_VARIABLE rc
                      OUTPUT_VARIABLE hash OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
      # Tracked files only; --no-optional-locks: never writes the index (another git process
      # may hold it).
      execute_process(COMMAND ${git} --no-optional-locks status --porcelain --untracked-files=no
                      RESULT_VARIABLE status_rc OUTPUT_VARIABLE changes ERROR_QUIET)
      execute_process(COMMAND ${git} describe --tags --exact-match --match v${base} HEAD
                      RESULT_VARIABLE tag_rc OUTPUT_QUIET ERROR_QUIET)
      set(dirty "")
      if(NOT status_rc EQUAL 0 OR NOT changes STREQUAL "")
        set(dirty "-dirty")
      endif()
      if(rc EQUAL 0 AND (NOT tag_rc EQUAL 0 OR dirty))
        set(version "${base}+g${hash}${dirty}")
      endif()
    endif()
  endif()
  set(${out_var} "${version}" PARENT_SCOPE)
endfunction()

if(CMAKE_SCRIPT_MODE_FILE STREQUAL CMAKE_CURRENT_LIST_FILE)
  if(NOT RBC_VERSION_BASE OR NOT RBC_SOURCE_DIR)
    message(FATAL_ERROR "rbc_version.cmake: pass -DRBC_VERSION_BASE=... -DRBC_SOURCE_DIR=...")
  endif()
  rbc_version_string("${RBC_VERSION_BASE}" "${RBC_SOURCE_DIR}" RBC_VERSION_STRING)
  if(RBC_VERSION_OUTPUT)
    configure_file("${RBC_VERSION_TEMPLATE}" "${RBC_VERSION_OUTPUT}" @ONLY)
  else()
    execute_process(COMMAND ${CMAKE_COMMAND} -E echo "${RBC_VERSION_STRING}")
  endif()
endif()
