# The parts whose applications sit beside the bootloader (docs/bootloader.md "Flash layout"):
# built with DXL_HAS_BOOTLOADER and the budget the boot section and the record leave, with a
# merged HEX for a new board. Read by firmware/CMakeLists.txt and cmake/firmware.cmake;
# python/ax12_fuses.py's BOOTLOADER_MCUS must agree (test/board/test_firmware_hex.py).
set(AX12_BOOTABLE_MCUS atmega88 atmega328p)
