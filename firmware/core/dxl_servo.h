/* One AX-12's protocol behaviour: the control table, the REG_WRITE slot and the seven
 * instructions, with Status Return Level, broadcast and error semantics from docs/policy.md.
 *
 * Handling a packet is split in two so the firmware can start the reply the moment the last
 * byte arrives:
 *   dxl_servo_prepare()  decides everything about a packet (reply bytes, when it may start,
 *                        what changes after it) from the packet and the current state, and
 *                        changes nothing. It may run before the checksum byte has arrived.
 *   dxl_servo_commit()   applies the prepared side effects once the checksum was good.
 * dxl_servo_handle() does both. After the reply's last byte has left (or at once when there
 * is no reply) the caller acts on response.after (see DXL_AFTER_*).
 */
#ifndef DXL_SERVO_H
#define DXL_SERVO_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_packet.h"
#include "dxl_table.h"

/* Longest write a REG_WRITE can hold: the longest run of writable addresses (24..35).
 * Tested against ct_longest_writable_run(). */
#define DXL_REG_SLOT_BYTES 12u

/* Longest status packet: a READ of the whole table. */
#define DXL_REPLY_MAX_BYTES (6u + CT_SIZE)

/* What must happen after the reply has left, in this order. */
#define DXL_AFTER_FACTORY_RESET 0x01u /* call dxl_servo_factory_reset() */
#define DXL_AFTER_APPLY_BAUD 0x02u    /* reprogram the UART from the Baud Rate register */
#define DXL_AFTER_PERSIST 0x04u       /* the EEPROM area (0..23) changed: persist it */
#define DXL_AFTER_BOOTLOADER 0x08u    /* enter the bootloader (DXL_INST_BOOTLOADER) */

/* What a prepared packet will do when committed. */
typedef enum {
  DXL_ACTION_NONE = 0,
  DXL_ACTION_WRITE,         /* write the window */
  DXL_ACTION_REGISTER,      /* hold the window in the REG_WRITE slot */
  DXL_ACTION_RUN_REGISTERED,
  DXL_ACTION_RESET,         /* factory reset, after the reply */
} dxl_action_t;

/* The bytes come last: the other fields lie within the AVR's 0..63 load/store displacement. */
typedef struct {
  /* The status packet, bytes[0..length); length 0 = stay silent. */
  uint8_t length;
  uint16_t delay_us; /* after the stop bit of the packet's last byte: 2 us x Return Delay Time */
  uint8_t after;     /* DXL_AFTER_* */
  /* The prepared side effect. */
  uint8_t action; /* dxl_action_t */
  /* The control-table window the packet reads (READ) or writes (data: the bytes to write,
   * pointing into the packet or the REG_WRITE slot). */
  uint8_t window_start;
  uint8_t window_len;
  const uint8_t *window_data;
  uint8_t events;            /* event error bits this packet raised (range, checksum, instruction) */
  uint8_t bytes[DXL_REPLY_MAX_BYTES];
} dxl_response_t;

typedef struct {
  uint8_t table[CT_SIZE];
  /* REG_WRITE slot; Registered Instruction (address 44) tells whether it holds a write. */
  uint8_t reg_start;
  uint8_t reg_len;
  uint8_t reg_data[DXL_REG_SLOT_BYTES];
  /* In wheel mode any Goal Position written is outside the limits: remembered here. */
  bool goal_written_in_wheel_mode;
  /* Conditions the control and alarm layer maintains: DXL_ERR_VOLTAGE, _OVERHEATING,
   * _OVERLOAD. (The Angle Limit condition is derived from the table.) */
  uint8_t held_conditions;
  /* Event bits raised since the alarm layer last took them (dxl_servo_take_events). */
  uint8_t pending_events;
} dxl_servo_t;

/* Power-up (docs/policy.md "Power-up"): the EEPROM area from eeprom_area (CT_EEPROM_SIZE bytes,
 * whose check the caller has verified; items out of range are repaired, ct_repair_stored_eeprom)
 * or factory defaults when it is NULL; the RAM area at its power-up values with Goal Position
 * = present_position. */
void dxl_servo_power_up(dxl_servo_t *servo, const uint8_t *eeprom_area, uint16_t present_position);

/* RESET: factory defaults for the whole table; the RAM area as at power-up with the present
 * position kept. Lock is not cleared by RESET (it refuses to run while locked). */
void dxl_servo_factory_reset(dxl_servo_t *servo);

/* Whether a packet with this ID and instruction, if its checksum is good, is answered (the
 * reply dxl_servo_prepare() would build has length != 0). It depends only on the ID, the
 * instruction, Status Return Level and the profile (not on the parameters), so the firmware
 * can decide it as soon as the instruction byte is in. Tested to agree with
 * dxl_servo_prepare() over every instruction code, parameter count, addressing and level. */
bool dxl_servo_answers(const dxl_servo_t *servo, uint8_t id, uint8_t instruction);

/* Streamed replies: which unicast packets to this servo the firmware may start answering from
 * the RX interrupt, before the main loop has seen them (docs/firmware.md "The sniff"). Bit i
 * of the mask is set when instruction i is one of PING, READ, WRITE, REG_WRITE, ACTION and is
 * answered (dxl_servo_answers) at the current Status Return Level; ACTION only while the
 * registered write, if any, leaves the Baud Rate alone. A packet streams when
 *   its ID is this servo's, its instruction's bit is set, and, for a WRITE with at least
 *   one parameter, that first parameter (the start address) is >= DXL_STREAM_WRITE_MIN_ADDR
 *   (a write from the ID or the Baud Rate on is answered by the main loop: a new baud
 *   applies after the reply).
 * Contract, tested over every LENGTH and parameter: such a packet's dxl_servo_prepare()
 * reply is non-empty, its after holds neither DXL_AFTER_FACTORY_RESET nor
 * DXL_AFTER_APPLY_BAUD (a store of the EEPROM area starts at the commit, whenever that comes)
 * and it starts FF FF ID, so its first three bytes can leave before it is prepared. */
#define DXL_STREAM_WRITE_MIN_ADDR (CT_ADDR_BAUD_RATE + 1u)
#define DXL_STREAM_HEADER_BYTES 3u
uint8_t dxl_servo_stream_mask(const dxl_servo_t *servo);

/* The status packet that answers a PING now (when it is answered at all: dxl_servo_answers):
 * bytes[0..DXL_PING_REPLY_BYTES), length and delay_us, byte for byte what
 * dxl_servo_prepare() builds for it; nothing else of *reply changes. Small, so the firmware
 * keeps one ready, and the RX interrupt can arm it before the main loop has seen the PING. */
#define DXL_PING_REPLY_BYTES 6u
void dxl_servo_ping_reply(const dxl_servo_t *servo, dxl_response_t *reply);

void dxl_servo_prepare(const dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response);
void dxl_servo_commit(dxl_servo_t *servo, const dxl_response_t *response);
void dxl_servo_handle(dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response);

/* A framed packet whose checksum was wrong: Checksum Error reply (Status Return Level 2) when
 * it was addressed to this servo, silence otherwise. Nothing else changes. */
void dxl_servo_reject_checksum(dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response);

/* Error bits that hold now: the held conditions plus Angle Limit. */
uint8_t dxl_servo_conditions(const dxl_servo_t *servo);

/* Returns and clears the event bits raised since the last call. */
uint8_t dxl_servo_take_events(dxl_servo_t *servo);

#endif
