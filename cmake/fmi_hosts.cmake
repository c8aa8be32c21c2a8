# pkm_add_fmi_hosts(<source dir> <output dir>): the tests' small FMI 2.0 and FMI 3.0 hosts
# (tests/fmu/host/fmi_host.c, one source built as fmi2_host and fmi3_host) in <output dir>.
# Included by fmu/CMakeLists.txt (this machine's hosts, tests/fmu/test_platforms.py and
# tests/fmu/test_fmi3_host.py) and fmu/platform/CMakeLists.txt (each cross-compiled
# platform's, run under Wine or QEMU to drive that platform's binaries).  Needs
# FMI2_HEADERS_DIR and FMI3_HEADERS_DIR.
function(pkm_add_fmi_hosts source_dir out_dir)
  foreach(v 2 3)
    add_executable(fmi${v}_host ${source_dir}/tests/fmu/host/fmi_host.c)
    target_include_directories(fmi${v}_host PRIVATE ${FMI2_HEADERS_DIR} ${FMI3_HEADERS_DIR})
    target_compile_definitions(fmi${v}_host PRIVATE PKM_HOST_FMI=${v})
    set_target_properties(fmi${v}_host PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${out_dir})
    if(WIN32)
      target_link_options(fmi${v}_host PRIVATE -static)  # needs only Windows' own DLLs
    else()
      target_link_libraries(fmi${v}_host PRIVATE ${CMAKE_DL_LIBS} m)
    endif()
  endforeach()
endfunction()
