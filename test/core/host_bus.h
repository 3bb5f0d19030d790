/* A Dynamixel bus on the host: N servos of the protocol core and a master, wired together.
 *
 * Each servo is a dxl_servo_t behind the firmware's link layer (firmware/link/dxl_link.h) on a
 * fake UART (test/support/fake_uart.h: its baud is the Baud Rate register value it runs at),
 * with an EEPROM image (dxl_image_build) that survives power cycles.
 *
 * Model (what the host harness decides; the simavr level has the real timing):
 * - Time is a microsecond clock. A byte takes 10 bit times at its sender's baud
 *   (2 000 000 / (register + 1) bps); the receivers measure the gap on it in whole ms.
 * - A byte reaches a receiver only when sender and receiver bauds are within 3 %
 *   (docs/policy.md "Framing and bus"); otherwise it is lost (the garbling is not modelled).
 * - The bus is serialised: when a byte completes a packet, every answering servo's reply is
 *   transmitted in full, in order of its start time (2 us x Return Delay Time after the byte),
 *   before the master's next byte. Replies whose time windows overlap are still delivered
 *   one after the other, and `collision` is set. A reply reaches the master and every other
 *   servo (which frame and ignore it); a servo does not hear its own echo.
 * - Each servo's link is the firmware's, on a receiver that frames as the firmware's RX
 *   interrupt does and arms nothing (every packet is answered from the link, as the firmware's
 *   main loop answers what its RX interrupt does not arm): one reply at a time, bytes that come meanwhile wait in its ring; what follows a packet is
 *   the firmware's own policy (firmware/link/dxl_after.h): a write of the EEPROM area rebuilds
 *   the servo's EEPROM image when it is committed (at once here: the firmware's store takes
 *   milliseconds in the background); after the reply has left (or at once when the servo
 *   stays silent) RESET's factory defaults are stored and a new Baud Rate applies to the
 *   servo's UART. The link's tick runs every POLL_STEP_MS of a wait.
 * - Present Position at power-up is HOST_BUS_PRESENT_POSITION (512, mid travel): there is no
 *   plant here. The control layer is not in the core either, so the harness writes Present
 *   Temperature (the `temperature` directive) after every power-up and factory reset, and
 *   leaves the other Present* registers at 0.
 * - When AX12_CONFORMANCE_LOG is set, init, sends, power cycles and master baud changes are
 *   recorded for docs/conformance.md (conformance_log.h); otherwise the hooks do nothing.
 */
#ifndef HOST_BUS_H
#define HOST_BUS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "dxl_image.h"
#include "dxl_link.h"
#include "dxl_packet.h"
#include "dxl_servo.h"
#include "fake_uart.h"

#define HOST_BUS_MAX_SERVOS 32u
#define HOST_BUS_PRESENT_POSITION 512u
#define HOST_BUS_HEARD_MAX 4096u

typedef struct host_bus host_bus_t;

/* Called for every packet a servo's link framed, after the servo handled it.
 * first_rx_index: index (in the bytes this servo has received since power-up,
 * uart.received_count) of the packet's first byte, the FF FF right before its ID; bytes/length:
 * the packet as framed (FF FF ID LENGTH ... CHECKSUM). */
typedef struct {
  size_t servo_index;
  dxl_find_result_t kind; /* DXL_FIND_PACKET or DXL_FIND_BAD_CHECKSUM */
  uint64_t first_rx_index;
  const uint8_t *bytes;
  size_t length;
  const dxl_response_t *response;
} host_bus_event_t;

typedef void (*host_bus_observer_t)(void *context, const host_bus_t *bus, const host_bus_event_t *event);

typedef struct {
  dxl_servo_t servo;
  dxl_link_t link;
  fake_uart_t uart;    /* baud_register: the Baud Rate register value the UART runs at */
  uint8_t eeprom_image[DXL_IMAGE_BYTES];
  unsigned packets;    /* DXL_FIND_PACKET results handled */
  unsigned bad_checksums;
  host_bus_t *bus;
  size_t index;
} host_bus_servo_t;

struct host_bus {
  host_bus_servo_t servos[HOST_BUS_MAX_SERVOS];
  size_t servo_count;
  uint8_t master_baud;
  uint8_t temperature_c;
  uint64_t now_us;
  uint8_t heard[HOST_BUS_HEARD_MAX]; /* bytes the master received since the last send */
  size_t heard_len;
  bool collision;                    /* two replies overlapped since the last send */
  host_bus_observer_t observer;
  void *observer_context;
};

/* Servos fresh from the factory with the given IDs and Baud Rate register, powered up;
 * the master at the same baud. */
void host_bus_init(host_bus_t *bus, const uint8_t *ids, size_t count, uint8_t baud, uint8_t temperature_c);

/* dst becomes a copy of src that runs on its own (a plain struct copy would share src's
 * servos: each servo's link and UART point at each other). */
void host_bus_copy(host_bus_t *dst, const host_bus_t *src);

/* The master sends bytes (clears heard[] and collision first). */
void host_bus_send(host_bus_t *bus, const uint8_t *bytes, size_t length);

/* The same without clearing what was heard before (for streams sent in pieces). */
void host_bus_send_more(host_bus_t *bus, const uint8_t *bytes, size_t length);

/* The bus stays idle for ms milliseconds (the receivers see the gap). */
void host_bus_wait_ms(host_bus_t *bus, uint32_t ms);

void host_bus_set_master_baud(host_bus_t *bus, uint8_t baud_register);

/* Every servo restarts from its EEPROM image (factory defaults when the image is invalid). */
void host_bus_power_cycle(host_bus_t *bus);

/* The servo with this ID in its table, or NULL. */
host_bus_servo_t *host_bus_find(host_bus_t *bus, uint8_t id);

/* True when two Baud Rate register values give bauds within 3 % of each other. */
bool host_bus_bauds_match(uint8_t a, uint8_t b);

#endif
