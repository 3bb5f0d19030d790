#include "dxl_servo.h"

#include "dxl_control.h"

#include <stddef.h>
#include <string.h>

#include "dxl_protocol.h"

/* Moving Speed in joint mode: 0..1023 (ct_items.h); in wheel mode bit 10 adds a direction. */
#define MOVING_SPEED_JOINT_MAX 1023u

/* The reply rules (docs/policy.md "Replies", "Instructions and their errors"), as two switches
 * (cheaper on the AVR than a table search on every packet):
 *   plan_instruction()   parameter counts that fit the instruction (else Instruction Error),
 *                        in the switch that plans it (one dispatch);
 *   min_status_level()   the Status Return Level from which a unicast packet is answered.
 * Broadcast packets are answered only for PING in the AX-12 profile. An instruction not
 * listed is an Instruction Error, answered from level 2. */
#define STATUS_LEVEL_ALL 2u
#define BROADCAST_PING_ANSWERED (DXL_PROFILE == DXL_PROFILE_AX12)

/* Deliberate defects, for the tests of `scripts/ax12 conform` only (test/conform builds extra
 * ELFs with them, through AX12_CONFORM_DEFECT in firmware/CMakeLists.txt): one ignores the
 * Status Return Level (answers as at level 2), one answers a broadcast READ. Never defined in
 * a product build. */
#ifdef AX12_CONFORM_DEFECT_IGNORE_SRL
#define STATUS_LEVEL(servo) STATUS_LEVEL_ALL
#else
#define STATUS_LEVEL(servo) ((servo)->table[CT_ADDR_STATUS_RETURN_LEVEL])
#endif
#ifdef AX12_CONFORM_DEFECT_BROADCAST_READ
#define BROADCAST_ANSWERED(instruction) \
  ((BROADCAST_PING_ANSWERED && (instruction) == DXL_INST_PING) || (instruction) == DXL_INST_READ)
#else
#define BROADCAST_ANSWERED(instruction) (BROADCAST_PING_ANSWERED && (instruction) == DXL_INST_PING)
#endif

#if DXL_HAS_BOOTLOADER
/* The key "BOOT" as one little-endian number (one 32-bit compare). Here, not in
 * dxl_protocol.h, whose every #define is one line (python/CMakeLists.txt reads them). */
#define BOOTLOADER_KEY_U32                                                                                        \
  ((uint32_t)DXL_BOOTLOADER_KEY_0 | (uint32_t)DXL_BOOTLOADER_KEY_1 << 8 | (uint32_t)DXL_BOOTLOADER_KEY_2 << 16 | \
   (uint32_t)DXL_BOOTLOADER_KEY_3 << 24)

/* The four bytes at bytes as one little-endian number. */
static uint32_t little_endian_u32(const uint8_t *bytes) {
  return (uint32_t)bytes[0] | (uint32_t)bytes[1] << 8 | (uint32_t)bytes[2] << 16 | (uint32_t)bytes[3] << 24;
}
#endif

static uint8_t min_status_level(uint8_t instruction) {
  switch (instruction) {
  case DXL_INST_PING:
#if DXL_HAS_BOOTLOADER
  case DXL_INST_BOOTLOADER: /* answered as a PING: the flasher must know it was heard */
#endif
    return 0;
  case DXL_INST_READ:
    return 1;
  default:
    return STATUS_LEVEL_ALL;
  }
}

bool dxl_servo_answers(const dxl_servo_t *servo, uint8_t id, uint8_t instruction) {
  if (id == DXL_ID_BROADCAST) {
    return BROADCAST_ANSWERED(instruction);
  }
  if (id != servo->table[CT_ADDR_ID]) { /* two returns, not one &&: smaller code */
    return false;
  }
  return STATUS_LEVEL(servo) >= min_status_level(instruction);
}


/* Whether the window [start, start + len) shares an address with [first_addr, last_addr], for
 * a window within the table (start + len <= CT_SIZE: every window ct_check_write() accepts),
 * so its end fits a byte. Two returns, not one &&: smaller on the ATmega88. */
static bool window_overlaps(uint8_t start, uint8_t len, uint8_t first_addr, uint8_t last_addr) {
  if (start > last_addr) {
    return false;
  }
  return (uint8_t)(start + len) > first_addr;
}

