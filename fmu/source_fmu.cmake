# cmake -P fmu/source_fmu.cmake: lays out and zips one source-code FMU (docs/fmu.md,
# "Source-code FMUs").  Run by the build after fmu_gen (pkm_add_fmu in fmu/CMakeLists.txt).
#
# The sources/ folder compiles with nothing but "-I." (what FMPy's compile_platform_binary
# passes): the core's source tree at its root (so "common/guard.hpp" and "pkm/pkm.h" resolve),
# Eigen's headers, the FMI 2.0 headers, the FMU layer, and one small wrapper per core file
# (pkm_<folder>_<file>.cpp: pkm_build.h, then the file), so every object file has its own
# name and the build settings need no compiler flag.
#
# Inputs (-D): ID, SOURCE_DIR (repository), STAGE (the binary FMU's staged folder: resources/
# and documentation/ are taken from it), GEN (folder of fmu_vars.h), MD (the source FMU's
# modelDescription.xml, from fmu_gen), HOOKS (","-list of the hooks files), MODEL_C, EIGEN_DIR (holds Eigen/), FMI2_HEADERS_DIR,
# WRAPPERS (","-list of "wrapper=core file"), OUT (.fmu), WORK (a scratch folder).
file(REMOVE_RECURSE ${WORK})
set(src ${WORK}/sources)
file(MAKE_DIRECTORY ${src})

# the core: its source tree, its header
file(COPY ${SOURCE_DIR}/c_core/src/ DESTINATION ${src})
file(COPY ${SOURCE_DIR}/c_core/include/pkm DESTINATION ${src})
file(COPY ${EIGEN_DIR}/Eigen DESTINATION ${src})
# the FMU layer and the generated table
foreach(f fmi2Functions.h fmi2FunctionTypes.h fmi2TypesPlatform.h)
  file(COPY ${FMI2_HEADERS_DIR}/${f} DESTINATION ${src})
endforeach()
string(REPLACE "," ";" HOOKS "${HOOKS}")
file(COPY ${SOURCE_DIR}/fmu/common/fmi2_functions.c ${SOURCE_DIR}/fmu/common/fmu_instance.c
     ${SOURCE_DIR}/fmu/common/fmu_state.c ${SOURCE_DIR}/fmu/common/fmu_instance.h
     ${SOURCE_DIR}/fmu/common/fmu_model.h ${SOURCE_DIR}/fmu/common/fmu_robot.h ${HOOKS} ${GEN}/fmu_vars.h
     DESTINATION ${src})
# the model folder's model.c as fmu_model.c: the core has a common/model.cpp (one model.o)
configure_file(${MODEL_C} ${src}/fmu_model.c COPYONLY)

file(WRITE ${src}/pkm_build.h
  "/* Settings of the source-code FMU's build, included by every pkm_*.cpp wrapper: the core\n"
  " * without SUNDIALS (its explicit Runge-Kutta methods; BDF and Adams are refused, saying so). */\n"
  "#define PKM_NO_CVODE \"source build\"\n")
string(REPLACE "," ";" WRAPPERS "${WRAPPERS}")
foreach(w ${WRAPPERS})
  string(REPLACE "=" ";" pair ${w})
  list(GET pair 0 wrapper)
  list(GET pair 1 core_file)
  file(WRITE ${src}/${wrapper}
    "/* The core's ${core_file}, compiled with this FMU's build settings. */\n"
    "#include \"pkm_build.h\"\n#include \"${core_file}\"\n")
endforeach()

# FMPy's gcc build links "gcc -shared *.o -lm", without the C++ runtime the core needs: this
# object-named file is a GNU ld script (ld reads a file that is no object as a script) that
# adds libstdc++ to that link.  The CMake and buildDescription builds do not use it.
file(WRITE ${src}/zz_cxx_runtime.o "/* GNU ld script: the C++ runtime for a \"gcc -shared *.o\" link */\nINPUT(-lstdc++)\n")

execute_process(COMMAND ${CMAKE_COMMAND} -E copy ${MD} ${WORK}/modelDescription.xml)
file(STRINGS ${MD} _files REGEX "<File name=")
set(file_lines "")
set(cmake_files "")
foreach(l ${_files})
  string(REGEX REPLACE ".*name=\"([^\"]+)\".*" "\\1" f "${l}")
  string(APPEND file_lines "      <SourceFile name=\"${f}\"/>\n")
  string(APPEND cmake_files " ${f}")
endforeach()
file(WRITE ${src}/buildDescription.xml
  "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
  "<fmiBuildDescription fmiVersion=\"3.0\">\n"
  "  <BuildConfiguration modelIdentifier=\"${ID}\" description=\"the core (C++17), Eigen and the FMI 2.0 layer; no SUNDIALS\">\n"
  "    <SourceFileSet language=\"C++17\">\n${file_lines}"
  "      <IncludeDirectory name=\".\"/>\n"
  "    </SourceFileSet>\n"
  "    <Library name=\"stdc++\"/>\n"
  "  </BuildConfiguration>\n"
  "</fmiBuildDescription>\n")
file(WRITE ${src}/CMakeLists.txt
  "# Builds this FMU's binary on any platform with a C11 and C++17 compiler:\n"
  "#   cmake -S sources -B build && cmake --build build --config Release\n"
  "# then copy build/${ID}.(so|dll|dylib) to binaries/<platform>/ and zip the FMU again.\n"
  "cmake_minimum_required(VERSION 3.10)\nproject(${ID} C CXX)\n"
  "set(CMAKE_CXX_STANDARD 17)\nset(CMAKE_C_STANDARD 11)\n"
  "if(NOT CMAKE_BUILD_TYPE)\n  set(CMAKE_BUILD_TYPE Release)\nendif()\n"
  "add_library(${ID} SHARED${cmake_files})\n"
  "target_include_directories(${ID} PRIVATE \${CMAKE_CURRENT_SOURCE_DIR})\n"
  "set_target_properties(${ID} PROPERTIES PREFIX \"\" C_VISIBILITY_PRESET hidden CXX_VISIBILITY_PRESET hidden)\n")

set(entries modelDescription.xml sources)
foreach(d resources documentation)
  if(EXISTS ${STAGE}/${d})
    file(COPY ${STAGE}/${d} DESTINATION ${WORK})
    list(APPEND entries ${d})
  endif()
endforeach()
file(REMOVE ${OUT})
execute_process(COMMAND ${CMAKE_COMMAND} -E tar cf ${OUT} --format=zip ${entries} WORKING_DIRECTORY ${WORK}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "zipping ${OUT} failed")
endif()
