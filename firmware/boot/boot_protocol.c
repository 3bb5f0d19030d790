/* The bootloader's protocol. See boot_protocol.h. */
#include "boot_protocol.h"

#include <string.h>

#include "boot_port.h"
#include "dxl_image.h"
#include "dxl_table.h"

#define INFO_HEAD_BYTES 8u

static uint16_t le16(const uint8_t *bytes) { return (uint16_t)(bytes[0] | ((uint16_t)bytes[1] << 8)); }

/* The CRC of flash bytes [0, length). */
static uint16_t flash_crc(uint16_t length) {
  uint16_t crc = BOOT_CRC_INITIAL;
  for (uint16_t address = 0; address < length; address++) {
    crc = dxl_crc16_update(crc, boot_port_flash_byte(address));
  }
  return crc;
}

static void flash_copy(uint8_t *out, uint16_t address, uint8_t count) {
  while (count--) {
    *out++ = boot_port_flash_byte(address++);
  }
}

void boot_init(boot_t *boot, uint8_t id, uint8_t entered_by) {
  memset(boot, 0, sizeof *boot);
  boot->id = id;
  boot->entered_by = entered_by;
}

bool boot_app_valid(void) {
  uint8_t record[BOOT_RECORD_BYTES];
  uint16_t length;
  uint16_t crc;
  flash_copy(record, BOOT_RECORD_ADDRESS, BOOT_RECORD_BYTES);
  return boot_record_parse(record, BOOT_RECORD_ADDRESS, &length, &crc) && flash_crc(length) == crc;
}

/* Programs one page and reads it back: 0 or BOOT_ERROR_PROGRAM. */
static uint8_t program_page(uint16_t address, const uint8_t *bytes) {
  boot_port_flash_program(address, bytes);
  for (uint8_t i = 0; i < BOOT_PAGE_BYTES; i++) {
    if (boot_port_flash_byte((uint16_t)(address + i)) != bytes[i]) {
      return BOOT_ERROR_PROGRAM;
    }
  }
  return 0;
}

/* Programs the record page: blank (the application is not valid from here on) or, at END,
 * with the record of the image BEGIN announced. */
static uint8_t program_record(const boot_t *boot, bool with_record) {
  uint8_t page[BOOT_PAGE_BYTES];
  memset(page, 0xFF, sizeof page);
  if (with_record) {
    boot_record_build(page, boot->image_length, boot->image_crc);
  }
  return program_page(BOOT_RECORD_ADDRESS, page);
}

static uint8_t on_begin(boot_t *boot, const uint8_t *params) {
  const uint16_t length = le16(params);
  boot->begun = false;
  if (length == 0 || length > BOOT_RECORD_ADDRESS) {
    return BOOT_ERROR_RANGE;
  }
  boot->image_length = length;
  boot->image_crc = le16(&params[2]);
  const uint8_t error = program_record(boot, false);
  boot->begun = error == 0;
  return error;
}

/* True when address starts a page below limit. */
static bool is_page_below(uint16_t address, uint16_t limit) {
  return (address & (BOOT_PAGE_BYTES - 1u)) == 0 && address < limit;
}

static uint8_t on_page(const boot_t *boot, const uint8_t *params) {
  const uint16_t address = le16(params);
  if (!boot->begun || !is_page_below(address, BOOT_RECORD_ADDRESS)) {
    return BOOT_ERROR_RANGE;
  }
  if (boot_crc_bytes(BOOT_CRC_INITIAL, &params[4], BOOT_PAGE_BYTES) != le16(&params[2])) {
    return BOOT_ERROR_CRC;
  }
  return program_page(address, &params[4]);
}

static uint8_t on_end(const boot_t *boot) {
  if (!boot->begun) {
    return BOOT_ERROR_RANGE;
  }
  if (flash_crc(boot->image_length) != boot->image_crc) {
    return BOOT_ERROR_CRC;
  }
  return program_record(boot, true);
}