/* Angle Limit condition (docs/policy.md "Goal Position and the angle limits"), for the table
 * as it is after writing data[0..len) at start (len 0: as it is now). In wheel mode every
 * Goal Position written lies outside the limits. */
static bool angle_limit_after_write(const dxl_servo_t *s, uint8_t start, const uint8_t *data, uint8_t len) {
  const uint16_t cw_limit = ct_u16_after_write(s->table, CT_ADDR_CW_ANGLE_LIMIT, start, data, len);
  const uint16_t ccw_limit = ct_u16_after_write(s->table, CT_ADDR_CCW_ANGLE_LIMIT, start, data, len);
  if (cw_limit == 0 && ccw_limit == 0) { /* wheel mode */
    /* Tests as returns, not one || of &&s: smaller on the ATmega88. */
    if (len != 0 && window_overlaps(start, len, CT_ADDR_GOAL_POSITION, CT_ADDR_GOAL_POSITION + 1)) {
      return true; /* a Goal Position written */
    }
    if (!ct_is_wheel_mode(s->table)) {
      return false;
    }
    return s->goal_written_in_wheel_mode;
  }
  const uint16_t goal = ct_u16_after_write(s->table, CT_ADDR_GOAL_POSITION, start, data, len);
  if (goal < cw_limit) { /* two returns, not one || */
    return true;
  }
  return goal > ccw_limit;
}

/* angle_limit_after_write() with nothing written, in a few table reads: it runs every control
 * tick. A copy on purpose: calling angle_limit_after_write(s, 0, NULL, 0) instead, or sharing
 * a helper with it, measured larger on the ATmega88 (and the call is slower).
 * In wheel mode the flag alone tells: apply_write() sets it afresh whenever wheel mode begins. */
static bool angle_limit_now(const dxl_servo_t *s) {
  const uint16_t cw_limit = ct_get_u16(s->table, CT_ADDR_CW_ANGLE_LIMIT);
  const uint16_t ccw_limit = ct_get_u16(s->table, CT_ADDR_CCW_ANGLE_LIMIT);
  if (cw_limit == 0 && ccw_limit == 0) {
    return s->goal_written_in_wheel_mode;
  }
  const uint16_t goal = ct_get_u16(s->table, CT_ADDR_GOAL_POSITION);
  if (goal < cw_limit) { /* two returns, not one || */
    return true;
  }
  return goal > ccw_limit;
}

uint8_t dxl_servo_conditions(const dxl_servo_t *servo) {
  uint8_t conditions = servo->held_conditions & (uint8_t)(DXL_ERR_CONDITIONS & ~DXL_ERR_ANGLE_LIMIT);
  if (angle_limit_now(servo)) {
    conditions |= DXL_ERR_ANGLE_LIMIT;
  }
  return conditions;
}

uint8_t dxl_servo_take_events(dxl_servo_t *servo) {
  const uint8_t events = servo->pending_events;
  servo->pending_events = 0;
  return events;
}

static void clear_registered(dxl_servo_t *s) {
  s->reg_len = 0;
  s->table[CT_ADDR_REGISTERED_INSTRUCTION] = 0;
}

DXL_ONE_COPY void dxl_servo_power_up(dxl_servo_t *servo, const uint8_t *eeprom_area, uint16_t present_position) {
  memset(servo, 0, sizeof *servo);
  ct_load_factory_defaults(servo->table);
  if (eeprom_area != NULL) {
    memcpy(servo->table, eeprom_area, CT_EEPROM_SIZE);
    ct_repair_stored_eeprom(servo->table); /* model, version from this firmware; no item out of range */
  }
  ct_set_power_up_ram(servo->table, present_position);
}

void dxl_servo_factory_reset(dxl_servo_t *servo) {
  const uint16_t present_position = ct_get_u16(servo->table, CT_ADDR_PRESENT_POSITION);
  const uint8_t held_conditions = servo->held_conditions;
  dxl_servo_power_up(servo, NULL, present_position);
  servo->held_conditions = held_conditions;
}

