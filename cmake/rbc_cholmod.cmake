# SPDX-License-Identifier: GPL-3.0-or-later
# CHOLMOD (SuiteSparse) as the imported target rbc::cholmod: Debian's libsuitesparse-dev ships no
# CMake package, so the header and the libraries are looked up directly. Included by the build
# (top-level CMakeLists.txt) and by the installed package config (rbcConfig.cmake), which thus
# find the same files. Leaves rbc::cholmod undefined when something is missing.
# SuiteSparse_config: CHOLMOD's allocator hooks (core/sparse_cholesky.cpp sets them).
if(NOT TARGET rbc::cholmod)
  find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
  find_library(CHOLMOD_LIBRARY cholmod)
  find_library(SUITESPARSECONFIG_LIBRARY suitesparseconfig)
  if(CHOLMOD_INCLUDE_DIR AND CHOLMOD_LIBRARY AND SUITESPARSECONFIG_LIBRARY)
    add_library(rbc::cholmod INTERFACE IMPORTED)
    set_target_properties(rbc::cholmod PROPERTIES
      INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}"
      INTERFACE_LINK_LIBRARIES "${CHOLMOD_LIBRARY};${SUITESPARSECONFIG_LIBRARY}")
  endif()
endif()
