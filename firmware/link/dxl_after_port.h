/* The board functions the after-reply policy (dxl_after.h) calls, defined by whoever runs it:
 * the firmware (firmware/app) and the host bus of the tests. port is the caller's handle,
 * passed through unchanged (the firmware has one servo and passes NULL). */
#ifndef DXL_AFTER_PORT_H
#define DXL_AFTER_PORT_H

#include <stdint.h>

#include "dxl_config.h"

/* Starts storing the EEPROM area of table (CT_EEPROM_SIZE bytes, copied at once). */
void dxl_after_port_persist(void *port, const uint8_t *table);

/* Reprograms the UART from a Baud Rate register value; the bus is idle. */
void dxl_after_port_set_baud(void *port, uint8_t baud_register);

#if DXL_HAS_BOOTLOADER
/* Enters the bootloader when no store of the settings is under way; otherwise returns and the
 * application stays (the flasher asks again; docs/bootloader.md "Entering from the
 * application"). The bus is idle. On the board, entering does not return. */
void dxl_after_port_enter_bootloader(void *port);
#endif

#endif
