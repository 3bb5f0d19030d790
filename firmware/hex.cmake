# Script mode (cmake -P), run after each link by ax12_firmware_hex() in CMakeLists.txt: the
# Intel HEX files a programmer (avrdude, `scripts/ax12 flash-isp`) writes to the part.
#   -DOBJCOPY=avr-objcopy -DSIZE_TOOL=avr-size -DELF=<elf> -DHEX=<stem>
# writes <stem>.hex: the flash image, .text and .data (the initialisers of .data are stored
# in flash right after .text; their load address is what objcopy uses), and, only when the
# ELF has an .eeprom section (an EEMEM factory image), <stem>-eeprom.hex with it at EEPROM
# address 0; otherwise a stale <stem>-eeprom.hex is removed. Today's firmware has no .eeprom
# section: a blank EEPROM boots with factory defaults, which it writes back itself
# (docs/hardware.md "EEPROM image").
cmake_minimum_required(VERSION 3.20)
foreach(var OBJCOPY SIZE_TOOL ELF HEX)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "hex.cmake: ${var} is not set")
  endif()
endforeach()
execute_process(COMMAND ${OBJCOPY} -O ihex -j .text -j .data ${ELF} ${HEX}.hex RESULT_VARIABLE failed)
if(failed)
  message(FATAL_ERROR "${OBJCOPY} -O ihex ${ELF} failed")
endif()
execute_process(COMMAND ${SIZE_TOOL} -A ${ELF} OUTPUT_VARIABLE sections RESULT_VARIABLE failed)
if(failed)
  message(FATAL_ERROR "${SIZE_TOOL} -A ${ELF} failed")
endif()
if(sections MATCHES "\n\\.eeprom[ \t]+[1-9]")
  execute_process(COMMAND ${OBJCOPY} -O ihex -j .eeprom --set-section-flags=.eeprom=alloc,load
                          --change-section-lma .eeprom=0 ${ELF} ${HEX}-eeprom.hex
                  RESULT_VARIABLE failed)
  if(failed)
    message(FATAL_ERROR "${OBJCOPY} -O ihex -j .eeprom ${ELF} failed")
  endif()
else()
  file(REMOVE ${HEX}-eeprom.hex)
endif()
