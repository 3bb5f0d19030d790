# The AVR firmware, built by its own CMake project (firmware/CMakeLists.txt, toolchain
# cmake/avr-gcc.cmake) once per MCU x behaviour profile, through ExternalProject: a CMake
# project has one C compiler, and this one is the host's. Included by the top-level
# CMakeLists.txt when AX12_BUILD_FIRMWARE is ON.
#
# Provides, for the simulator and its tests:
#   AX12_FIRMWARE_DIR                   the ELFs: ${CMAKE_BINARY_DIR}/firmware/ax12-<profile>-<mcu>.elf
#   AX12_FIRMWARE_MCUS                  atmega88 atmega328p
#   AX12_FIRMWARE_PROFILES              ax12 ax12a
#   AX12_FIRMWARE_ELF_<profile>_<mcu>   the path of one ELF
#   AX12_FIRMWARE_ELFS                  all four paths
#   AX12_FIRMWARE_HEX_<profile>_<mcu>   its flash image in Intel HEX, beside it
#                                       (ax12-<profile>-<mcu>.hex, firmware/hex.cmake)
#   AX12_FIRMWARE_BOOT_MCUS             the parts the bootloader is built for (both)
#   AX12_FIRMWARE_BOOT_ELF_<mcu>, AX12_FIRMWARE_BOOT_HEX_<mcu>
#                                       its ELF and HEX (ax12-boot-<mcu>.elf/.hex)
#   AX12_FIRMWARE_BOOTABLE_MCUS         the parts whose applications sit beside it
#   AX12_FIRMWARE_MERGED_HEX_<profile>_<mcu>
#                                       for those: the whole flash of a new board,
#                                       application, its record and the bootloader
#                                       (ax12-<profile>-<mcu>-merged.hex)
#   target firmware                     builds all four (part of ALL); add_dependencies() on it
#   targets firmware-<profile>-<mcu>    one each
#   target firmware-merged-hex          the merged HEX files (part of firmware)
# Every build re-runs the four sub-builds (BUILD_ALWAYS: their sources are not known here),
# which recompile what changed and print each ELF's flash and RAM use; the ATmega88 builds
# fail above 8192 B flash or 1024 B static RAM.
include_guard(GLOBAL)
include(ExternalProject)

find_program(AX12_AVR_GCC avr-gcc)
find_program(AX12_AVR_OBJCOPY avr-objcopy)
if(NOT AX12_AVR_GCC)
  message(FATAL_ERROR "avr-gcc not found: install gcc-avr avr-libc binutils-avr, "
                      "or configure with -DAX12_BUILD_FIRMWARE=OFF")
endif()

get_filename_component(ax12_repo_dir ${CMAKE_CURRENT_LIST_DIR}/.. ABSOLUTE)
set(AX12_FIRMWARE_DIR ${CMAKE_BINARY_DIR}/firmware)
set(AX12_FIRMWARE_MCUS atmega88 atmega328p)
set(AX12_FIRMWARE_PROFILES ax12 ax12a)
set(AX12_FIRMWARE_ELFS "")

