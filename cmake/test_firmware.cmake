# Test-only firmware builds: the product's sources with one test option set (firmware/
# CMakeLists.txt: AX12_INJECT_HANG, AX12_CONFORM_DEFECT), built through
# ExternalProject in their own folders so their ELFs never mix with the product's.
#
#   ax12_add_test_firmware(NAME <target> MCU <mcu> OPTION <cache variable> VALUE <value>
#                          OUTPUT_DIR <dir> [PROFILE <profile>])
# builds <dir>/ax12-<profile>-<mcu>.elf (profile ax12 unless given).
include_guard(GLOBAL)
include(ExternalProject)

include(${CMAKE_CURRENT_LIST_DIR}/../firmware/bootable_mcus.cmake)

function(ax12_add_test_firmware)
  cmake_parse_arguments(arg "" "NAME;MCU;OPTION;VALUE;OUTPUT_DIR;PROFILE" "" ${ARGN})
  if(NOT arg_PROFILE)
    set(arg_PROFILE ax12)
  endif()
  # As the product's build of that part (cmake/firmware.cmake), whatever an older configure left.
  set(with_bootloader OFF)
  if(arg_MCU IN_LIST AX12_BOOTABLE_MCUS)
    set(with_bootloader ON)
  endif()
  ExternalProject_Add(${arg_NAME}
    SOURCE_DIR ${CMAKE_SOURCE_DIR}/firmware
    BINARY_DIR ${CMAKE_CURRENT_BINARY_DIR}/${arg_NAME}
    CMAKE_ARGS -DCMAKE_TOOLCHAIN_FILE=${CMAKE_SOURCE_DIR}/cmake/avr-gcc.cmake
               -DAVR_MCU=${arg_MCU}
               -DDXL_PROFILE_NAME=${arg_PROFILE}
               -D${arg_OPTION}=${arg_VALUE}
               -DAX12_FIRMWARE_WITH_BOOTLOADER=${with_bootloader}
               -DAX12_FIRMWARE_OUTPUT_DIR=${arg_OUTPUT_DIR}
    BUILD_ALWAYS ON
    INSTALL_COMMAND ""
    BUILD_BYPRODUCTS ${arg_OUTPUT_DIR}/ax12-${arg_PROFILE}-${arg_MCU}.elf)
endfunction()