/* Effects on the UART and EEPROM of a write window, for response->after. */
static uint8_t after_flags_of_write(uint8_t start, uint8_t len) {
  uint8_t after = 0;
  if (window_overlaps(start, len, 0, CT_EEPROM_SIZE - 1)) {
    after |= DXL_AFTER_PERSIST;
  }
  if (window_overlaps(start, len, CT_ADDR_BAUD_RATE, CT_ADDR_BAUD_RATE)) {
    after |= DXL_AFTER_APPLY_BAUD;
  }
  return after;
}

uint8_t dxl_servo_stream_mask(const dxl_servo_t *servo) {
  /* min_status_level() per streamed instruction: PING 0, READ 1, WRITE, REG_WRITE and
   * ACTION 2 (two tests: smaller on the ATmega88 than a table by level). */
  const uint8_t level = STATUS_LEVEL(servo);
  uint8_t mask = 1u << DXL_INST_PING;
  if (level >= 1u) {
    mask |= 1u << DXL_INST_READ;
  }
  if (level >= STATUS_LEVEL_ALL) {
    mask |= (1u << DXL_INST_WRITE) | (1u << DXL_INST_REG_WRITE) | (1u << DXL_INST_ACTION);
  }
  if (servo->table[CT_ADDR_REGISTERED_INSTRUCTION] != 0 &&
      (after_flags_of_write(servo->reg_start, servo->reg_len) & DXL_AFTER_APPLY_BAUD) != 0) {
    mask &= (uint8_t)~(1u << DXL_INST_ACTION); /* it writes the Baud Rate: applied after the reply */
  }
  return mask;
}

/* The write of data[0..len) at start that action plans (WRITE, REG_WRITE, ACTION, SYNC_WRITE),
 * if ct_check_write() accepts it; returns its error bits. One copy for the three callers:
 * smaller on the ATmega88. */
static DXL_ONE_COPY uint8_t plan_checked_write(const dxl_servo_t *s, dxl_response_t *r, uint8_t action, uint8_t start,
                                  const uint8_t *data, uint8_t len) {
  const uint8_t error = ct_check_write(s->table, start, data, len);
  if (error == 0) {
    r->action = action;
    r->window_start = start;
    r->window_data = data;
    r->window_len = len;
  }
  return error;
}

/* Prepares the side effect of an instruction addressed to this servo (or broadcast) and
 * returns its event error bits: Instruction Error when its parameter count does not fit it
 * (PING, ACTION, RESET: none; READ: 2; WRITE, REG_WRITE, SYNC_WRITE: at least 2). */
static uint8_t plan_instruction(const dxl_servo_t *s, const dxl_packet_t *p, bool broadcast, dxl_response_t *r) {
  const uint8_t *params = p->params;
  const uint8_t count = p->param_count;
  switch (p->instruction) {
  case DXL_INST_PING:
    if (count != 0) {
      break;
    }
    return 0;
  case DXL_INST_READ: {
    if (count != 2) {
      break;
    }
    const uint8_t start = params[0];
    const uint8_t len = params[1];
    if (len == 0 || start >= CT_SIZE || len > (uint8_t)(CT_SIZE - start)) {
      return DXL_ERR_RANGE;
    }
    r->window_start = start;
    r->window_len = len;
    return 0;
  }
  case DXL_INST_WRITE:
  case DXL_INST_REG_WRITE:
    if (count < 2) {
      break;
    }
    return plan_checked_write(s, r, p->instruction == DXL_INST_WRITE ? DXL_ACTION_WRITE : DXL_ACTION_REGISTER,
                              params[0], &params[1], (uint8_t)(count - 1u));
  case DXL_INST_ACTION:
    if (count != 0) {
      break;
    }
    if (s->table[CT_ADDR_REGISTERED_INSTRUCTION] == 0) {
      return DXL_ERR_INSTRUCTION;
    }
    /* Validated at REG_WRITE; checked again in case Lock or the limits changed since (a
     * refusal is a Range Error, the only error ct_check_write() returns). */
    return plan_checked_write(s, r, DXL_ACTION_RUN_REGISTERED, s->reg_start, s->reg_data, s->reg_len);
#if DXL_HAS_BOOTLOADER
  case DXL_INST_BOOTLOADER:
    if (broadcast || count != 4u || little_endian_u32(params) != BOOTLOADER_KEY_U32) {
      break;
    }
    r->after |= DXL_AFTER_BOOTLOADER;
    return 0;
#endif
  case DXL_INST_RESET:
    if (count != 0) {
      break;
    }
    if (s->table[CT_ADDR_LOCK] != 0) {
      return DXL_ERR_INSTRUCTION;
    }
    r->action = DXL_ACTION_RESET;
    return 0;
  case DXL_INST_SYNC_WRITE: {
    if (count < 2) {
      break;
    }
    if (!broadcast) {
      return DXL_ERR_INSTRUCTION;
    }
    const uint8_t start = params[0];
    const uint8_t slice_data_len = params[1];
    uint8_t left = (uint8_t)(count - 2u); /* the slices' bytes from slice on */
    if (slice_data_len == 0 || left == 0) {
      return 0; /* LENGTH does not fit: the whole packet is ignored */
    }
    /* Every slice is walked (no division on the AVR), in bytes (a slice of 256 never fits
     * the at most 251 bytes): the slices must end exactly at the packet's end, else the whole
     * packet is ignored. */
    const uint8_t *slice = &params[2];
    const uint8_t *own = NULL;
    for (;;) {
      if (own == NULL && slice[0] == s->table[CT_ADDR_ID]) {
        own = slice;
      }
      if (left <= slice_data_len) {
        return 0; /* the last slice is cut short */
      }
      left = (uint8_t)(left - slice_data_len - 1u);
      if (left == 0) {
        break;
      }
      slice += slice_data_len + 1u;
    }
    if (own == NULL) {
      return 0;
    }
    return plan_checked_write(s, r, DXL_ACTION_WRITE, start, own + 1, slice_data_len);
  }
  default:
    break;
  }
  return DXL_ERR_INSTRUCTION;
}

