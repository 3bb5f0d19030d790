/* Dynamixel Protocol 1.0 constants as the AX-12 uses them. */
#ifndef DXL_PROTOCOL_H
#define DXL_PROTOCOL_H

#define DXL_HEADER_BYTE 0xFFu
#define DXL_ID_BROADCAST 0xFEu
#define DXL_ID_MAX 253u

/* Instruction codes. */
#define DXL_INST_PING 0x01u
#define DXL_INST_READ 0x02u
#define DXL_INST_WRITE 0x03u
#define DXL_INST_REG_WRITE 0x04u
#define DXL_INST_ACTION 0x05u
#define DXL_INST_RESET 0x06u
#define DXL_INST_SYNC_WRITE 0x83u
/* Enters the bootloader (docs/bootloader.md), only with the 4 parameters "BOOT" and only in a
 * build with a bootloader (DXL_HAS_BOOTLOADER); otherwise an unknown instruction. */
#define DXL_INST_BOOTLOADER 0x0Au
#define DXL_BOOTLOADER_KEY_0 0x42u /* 'B' */
#define DXL_BOOTLOADER_KEY_1 0x4Fu /* 'O' */
#define DXL_BOOTLOADER_KEY_2 0x4Fu /* 'O' */
#define DXL_BOOTLOADER_KEY_3 0x54u /* 'T' */

/* Error byte of a status packet (docs/policy.md "Error byte"). Conditions hold in every reply while
 * true; events appear only in the reply to the offending packet. */
#define DXL_ERR_VOLTAGE 0x01u     /* condition */
#define DXL_ERR_ANGLE_LIMIT 0x02u /* condition */
#define DXL_ERR_OVERHEATING 0x04u /* condition */
#define DXL_ERR_RANGE 0x08u       /* event */
#define DXL_ERR_CHECKSUM 0x10u    /* event */
#define DXL_ERR_OVERLOAD 0x20u    /* condition */
#define DXL_ERR_INSTRUCTION 0x40u /* event */

#define DXL_ERR_CONDITIONS (DXL_ERR_VOLTAGE | DXL_ERR_ANGLE_LIMIT | DXL_ERR_OVERHEATING | DXL_ERR_OVERLOAD)
#define DXL_ERR_EVENTS (DXL_ERR_RANGE | DXL_ERR_CHECKSUM | DXL_ERR_INSTRUCTION)

/* Offset of the error byte in a status packet: FF FF ID LENGTH ERROR PARAMS... CHECKSUM. */
#define DXL_STATUS_ERROR_OFFSET 4u

/* Inter-byte gap that discards a partial packet. */
#define DXL_PACKET_GAP_TIMEOUT_MS 100u

/* Return Delay Time unit. */
#define DXL_RETURN_DELAY_UNIT_US 2u

#endif
