# Test-only firmware builds: the product's sources with one test option set (firmware/
# CMakeLists.txt: AX12_INJECT_HANG, AX12_CONFORM_DEFECT, AX12_TEST_WITHOUT), built through
# ExternalProject in their own folders so their ELFs never mix with the product's.
#
#   ax12_add_test_firmware(NAME <target> MCU <mcu> OPTION <cache variable> VALUE <value>
#                          OUTPUT_DIR <dir> [PROFILE <profile>] [ARGS -D...])
# builds <dir>/ax12-<profile>-<mcu>.elf (profile ax12 unless given); ARGS are further cache
# settings of the firmware project (AX12_FIRMWARE_WITH_BOOTLOADER=ON).
include_guard(GLOBAL)
include(ExternalProject)

function(ax12_add_test_firmware)
  cmake_parse_arguments(arg "" "NAME;MCU;OPTION;VALUE;OUTPUT_DIR;PROFILE" "ARGS" ${ARGN})
  if(NOT arg_PROFILE)
    set(arg_PROFILE ax12)
  endif()
  ExternalProject_Add(${arg_NAME}
    SOURCE_DIR ${CMAKE_SOURCE_DIR}/firmware
    BINARY_DIR ${CMAKE_CURRENT_BINARY_DIR}/${arg_NAME}
    CMAKE_ARGS -DCMAKE_TOOLCHAIN_FILE=${CMAKE_SOURCE_DIR}/cmake/avr-gcc.cmake
               -DAVR_MCU=${arg_MCU}
               -DDXL_PROFILE_NAME=${arg_PROFILE}
               -D${arg_OPTION}=${arg_VALUE}
               ${arg_ARGS}
               -DAX12_FIRMWARE_OUTPUT_DIR=${arg_OUTPUT_DIR}
    BUILD_ALWAYS ON
    INSTALL_COMMAND ""
    BUILD_BYPRODUCTS ${arg_OUTPUT_DIR}/ax12-${arg_PROFILE}-${arg_MCU}.elf)
endfunction()