static void encode_status(const dxl_servo_t *s, uint8_t error, const uint8_t *params, uint8_t param_count,
                          dxl_response_t *r) {
  uint8_t *out = r->bytes;
  const uint8_t id = s->table[CT_ADDR_ID];
  const uint8_t length = (uint8_t)(param_count + 2u);
  uint8_t sum = (uint8_t)(id + length + error);
  out[0] = DXL_HEADER_BYTE;
  out[1] = DXL_HEADER_BYTE;
  out[2] = id;
  out[3] = length;
  out[4] = error;
  out += 5;
  for (uint8_t i = 0; i < param_count; i++) {
    const uint8_t b = params[i];
    sum = (uint8_t)(sum + b);
    *out++ = b;
  }
  *out = (uint8_t)~sum;
  r->length = (uint8_t)(length + 4u);
  r->delay_us = (uint16_t)(DXL_RETURN_DELAY_UNIT_US * s->table[CT_ADDR_RETURN_DELAY_TIME]);
}

/* Everything but the reply bytes: no reply, no action, no events. */
static void response_clear(dxl_response_t *r) {
  memset(r, 0, offsetof(dxl_response_t, bytes));
}

void dxl_servo_prepare(const dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response) {
  const dxl_servo_t *s = servo;
  dxl_response_t *r = response;
  DXL_OPAQUE(r); /* its fields by displacement (dxl_config.h) */
  response_clear(r);
  const bool broadcast = packet->id == DXL_ID_BROADCAST;
  if (!broadcast && packet->id != s->table[CT_ADDR_ID]) {
    return; /* another servo's packet, or a status packet on the bus */
  }
  r->events = plan_instruction(s, packet, broadcast, r);

  /* The Angle Limit condition as it will be after this packet. */
  uint8_t start = 0;
  uint8_t len = 0;
  const uint8_t *data = NULL;
  switch (r->action) {
  case DXL_ACTION_WRITE:
  case DXL_ACTION_RUN_REGISTERED:
    start = r->window_start;
    len = r->window_len;
    data = r->window_data;
    r->after = after_flags_of_write(start, len);
    break;
  case DXL_ACTION_RESET:
    r->after = DXL_AFTER_FACTORY_RESET | DXL_AFTER_APPLY_BAUD | DXL_AFTER_PERSIST;
    break;
  default:
    break;
  }

  if (!dxl_servo_answers(s, packet->id, packet->instruction)) {
    return;
  }
  uint8_t error = (uint8_t)(r->events | (s->held_conditions & (DXL_ERR_CONDITIONS & ~DXL_ERR_ANGLE_LIMIT)));
  if (angle_limit_after_write(s, start, data, len)) {
    error |= DXL_ERR_ANGLE_LIMIT;
  }
  /* Two calls, not one with two conditional arguments: smaller on the ATmega88. */
  if (packet->instruction == DXL_INST_READ && r->events == 0) { /* (so it fits) */
    encode_status(s, error, &s->table[r->window_start], r->window_len, r);
  } else {
    encode_status(s, error, NULL, 0, r);
  }
}