add_custom_target(firmware ALL COMMENT "AVR firmware: ${AX12_FIRMWARE_DIR}")
# The bootloader (docs/bootloader.md) is built for both parts, once, in the ax12 profile's
# project. The applications sit beside it on the parts of firmware/bootable_mcus.cmake.
set(AX12_FIRMWARE_BOOT_MCUS atmega88 atmega328p)
include(${ax12_repo_dir}/firmware/bootable_mcus.cmake)
set(AX12_FIRMWARE_BOOTABLE_MCUS ${AX12_BOOTABLE_MCUS})
foreach(mcu ${AX12_FIRMWARE_MCUS})
  foreach(profile ${AX12_FIRMWARE_PROFILES})
    set(elf ${AX12_FIRMWARE_DIR}/ax12-${profile}-${mcu}.elf)
    # Said on every configure (not left to the option's default), so that a build folder made
    # before a part joined AX12_BOOTABLE_MCUS follows it.
    if(mcu IN_LIST AX12_FIRMWARE_BOOTABLE_MCUS)
      set(boot_args -DAX12_FIRMWARE_WITH_BOOTLOADER=ON)
    else()
      set(boot_args -DAX12_FIRMWARE_WITH_BOOTLOADER=OFF)
    endif()
    set(boot_products "")
    if(profile STREQUAL "ax12" AND mcu IN_LIST AX12_FIRMWARE_BOOT_MCUS)
      list(APPEND boot_args -DAX12_FIRMWARE_BOOTLOADER=ON)
      set(AX12_FIRMWARE_BOOT_ELF_${mcu} ${AX12_FIRMWARE_DIR}/ax12-boot-${mcu}.elf)
      set(AX12_FIRMWARE_BOOT_HEX_${mcu} ${AX12_FIRMWARE_DIR}/ax12-boot-${mcu}.hex)
      set(boot_products ${AX12_FIRMWARE_BOOT_ELF_${mcu}} ${AX12_FIRMWARE_BOOT_HEX_${mcu}})
    endif()
    ExternalProject_Add(firmware-${profile}-${mcu}
      SOURCE_DIR ${ax12_repo_dir}/firmware
      BINARY_DIR ${CMAKE_BINARY_DIR}/firmware-build/${profile}-${mcu}
      CMAKE_ARGS -DCMAKE_TOOLCHAIN_FILE=${ax12_repo_dir}/cmake/avr-gcc.cmake
                 -DAVR_MCU=${mcu}
                 -DDXL_PROFILE_NAME=${profile}
                 -DAX12_FIRMWARE_OUTPUT_DIR=${AX12_FIRMWARE_DIR}
                 ${boot_args}
      BUILD_ALWAYS ON
      INSTALL_COMMAND ""
      BUILD_BYPRODUCTS ${elf} ${AX12_FIRMWARE_DIR}/ax12-${profile}-${mcu}.hex ${boot_products})
    add_dependencies(firmware firmware-${profile}-${mcu})
    set(AX12_FIRMWARE_ELF_${profile}_${mcu} ${elf})
    set(AX12_FIRMWARE_HEX_${profile}_${mcu} ${AX12_FIRMWARE_DIR}/ax12-${profile}-${mcu}.hex)
    list(APPEND AX12_FIRMWARE_ELFS ${elf})
  endforeach()
endforeach()

# The merged HEX of each application that sits beside the bootloader (docs/bootloader.md
# "Flash layout"), by scripts/ax12_merge_hex.py with the project's Python (scripts/setup's
# .venv: intelhex). Run on every build after the sub-builds (one per part writes the
# bootloader's HEX); it rewrites a merged HEX only when its bytes change, and writes none while
# the bootloader's HEX does not exist.
set(ax12_python ${ax12_repo_dir}/.venv/bin/python)
add_custom_target(firmware-merged-hex COMMENT "merged HEX: application + record + bootloader")
foreach(mcu ${AX12_FIRMWARE_BOOTABLE_MCUS})
  foreach(profile ${AX12_FIRMWARE_PROFILES})
    set(AX12_FIRMWARE_MERGED_HEX_${profile}_${mcu} ${AX12_FIRMWARE_DIR}/ax12-${profile}-${mcu}-merged.hex)
    add_custom_command(TARGET firmware-merged-hex POST_BUILD
      COMMAND ${ax12_python} ${ax12_repo_dir}/scripts/ax12_merge_hex.py --mcu ${mcu}
              ${AX12_FIRMWARE_HEX_${profile}_${mcu}} ${AX12_FIRMWARE_BOOT_HEX_${mcu}}
              ${AX12_FIRMWARE_MERGED_HEX_${profile}_${mcu}}
      VERBATIM)
    add_dependencies(firmware-merged-hex firmware-${profile}-${mcu} firmware-ax12-${mcu})
  endforeach()
endforeach()
add_dependencies(firmware firmware-merged-hex)