static void info(const boot_t *boot, uint8_t *out) {
  static const DXL_FLASH uint8_t head[INFO_HEAD_BYTES] = {'A', 'X', 'B', 'L', BOOT_VERSION, BOOT_SIGNATURE_0,
                                                          BOOT_SIGNATURE_1, BOOT_SIGNATURE_2};
  for (uint8_t i = 0; i < INFO_HEAD_BYTES; i++) {
    out[i] = head[i];
  }
  out[8] = BOOT_PAGE_BYTES;
  out[9] = 0;
  out[10] = (uint8_t)(BOOT_START & 0xFFu);
  out[11] = (uint8_t)(BOOT_START >> 8);
  out[12] = (uint8_t)(boot->entered_by | (boot_app_valid() ? BOOT_STATE_APP_VALID : 0u));
}

/* The parameter count each instruction takes; 0xFF for an unknown instruction. If-chains, not
 * a switch: gcc would make that a lookup table in RAM. */
static uint8_t param_count_of(uint8_t instruction) {
  if (instruction == BOOT_INST_ENTER || instruction == BOOT_INST_BEGIN) {
    return 4u;
  }
  if (instruction == BOOT_INST_PAGE) {
    return (uint8_t)(4u + BOOT_PAGE_BYTES);
  }
  if (instruction == BOOT_INST_READ) {
    return 2u;
  }
  if (instruction == BOOT_INST_PING || (instruction >= BOOT_INST_INFO && instruction <= BOOT_INST_GO)) {
    return 0;
  }
  return 0xFFu;
}

uint8_t boot_handle(boot_t *boot, const dxl_packet_t *packet, uint8_t reply[BOOT_REPLY_MAX_BYTES]) {
  if (packet->id != boot->id) {
    return 0;
  }
  const uint8_t *const params = packet->params;
  uint8_t *const out = &reply[5];
  uint8_t error = BOOT_ERROR_INSTRUCTION;
  uint8_t out_count = 0;
  if (packet->param_count == param_count_of(packet->instruction)) {
    error = 0;
    switch (packet->instruction) {
    case BOOT_INST_ENTER:
      if (params[0] != BOOT_ENTER_KEY_0 || params[1] != BOOT_ENTER_KEY_1 || params[2] != BOOT_ENTER_KEY_2 ||
          params[3] != BOOT_ENTER_KEY_3) {
        error = BOOT_ERROR_INSTRUCTION;
      }
      break;
    case BOOT_INST_INFO:
      info(boot, out);
      out_count = BOOT_INFO_BYTES;
      break;
    case BOOT_INST_BEGIN:
      error = on_begin(boot, params);
      break;
    case BOOT_INST_PAGE:
      error = on_page(boot, params);
      break;
    case BOOT_INST_END:
      error = on_end(boot);
      break;
    case BOOT_INST_READ: /* a page of the application area or the record page */
      error = BOOT_ERROR_RANGE;
      if (is_page_below(le16(params), BOOT_START)) {
        flash_copy(out, le16(params), BOOT_PAGE_BYTES);
        error = 0;
        out_count = BOOT_PAGE_BYTES;
      }
      break;
    case BOOT_INST_GO:
      error = boot_app_valid() ? 0u : BOOT_ERROR_CRC;
      boot->start_app = error == 0;
      break;
    default: /* PING */
      break;
    }
  }
  reply[0] = 0xFFu;
  reply[1] = 0xFFu;
  reply[2] = boot->id;
  reply[3] = (uint8_t)(out_count + 2u);
  reply[4] = error;
  uint8_t sum = 0;
  for (uint8_t i = 2; i < out_count + 5u; i++) {
    sum = (uint8_t)(sum + reply[i]);
  }
  reply[5u + out_count] = (uint8_t)~sum;
  return (uint8_t)(out_count + 6u);
}
