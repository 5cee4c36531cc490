# Registered parts (core/registry.hpp, docs/extending.md) and how the program finds them.
#
# A part in a folder of its own, <module>/<part>/, holds its sources and register_<part>.hpp,
# which declares `void register_<part>(Registry&)`. A module's CMakeLists.txt calls
# twill_add_part_folders(), which builds every such folder as the library twill_<part>; a
# folder that needs more than the module's usual dependencies has a CMakeLists.txt of its own
# that calls twill_add_part() with them.
#
# Every library that registers something with the program says so with
# twill_register_with_program(<target> <header>). The program's registry (app/CMakeLists.txt)
# links them all and includes their headers through one generated header, so registering a
# part is the one line `register_<part>(registry);` in app/program_registry.cpp.

# <target> registers parts through the functions declared in <header> (a path from the
# project's root, as #include writes it).
function(twill_register_with_program target header)
  set_property(GLOBAL APPEND PROPERTY TWILL_PROGRAM_TARGETS ${target})
  set_property(GLOBAL APPEND PROPERTY TWILL_PROGRAM_HEADERS "${header}")
endfunction()

# twill_add_part(<folder> [LINK <libraries>...]): the part in <folder> as the library
# twill_<folder name>, from the folder's .cpp files, linked to twill_core and <libraries>.
function(twill_add_part folder)
  cmake_parse_arguments(PARSE_ARGV 1 _arg "" "" "LINK")
  get_filename_component(_part "${folder}" NAME)
  file(GLOB _sources CONFIGURE_DEPENDS "${folder}/*.cpp")
  if(NOT _sources)
    return()
  endif()
  add_library(twill_${_part} ${_sources})
  target_link_libraries(twill_${_part} PUBLIC twill_core PRIVATE ${_arg_LINK} twill_warnings)
  file(RELATIVE_PATH _header "${PROJECT_SOURCE_DIR}" "${folder}/register_${_part}.hpp")
  twill_register_with_program(twill_${_part} "${_header}")
endfunction()

# twill_add_part_folders([LINK <libraries>...]): every subfolder of the calling module that
# holds register_<subfolder>.hpp is a part: added by its own CMakeLists.txt when it has one,
# otherwise with twill_add_part(<subfolder> LINK <libraries>).
function(twill_add_part_folders)
  file(GLOB _children LIST_DIRECTORIES true CONFIGURE_DEPENDS "${CMAKE_CURRENT_SOURCE_DIR}/*")
  foreach(_folder ${_children})
    get_filename_component(_name "${_folder}" NAME)
    if(NOT EXISTS "${_folder}/register_${_name}.hpp")
      continue()
    endif()
    if(EXISTS "${_folder}/CMakeLists.txt")
      add_subdirectory("${_folder}")
    else()
      twill_add_part("${_folder}" ${ARGN})
    endif()
  endforeach()
endfunction()
