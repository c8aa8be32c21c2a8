# The functions that add FMUs to a build: pkm_add_fmu, pkm_add_described_fmu and
# pkm_add_fmu_platforms.  Included by fmu/CMakeLists.txt (the project's FMUs) and by
# fmu/described/CMakeLists.txt (the FMUs of one description file, in a build tree of their own).
# They need PKM_FMU_DIR (where the FMUs are staged and packed), PKM_CORE_SOURCES,
# PKM_FMU_EXTRA_PLATFORMS, FMI2_HEADERS_DIR, FMI3_HEADERS_DIR and the targets fmu_gen and
# pkm_static.
include(ExternalProject)
set(PKM_FMU_SOURCE_DIR ${CMAKE_CURRENT_LIST_DIR})               # fmu/
get_filename_component(PKM_SOURCE_DIR ${CMAKE_CURRENT_LIST_DIR} DIRECTORY)  # the checkout

# pkm_add_fmu(<folder> [HOOKS <file.c>...] [ROBOTS <robot.cpp>...] [GENERATOR <target>]): the FMU
# described by <folder>/variables.txt (relative to fmu/, or absolute).  The hooks of
# fmu_model.h are the robot's (common/robot.c and common/robot_states.c) unless HOOKS names
# other files (common/controller.c for the controller FMUs).  ROBOTS are robot sources outside the core
# (the test tree's toy robots) linked into the binary, with GENERATOR an fmu_gen that knows
# them too.
function(pkm_add_fmu folder)
  cmake_parse_arguments(F "" "GENERATOR" "HOOKS;ROBOTS;RESOURCES" ${ARGN})
  set(hooks ${PKM_FMU_SOURCE_DIR}/common/robot.c ${PKM_FMU_SOURCE_DIR}/common/robot_states.c)
  if(F_HOOKS)
    set(hooks "")
    foreach(h ${F_HOOKS})
      list(APPEND hooks ${PKM_FMU_SOURCE_DIR}/${h})
    endforeach()
  endif()
  string(REPLACE ";" "," hooks_text "${hooks}")  # one argument, one field of a record
  set(generator fmu_gen)
  if(F_GENERATOR)
    set(generator ${F_GENERATOR})
  endif()
  if(IS_ABSOLUTE ${folder})
    set(src ${folder})
  else()
    set(src ${PKM_FMU_SOURCE_DIR}/${folder})
  endif()
  file(STRINGS ${src}/variables.txt _id_line REGEX "^@identifier[ \t]+")
  string(REGEX REPLACE "^@identifier[ \t]+([A-Za-z0-9_]+).*" "\\1" id "${_id_line}")
  if(NOT id)
    message(FATAL_ERROR "${src}/variables.txt: no @identifier line")
  endif()
  set(stage ${PKM_FMU_DIR}/${id})      # the unzipped FMU
  set(gen ${PKM_FMU_DIR}/gen/${id})    # generated C header
  file(MAKE_DIRECTORY ${stage} ${gen})

  # The source-code FMU's files (source_fmu.cmake): a wrapper per core file, then the FMU layer.
  set(source_md "")
  set(source_files "")
  set(wrappers "")
  if(NOT F_ROBOTS)
    set(source_md ${PKM_FMU_DIR}/gen/${id}/source_modelDescription.xml)
    foreach(c ${PKM_CORE_SOURCES})
      file(RELATIVE_PATH rel ${PKM_SOURCE_DIR}/c_core/src ${c})
      string(REPLACE "/" "_" w "pkm_${rel}")
      list(APPEND source_files ${w})
      list(APPEND wrappers "${w}=${rel}")
    endforeach()
    list(APPEND source_files fmi2_functions.c fmu_instance.c fmu_state.c)
    foreach(h ${hooks})
      get_filename_component(hooks_name ${h} NAME)
      list(APPEND source_files ${hooks_name})
    endforeach()
    list(APPEND source_files fmu_model.c)
  endif()

  # The FMI 3.0 FMU of the same table: its own modelDescription.xml, the same binary (which
  # exports both interfaces) in the FMI 3.0 platform folders.
  set(stage3 ${PKM_FMU_DIR}/fmi3/${id})
  file(MAKE_DIRECTORY ${stage3})
  add_custom_command(
    OUTPUT ${stage}/modelDescription.xml ${gen}/fmu_vars.h ${source_md} ${stage3}/modelDescription.xml
           ${gen}/fmu_vars3.h
    COMMAND ${generator} --fmi3 ${stage3}/modelDescription.xml ${gen}/fmu_vars3.h
            ${src}/variables.txt ${stage}/modelDescription.xml ${gen}/fmu_vars.h ${source_md}
            ${source_files}
    DEPENDS ${generator} ${src}/variables.txt ${F_RESOURCES}
    COMMENT "fmu_gen: ${id} modelDescription.xml and value references"
    VERBATIM)

  add_library(${id} SHARED
    ${PKM_FMU_SOURCE_DIR}/common/fmi2_functions.c
    ${PKM_FMU_SOURCE_DIR}/common/fmi3_functions.c
    ${PKM_FMU_SOURCE_DIR}/common/fmu_instance.c
    ${PKM_FMU_SOURCE_DIR}/common/fmu_state.c
    ${hooks}
    ${src}/model.c
    ${gen}/fmu_vars.h
    ${gen}/fmu_vars3.h
    ${F_ROBOTS})
  target_include_directories(${id} PRIVATE ${gen} ${PKM_FMU_SOURCE_DIR}/common ${FMI2_HEADERS_DIR}
                             ${FMI3_HEADERS_DIR})
  if(F_ROBOTS)
    target_include_directories(${id} PRIVATE ${PKM_SOURCE_DIR}/c_core/src)
    target_link_libraries(${id} PRIVATE Eigen3::Eigen)
  endif()
  target_link_libraries(${id} PRIVATE pkm_static)
  target_compile_options(${id} PRIVATE -Wall -Wextra)
  set_target_properties(${id} PROPERTIES
    PREFIX ""
    OUTPUT_NAME ${id}
    LIBRARY_OUTPUT_DIRECTORY ${stage}/binaries/linux64
    C_STANDARD 11
    C_VISIBILITY_PRESET hidden
    LINKER_LANGUAGE CXX
    LINK_DEPENDS ${PKM_FMU_SOURCE_DIR}/common/exports.map)
  # Self-contained binary: core, SUNDIALS and the C++ runtime inside, only fmi2* and fmi3* out (stripped).
  target_link_options(${id} PRIVATE
    -Wl,--version-script=${PKM_FMU_SOURCE_DIR}/common/exports.map
    -Wl,--exclude-libs,ALL -Wl,--no-undefined -static-libstdc++ -static-libgcc -s)

  if(EXISTS ${src}/readme.md)
    set(doc_dep ${src}/readme.md)
    add_custom_command(
      OUTPUT ${stage}/documentation/readme.md
      COMMAND ${CMAKE_COMMAND} -E copy ${src}/readme.md ${stage}/documentation/readme.md
      DEPENDS ${src}/readme.md VERBATIM)
    set(doc_out ${stage}/documentation/readme.md)
    set(doc_entry documentation)
  endif()

  set(res_out "")
  set(res_entry "")
  foreach(r ${F_RESOURCES})
    get_filename_component(rn ${r} NAME)
    add_custom_command(
      OUTPUT ${stage}/resources/${rn}
      COMMAND ${CMAKE_COMMAND} -E copy ${r} ${stage}/resources/${rn}
      DEPENDS ${r} VERBATIM)
    list(APPEND res_out ${stage}/resources/${rn})
    set(res_entry resources)
  endforeach()

  # The other platforms' binaries (fmu/platform), for FMUs made of the core alone.
  set(cross_out "")
  if(NOT F_ROBOTS)
    set_property(GLOBAL APPEND PROPERTY PKM_FMU_RECORDS "${id}|${src}|${hooks_text}")
    set_property(GLOBAL APPEND PROPERTY PKM_FMU_GENERATED ${gen}/fmu_vars.h ${gen}/fmu_vars3.h)
    foreach(p ${PKM_FMU_EXTRA_PLATFORMS})
      if(p STREQUAL "win64")
        set(bin ${stage}/binaries/${p}/${id}.dll)
      else()
        set(bin ${stage}/binaries/${p}/${id}.so)
      endif()
      list(APPEND cross_out ${bin})
      set_property(GLOBAL APPEND PROPERTY PKM_FMU_BINARIES_${p} ${bin})
    endforeach()
    set_property(GLOBAL APPEND PROPERTY PKM_FMU_ZIP_TARGETS ${id}_fmu)
  endif()

  add_custom_command(
    OUTPUT ${PKM_FMU_DIR}/${id}.fmu
    COMMAND ${CMAKE_COMMAND} -E rm -f ${PKM_FMU_DIR}/${id}.fmu
    COMMAND ${CMAKE_COMMAND} -E tar cf ${PKM_FMU_DIR}/${id}.fmu --format=zip
            modelDescription.xml binaries ${doc_entry} ${res_entry}
    WORKING_DIRECTORY ${stage}
    DEPENDS ${id} ${stage}/modelDescription.xml ${doc_out} ${res_out} ${cross_out}
    COMMENT "zipping ${PKM_FMU_DIR}/${id}.fmu"
    VERBATIM)
  add_custom_target(${id}_fmu ALL DEPENDS ${PKM_FMU_DIR}/${id}.fmu)

  # The FMI 3.0 FMU: the same binaries under the FMI 3.0 platform tuples.
  set(copies3 COMMAND ${CMAKE_COMMAND} -E copy $<TARGET_FILE:${id}> ${stage3}/binaries/x86_64-linux/${id}.so)
  foreach(bin ${cross_out})
    get_filename_component(pdir ${bin} DIRECTORY)
    get_filename_component(p ${pdir} NAME)
    get_filename_component(bname ${bin} NAME)
    set(p3 ${p})
    if(p STREQUAL "win64")
      set(p3 x86_64-windows)
    endif()
    list(APPEND copies3 COMMAND ${CMAKE_COMMAND} -E copy ${bin} ${stage3}/binaries/${p3}/${bname})
  endforeach()
  set(extra3 "")
  if(doc_out)
    list(APPEND copies3 COMMAND ${CMAKE_COMMAND} -E copy_directory ${stage}/documentation ${stage3}/documentation)
    list(APPEND extra3 documentation)
  endif()
  if(res_entry)
    list(APPEND copies3 COMMAND ${CMAKE_COMMAND} -E copy_directory ${stage}/resources ${stage3}/resources)
    list(APPEND extra3 resources)
  endif()
  add_custom_command(
    OUTPUT ${PKM_FMU_DIR}/fmi3/${id}.fmu
    COMMAND ${CMAKE_COMMAND} -E rm -rf ${stage3}/binaries
    ${copies3}
    COMMAND ${CMAKE_COMMAND} -E rm -f ${PKM_FMU_DIR}/fmi3/${id}.fmu
    COMMAND ${CMAKE_COMMAND} -E tar cf ${PKM_FMU_DIR}/fmi3/${id}.fmu --format=zip
            modelDescription.xml binaries ${extra3}
    WORKING_DIRECTORY ${stage3}
    DEPENDS ${id} ${stage3}/modelDescription.xml ${doc_out} ${res_out} ${cross_out}
    COMMENT "zipping ${PKM_FMU_DIR}/fmi3/${id}.fmu"
    VERBATIM)
  add_custom_target(${id}_fmu3 ALL DEPENDS ${PKM_FMU_DIR}/fmi3/${id}.fmu)
  if(NOT F_ROBOTS)
    set_property(GLOBAL APPEND PROPERTY PKM_FMU_ZIP_TARGETS ${id}_fmu3)
  endif()

  if(NOT F_ROBOTS)
    get_target_property(eigen_inc Eigen3::Eigen INTERFACE_INCLUDE_DIRECTORIES)
    set(out ${PKM_FMU_DIR}/source/${id}.fmu)
    string(REPLACE ";" "," wrappers_text "${wrappers}")  # one argument
    add_custom_command(
      OUTPUT ${out}
      COMMAND ${CMAKE_COMMAND} -DID=${id} -DSOURCE_DIR=${PKM_SOURCE_DIR} -DSTAGE=${stage} -DGEN=${gen}
              -DMD=${source_md} -DHOOKS=${hooks_text} -DMODEL_C=${src}/model.c -DEIGEN_DIR=${eigen_inc}
              -DFMI2_HEADERS_DIR=${FMI2_HEADERS_DIR} -DWRAPPERS=${wrappers_text} -DOUT=${out}
              -DWORK=${PKM_FMU_DIR}/source/${id} -P ${PKM_FMU_SOURCE_DIR}/source_fmu.cmake
      DEPENDS ${source_md} ${gen}/fmu_vars.h ${PKM_CORE_SOURCES} ${PKM_FMU_SOURCE_DIR}/source_fmu.cmake
              ${PKM_FMU_SOURCE_DIR}/common/fmi2_functions.c ${PKM_FMU_SOURCE_DIR}/common/fmu_instance.c
              ${PKM_FMU_SOURCE_DIR}/common/fmu_state.c ${hooks} ${src}/model.c ${doc_out} ${res_out}
      COMMENT "source-code FMU ${out}"
      VERBATIM)
    add_custom_target(${id}_source_fmu ALL DEPENDS ${out})
  endif()