void dxl_servo_ping_reply(const dxl_servo_t *servo, dxl_response_t *reply) {
  encode_status(servo, dxl_servo_conditions(servo), NULL, 0, reply);
}

/* The one write path into the table for instructions (WRITE, ACTION, SYNC_WRITE). The
 * window was checked by ct_check_write(). */
static void apply_write(dxl_servo_t *s, uint8_t start, const uint8_t *data, uint8_t len) {
  DXL_OPAQUE(s); /* the table and slot by displacement: smaller on the ATmega88 */
  const bool was_wheel_mode = ct_is_wheel_mode(s->table);
  for (uint8_t i = 0; i < len; i++) {
    const uint8_t addr = (uint8_t)(start + i);
    if (addr == CT_ADDR_REGISTERED_INSTRUCTION) {
      if (data[i] == 0) {
        clear_registered(s); /* writing 0 discards the registered write; 1 changes nothing */
      }
      continue;
    }
    s->table[addr] = data[i];
  }
  if (ct_is_wheel_mode(s->table)) {
    const bool goal_written = window_overlaps(start, len, CT_ADDR_GOAL_POSITION, CT_ADDR_GOAL_POSITION + 1);
    s->goal_written_in_wheel_mode = goal_written || (was_wheel_mode && s->goal_written_in_wheel_mode);
  } else {
    s->goal_written_in_wheel_mode = false;
    /* docs/policy.md "Motion semantics": back in joint mode, a wheel-mode Moving Speed keeps
     * its speed (bits 0..9) and drops its direction (bit 10), inside the joint range 0..1023. */
    s->table[CT_ADDR_MOVING_SPEED + 1] &= (uint8_t)(MOVING_SPEED_JOINT_MAX >> 8);
  }
  dxl_control_after_write(s->table);
}

void dxl_servo_commit(dxl_servo_t *servo, const dxl_response_t *response) {
  dxl_servo_t *s = servo;
  const dxl_response_t *r = response;
  DXL_OPAQUE(r); /* with prepare's: smaller on the ATmega88 (measured) */
  s->pending_events |= r->events;
  switch (r->action) {
  case DXL_ACTION_WRITE:
    apply_write(s, r->window_start, r->window_data, r->window_len);
    break;
  case DXL_ACTION_REGISTER:
    memcpy(s->reg_data, r->window_data, r->window_len);
    s->reg_start = r->window_start;
    s->reg_len = r->window_len;
    s->table[CT_ADDR_REGISTERED_INSTRUCTION] = 1;
    break;
  case DXL_ACTION_RUN_REGISTERED: {
    /* The slot is emptied first; its bytes stay (apply_write writes the table alone). */
    const uint8_t len = s->reg_len;
    clear_registered(s);
    apply_write(s, s->reg_start, s->reg_data, len);
    break;
  }
  default: /* RESET runs after the reply: DXL_AFTER_FACTORY_RESET */
    break;
  }
}

void dxl_servo_handle(dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response) {
  dxl_servo_prepare(servo, packet, response);
  dxl_servo_commit(servo, response);
}

void dxl_servo_reject_checksum(dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response) {
  response_clear(response);
  if (packet->id != servo->table[CT_ADDR_ID]) {
    return;
  }
  response->events = DXL_ERR_CHECKSUM;
  servo->pending_events |= DXL_ERR_CHECKSUM;
  if (STATUS_LEVEL(servo) >= STATUS_LEVEL_ALL) {
    encode_status(servo, (uint8_t)(DXL_ERR_CHECKSUM | dxl_servo_conditions(servo)), NULL, 0, response);
  }
}
