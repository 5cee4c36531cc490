# Debian's SuiteSparse 5.12 ships neither a CMake config nor a .pc file: find CHOLMOD and the
# libraries it needs (ordering and config) by hand.
find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(CHOLMOD_LIBRARY cholmod)
set(_cholmod_deps suitesparseconfig amd colamd camd ccolamd)
set(CHOLMOD_DEP_LIBRARIES "")
foreach(_lib IN LISTS _cholmod_deps)
  find_library(CHOLMOD_${_lib}_LIBRARY ${_lib})
  mark_as_advanced(CHOLMOD_${_lib}_LIBRARY)
  if(CHOLMOD_${_lib}_LIBRARY)
    list(APPEND CHOLMOD_DEP_LIBRARIES "${CHOLMOD_${_lib}_LIBRARY}")
  else()
    set(CHOLMOD_DEP_MISSING "${CHOLMOD_DEP_MISSING} ${_lib}")
  endif()
endforeach()
if(CHOLMOD_INCLUDE_DIR AND EXISTS "${CHOLMOD_INCLUDE_DIR}/SuiteSparse_config.h")
  file(STRINGS "${CHOLMOD_INCLUDE_DIR}/SuiteSparse_config.h" _ss_lines
       REGEX "^#define SUITESPARSE_(MAIN|SUB|SUBSUB)_VERSION")
  string(REGEX REPLACE ".*MAIN_VERSION[ \t]+([0-9]+).*" "\\1" _ss_major "${_ss_lines}")
  string(REGEX REPLACE ".*SUB_VERSION[ \t]+([0-9]+).*SUBSUB.*" "\\1" _ss_minor "${_ss_lines}")
  set(CHOLMOD_VERSION "SuiteSparse ${_ss_major}.${_ss_minor}")
endif()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(CHOLMOD
  REQUIRED_VARS CHOLMOD_LIBRARY CHOLMOD_INCLUDE_DIR CHOLMOD_DEP_LIBRARIES)
if(CHOLMOD_FOUND AND NOT TARGET SuiteSparse::CHOLMOD)
  add_library(SuiteSparse::CHOLMOD UNKNOWN IMPORTED)
  set_target_properties(SuiteSparse::CHOLMOD PROPERTIES
    IMPORTED_LOCATION "${CHOLMOD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${CHOLMOD_DEP_LIBRARIES}")
endif()
mark_as_advanced(CHOLMOD_INCLUDE_DIR CHOLMOD_LIBRARY)