endfunction()

# pkm_add_described_fmu(<robot>): the FMUs of robots/<robot>.toml with no code of their own
# (the plant PKM_<ROBOT> and its controller PKM_<ROBOT>_CTRL):
# the common variable table (described/variables.txt.in: pose names and units from the
# core) and model.c; fmu_gen packs the description into the binary (the core compiles it
# when the FMU is instantiated) and a copy goes to resources/ for the reader.
# <robot> may also be the absolute path of a description file anywhere (PKM_FMU_DESCRIPTIONS):
# the FMU is named after the file (PKM_MY_STEWART from my_stewart.toml).
function(pkm_add_described_fmu robot)
  if(IS_ABSOLUTE ${robot})
    set(desc ${robot})
    get_filename_component(robot ${desc} NAME_WE)
  else()
    set(desc ${PKM_SOURCE_DIR}/robots/${robot}.toml)
  endif()
  string(TOUPPER "PKM_${robot}" FMU_ID)
  string(MAKE_C_IDENTIFIER ${FMU_ID} FMU_ID)
  file(STRINGS ${desc} _title REGEX "^title[ \t]*=")
  string(REGEX REPLACE "^title[ \t]*=[ \t]*\"([^\"]*)\".*" "\\1" FMU_TITLE "${_title}")
  if(NOT FMU_TITLE)
    set(FMU_TITLE ${robot})
  endif()
  set(FMU_ROBOT ${robot})
  set(FMU_DESCRIPTION_FILE ${desc})
  set(folder ${CMAKE_BINARY_DIR}/fmu_described/${robot})
  configure_file(${PKM_FMU_SOURCE_DIR}/described/variables.txt.in ${folder}/variables.txt @ONLY)
  configure_file(${PKM_FMU_SOURCE_DIR}/described/model.c ${folder}/model.c COPYONLY)
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${desc})
  pkm_add_fmu(${folder} RESOURCES ${desc})
  # and its joint-space controller FMU (what cosim export-ssp pairs with the plant)
  set(cfolder ${CMAKE_BINARY_DIR}/fmu_described/${robot}_ctrl)
  configure_file(${PKM_FMU_SOURCE_DIR}/described/controller_variables.txt.in ${cfolder}/variables.txt @ONLY)
  configure_file(${PKM_FMU_SOURCE_DIR}/described/model.c ${cfolder}/model.c COPYONLY)
  pkm_add_fmu(${cfolder} HOOKS common/controller.c RESOURCES ${desc})
