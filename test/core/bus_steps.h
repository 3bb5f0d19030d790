/* Protocol steps for the core tests, named after what the master does and sees:
 * build packets (model/bus/packet_encode.h, independent of the core), send them on a host bus,
 * and expect a status packet or silence. The expect_* steps are cmocka assertions.
 *
 *   given_bus(&bus, 1);                               one factory-fresh servo, ID 1
 *   when_master_sends(&bus, 1, DXL_INST_READ, P(25, 1));
 *   then_status_is(&bus, 1, 0, P(0));                 FF FF 01 03 00 00 FB
 *   when_master_sends(&bus, 1, DXL_INST_PING, NO_PARAMS);
 */
#ifndef BUS_STEPS_H
#define BUS_STEPS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "conversation.h"
#include "host_bus.h"
#include "packet_encode.h"

/* A parameter list: P(a, b, ...) or NO_PARAMS, expanding to (pointer, count). */
#define P(...) (const uint8_t[]){__VA_ARGS__}, sizeof((const uint8_t[]){__VA_ARGS__})
#define NO_PARAMS NULL, 0u

#define STEPS_PACKET_MAX 300u
#define GAP_THAT_DISCARDS_MS (DXL_PACKET_GAP_TIMEOUT_MS + 1u)

/* Packets are built with model/bus/packet_encode.h (packet_encode, packet_checksum,
 * packet_hex): the manual's encoding, independent of the core. */

/* A bus of factory-fresh servos at 1 Mbps, 25 degrees C. */
void given_bus(host_bus_t *bus, uint8_t id);
void given_bus_of(host_bus_t *bus, const uint8_t *ids, size_t count);

void when_master_sends(host_bus_t *bus, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count);
void when_master_sends_bytes(host_bus_t *bus, const uint8_t *bytes, size_t count);

/* The status packet the master heard since its last send must be exactly this one. */
void then_status_is(const host_bus_t *bus, uint8_t id, uint8_t error, const uint8_t *params, size_t count);
void then_heard_bytes(const host_bus_t *bus, const uint8_t *bytes, size_t count);
void then_silence(const host_bus_t *bus);

/* Sends and swallows whatever comes back (setup steps). */
void given_write(host_bus_t *bus, uint8_t id, uint8_t addr, const uint8_t *data, size_t count);

/* Direct looks at a servo's table (by its current ID). */
dxl_servo_t *servo_of(host_bus_t *bus, uint8_t id);
uint8_t table_byte(host_bus_t *bus, uint8_t id, uint8_t addr);
uint16_t table_word(host_bus_t *bus, uint8_t id, uint8_t addr);

/* Conversation replay on a host bus. conv_bus_init sets the bus up as the file says;
 * conv_replay_step runs one step and returns false with a message when what came back differs. */
void conv_bus_init(host_bus_t *bus, const conv_t *conv);
bool conv_replay_step(host_bus_t *bus, const conv_t *conv, const conv_step_t *step, char *msg, size_t msg_len);

/* The .conv files of a directory, sorted by name: paths[i] are malloc'd (path_chars each), the
 * caller frees them. Returns how many (at most max). */
size_t conv_list_files(const char *dir, char **paths, size_t max, size_t path_chars);

#endif
