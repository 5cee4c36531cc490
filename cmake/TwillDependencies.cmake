# Every dependency, found by the mechanism Debian 12 really ships (../shared/docs/build-notes.md).
# Each is required; scripts/install-deps.sh installs them. The summary at the end says which
# were found and their versions.
find_package(Eigen3 3.4 REQUIRED CONFIG)
find_package(CHOLMOD REQUIRED)
find_package(OpenSubdiv REQUIRED)
find_package(OpenMesh REQUIRED CONFIG)          # no version: asking for 9 fails on Debian
find_package(PkgConfig REQUIRED)
pkg_check_modules(IPOPT REQUIRED IMPORTED_TARGET ipopt)   # headers under coin/, adds -DHAVE_CSTDDEF
find_package(NLopt REQUIRED CONFIG)
find_package(yaml-cpp REQUIRED CONFIG)
find_package(CLI11 REQUIRED CONFIG)
find_package(spdlog REQUIRED CONFIG)
find_package(fmt REQUIRED CONFIG)
find_package(nlohmann_json REQUIRED CONFIG)
find_package(TBB REQUIRED CONFIG)
if(TWILL_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()

# OpenMesh's Debian config sets no version variable: read it from the header.
if(NOT OpenMesh_VERSION)
  find_file(_om_config_h OpenMesh/Core/System/config.h)
  if(_om_config_h)
    file(STRINGS "${_om_config_h}" _om_line REGEX "^#define OM_VERSION 0x")
    string(REGEX REPLACE ".*0x([0-9a-fA-F])([0-9a-fA-F][0-9a-fA-F])([0-9a-fA-F][0-9a-fA-F]).*" "\\1.\\2.\\3" OpenMesh_VERSION "${_om_line}")
  endif()
endif()

message(STATUS "twill dependencies:")
message(STATUS "  Eigen        ${Eigen3_VERSION}")
message(STATUS "  CHOLMOD      ${CHOLMOD_VERSION} (${CHOLMOD_LIBRARY})")
message(STATUS "  OpenSubdiv   ${OpenSubdiv_VERSION} (${OpenSubdiv_CPU_LIBRARY})")
message(STATUS "  OpenMesh     ${OpenMesh_VERSION}")
message(STATUS "  Ipopt        ${IPOPT_VERSION}")
message(STATUS "  NLopt        ${NLopt_VERSION}")
message(STATUS "  yaml-cpp     ${yaml-cpp_VERSION}")
message(STATUS "  CLI11        ${CLI11_VERSION}")
message(STATUS "  spdlog       ${spdlog_VERSION}, fmt ${fmt_VERSION}")
message(STATUS "  nlohmann     ${nlohmann_json_VERSION}")
message(STATUS "  TBB          ${TBB_VERSION}")
if(TWILL_BUILD_TESTS)
  message(STATUS "  GoogleTest   ${GTest_VERSION}")
endif()