endfunction()

# pkm_add_fmu_platforms([CORE_OBJECTS_FROM <build dir>]): the cross-compiled binaries of the FMUs
# added above: one ExternalProject per platform of PKM_FMU_EXTRA_PLATFORMS (fmu/platform), after
# fmu_gen has written every FMU's fmu_vars.h; each FMU's zip waits for them.  The sub-build is
# incremental (BUILD_ALWAYS only asks it to check).  With CORE_OBJECTS_FROM, the core of each
# platform is not compiled again: the objects of that build's sub-build are linked
# (fmu/described, the FMUs of a description file in a tree of their own).
function(pkm_add_fmu_platforms)
  cmake_parse_arguments(F "" "CORE_OBJECTS_FROM" "" ${ARGN})
  if(TARGET Eigen3::Eigen)
    get_target_property(_eigen_inc Eigen3::Eigen INTERFACE_INCLUDE_DIRECTORIES)
  else()
    set(_eigen_inc ${EIGEN3_INCLUDE_DIR})
  endif()
  get_property(_records GLOBAL PROPERTY PKM_FMU_RECORDS)
  get_property(_generated GLOBAL PROPERTY PKM_FMU_GENERATED)
  get_property(_zips GLOBAL PROPERTY PKM_FMU_ZIP_TARGETS)
  string(REPLACE ";" "\n" _records_text "${_records}")
  file(WRITE ${PKM_FMU_DIR}/platform_fmus.txt.new "${_records_text}\n")
  configure_file(${PKM_FMU_DIR}/platform_fmus.txt.new ${PKM_FMU_DIR}/platform_fmus.txt COPYONLY)  # touched if changed
  add_custom_target(pkm_fmu_generated DEPENDS ${_generated})
  foreach(p ${PKM_FMU_EXTRA_PLATFORMS})
    set(core "")
    if(F_CORE_OBJECTS_FROM)
      set(core -DPKM_CORE_OBJECTS=${F_CORE_OBJECTS_FROM}/fmu_platform/${p}/pkm_core_objects.txt)
    endif()
    get_property(_bins GLOBAL PROPERTY PKM_FMU_BINARIES_${p})
    ExternalProject_Add(pkm_fmu_${p}
      SOURCE_DIR ${PKM_FMU_SOURCE_DIR}/platform
      BINARY_DIR ${CMAKE_BINARY_DIR}/fmu_platform/${p}
      CMAKE_ARGS
        -DCMAKE_TOOLCHAIN_FILE=${PKM_SOURCE_DIR}/cmake/toolchains/${_toolchain_${p}}.cmake
        -DCMAKE_BUILD_TYPE=Release
        -DCMAKE_C_COMPILER_LAUNCHER=${CMAKE_C_COMPILER_LAUNCHER}
        -DCMAKE_CXX_COMPILER_LAUNCHER=${CMAKE_CXX_COMPILER_LAUNCHER}
        -DPKM_SOURCE_DIR=${PKM_SOURCE_DIR}
        -DPKM_FMU_LIST=${PKM_FMU_DIR}/platform_fmus.txt
        -DPKM_FMU_DIR=${PKM_FMU_DIR}
        -DPKM_FMI_PLATFORM=${p}
        -DFMI2_HEADERS_DIR=${FMI2_HEADERS_DIR}
        -DFMI3_HEADERS_DIR=${FMI3_HEADERS_DIR}
        -DEIGEN3_INCLUDE_DIR=${_eigen_inc}
      ${core}
      BUILD_ALWAYS ON
      INSTALL_COMMAND ""
      BUILD_BYPRODUCTS ${_bins}
      DEPENDS pkm_fmu_generated)
    foreach(z ${_zips})
      add_dependencies(${z} pkm_fmu_${p})
    endforeach()
  endforeach()
endfunction()
