/* The fuzz input format of fuzz_core.c, shared with the seed generator (make_seeds.c).
 *
 * An input is a start (how the EEPROM looks before the first power-up) and then a script of
 * operations, each an opcode byte (taken modulo FUZZ_OP_COUNT) and its arguments. A read past
 * the end of the input gives 0, so every byte string is a valid script.
 *
 * Start: FUZZ_START_* (byte modulo FUZZ_START_COUNT), then its arguments:
 *   BLANK        -                      erased EEPROM: factory defaults, stored at power-up
 *   ONE_SLOT     area                   slot 0 only (dxl_image_build)
 *   TWO_SLOTS    area area seq delta    slot 0 with seq, slot 1 with seq + delta
 *   TORN_SLOT    area area seq n value  slot 0 factory settings at seq - 1, slot 1 the first
 *                                       area at seq; a store of the second area into slot 0
 *                                       (nvm.c's writer) cut after n % 28 writes, the next
 *                                       write torn to value: the states a cut leaves (a slot
 *                                       torn any other way, with its sequence number already
 *                                       the next one, is not one: docs/testing.md)
 *   area = ID, Baud Rate, Return Delay Time, Status Return Level, CW Angle Limit (2 bytes),
 *          CCW Angle Limit (2), Max Torque (2), Alarm LED, Alarm Shutdown: raw, so stored
 *          values out of range occur (power-up repairs them)
 *   and then the present position at power-up (2 bytes, & 1023).
 *
 * Operations (arguments in order); "passes": main-loop passes of the link layer until it is
 * idle, each reply it starts sent:
 *   PUSH_BYTE    b                      one byte into the UART's receive ring, then passes
 *   PUSH_BATCH   n, n bytes             n bytes into the ring (one batch for the finder), then
 *                                       passes
 *   WAIT         ms                     time passes (ms = 0..255), one link tick, passes
 *   WAIT_LONG    ms16                   time passes (0..65535 ms), one link tick, passes
 *   TICKS        n, flags, pos16, step, volts, temp
 *                                       n (x8 if flags & 1) ticks of 1 ms each as the
 *                                       firmware's service_tick (the link's tick, the control
 *                                       tick, the conditions to the link), passes after each;
 *                                       the pot moves by (int8)step counts a tick, clamped to
 *                                       0..1023
 *   PACKET       sel, mode, ...         a packet built from the input (see below), delivered
 *                                       by bytes, in one batch, split by a wait, or through the
 *                                       RX interrupt's arming and the link's armed path
 *   EEPROM       n                      n + 1 writes of the EEPROM writer (nvm_service)
 *   EEPROM_FLUSH -                      the store runs to its end
 *   CUT          how, garbage, pos16    power cut: how & 1: in the middle of a byte's write
 *                                       (left at garbage), else between writes; then power-up
 *   PASS         -                      passes with no new byte (the link's armed path pushes
 *                                       empty batches while a checksum is late: PACKET mode
 *                                       bit 6)
 *
 * PACKET: sel = id (bits 0-1: this servo's, broadcast, another given by the next byte, this
 * servo's + 1) and instruction (bits 2-4: PING, READ, WRITE, REG_WRITE, ACTION, RESET,
 * SYNC_WRITE, any given by the next byte); bit 5: raw parameters (count, then the bytes) else
 * the instruction's own shape:
 *   READ        address, length
 *   WRITE/REG   address (mod 50), L (mod 12, + 1), L bytes
 *   SYNC_WRITE  address (mod 50), L (mod 8, + 1), N (mod 5), N x (ID selector: bit 0 this
 *               servo's else another given by the next byte, then L bytes)
 *   others      none
 * mode: bits 0-1 delivery (0 bytes, 1 one batch, 2 two batches with a wait of the next byte
 * in ms and one link tick between, at the split given by the byte after it, the second taken
 * by passes before that tick, 3 armed: a packet the RX interrupt would arm, while the link
 * listens, goes through the armed path, any other in one batch); bit 2 bad checksum (xor with
 * the next byte | 1); bits 3-4 extra leading 0xFF bytes; bit 5 replies take time: the next
 * byte is how many ms pass between a reply's start and its end (ticks and EEPROM writes run,
 * what follows the reply waits); bit 6, with delivery 3: the checksum comes the next byte in
 * ms late, with the link's tick and passes every ms (after more than the 100 ms gap the receiver
 * drops the packet and the armed reply). A PACKET's bytes in order: sel, mode, the ID (id GIVEN), the instruction (GIVEN), the
 * parameters, the checksum xor (bit 2), the reply time (bit 5), the split's wait and place
 * (delivery 2), the checksum's delay (bit 6, delivery 3). */
#ifndef FUZZ_OPS_H
#define FUZZ_OPS_H

enum fuzz_start {
  FUZZ_START_BLANK,
  FUZZ_START_ONE_SLOT,
  FUZZ_START_TWO_SLOTS,
  FUZZ_START_TORN_SLOT,
  FUZZ_START_COUNT
};

enum fuzz_op {
  FUZZ_OP_PUSH_BYTE,
  FUZZ_OP_PUSH_BATCH,
  FUZZ_OP_WAIT,
  FUZZ_OP_WAIT_LONG,
  FUZZ_OP_TICKS,
  FUZZ_OP_PACKET,
  FUZZ_OP_EEPROM,
  FUZZ_OP_EEPROM_FLUSH,
  FUZZ_OP_CUT,
  FUZZ_OP_PASS,
  FUZZ_OP_COUNT
};

/* PACKET selector */
#define FUZZ_ID_OWN 0u
#define FUZZ_ID_BROADCAST 1u
#define FUZZ_ID_GIVEN 2u
#define FUZZ_ID_NEIGHBOUR 3u
#define FUZZ_INST_PING 0u
#define FUZZ_INST_READ 1u
#define FUZZ_INST_WRITE 2u
#define FUZZ_INST_REG_WRITE 3u
#define FUZZ_INST_ACTION 4u
#define FUZZ_INST_RESET 5u
#define FUZZ_INST_SYNC_WRITE 6u
#define FUZZ_INST_GIVEN 7u
#define FUZZ_SEL(id, inst) ((id) | ((inst) << 2))
#define FUZZ_SEL_RAW_PARAMS 0x20u

/* PACKET mode */
#define FUZZ_DELIVER_BYTES 0u
#define FUZZ_DELIVER_BATCH 1u
#define FUZZ_DELIVER_SPLIT 2u
#define FUZZ_DELIVER_EARLY 3u
#define FUZZ_MODE_BAD_CHECKSUM 0x04u
#define FUZZ_MODE_EXTRA_FF(n) ((n) << 3)
#define FUZZ_MODE_REPLY_TIME 0x20u
#define FUZZ_MODE_LATE_CHECKSUM 0x40u

#define FUZZ_WRITE_L_MOD 12u
#define FUZZ_SYNC_L_MOD 8u
#define FUZZ_SYNC_N_MOD 5u
#define FUZZ_TICKS_MANY 8u

#endif
