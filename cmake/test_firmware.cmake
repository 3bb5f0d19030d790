# Test-only firmware builds: the product's sources with one test option set (firmware/
# CMakeLists.txt: AX12_INJECT_HANG, AX12_CONFORM_DEFECT), built through ExternalProject in
# their own folders so their ELFs never mix with the product's.
#
#   ax12_add_test_firmware(NAME <target> MCU <mcu> OPTION <cache variable> VALUE <value>
#                          OUTPUT_DIR <dir>)
# builds <dir>/ax12-ax12-<mcu>.elf (profile ax12).
include_guard(GLOBAL)
include(ExternalProject)

function(ax12_add_test_firmware)
  cmake_parse_arguments(arg "" "NAME;MCU;OPTION;VALUE;OUTPUT_DIR" "" ${ARGN})
  ExternalProject_Add(${arg_NAME}
    SOURCE_DIR ${CMAKE_SOURCE_DIR}/firmware
    BINARY_DIR ${CMAKE_CURRENT_BINARY_DIR}/${arg_NAME}
    CMAKE_ARGS -DCMAKE_TOOLCHAIN_FILE=${CMAKE_SOURCE_DIR}/cmake/avr-gcc.cmake
               -DAVR_MCU=${arg_MCU}
               -DDXL_PROFILE_NAME=ax12
               -D${arg_OPTION}=${arg_VALUE}
               -DAX12_FIRMWARE_OUTPUT_DIR=${arg_OUTPUT_DIR}
    BUILD_ALWAYS ON
    INSTALL_COMMAND ""
    BUILD_BYPRODUCTS ${arg_OUTPUT_DIR}/ax12-ax12-${arg_MCU}.elf)
endfunction()
