/* Open AX-12 firmware: the main loop that ties the protocol core (firmware/core) to the
 * board (firmware/hal). SPDX-License-Identifier: MIT (the firmware; the simavr host that
 * runs it is GPL-3.0-or-later, see docs/firmware.md).
 *
 * Execution contexts (docs/firmware.md): the ISRs in hal/ move bytes and start replies;
 * everything else runs here, in one loop that never blocks:
 *   0. the watchdog, fed only when the tick and the receive path made progress (feed_watchdog);
 *   1. reply bookkeeping: after a reply's last byte, apply what follows it (factory reset,
 *      new baud);
 *   2. receive: the packet whose reply the RX ISR's sniff armed (prepare and publish it
 *      before its checksum, commit after), or ring bytes through the packet finder;
 *   3. control tick (1 kHz): the sniff's and the skip's timeouts, finder gap timeout, ADC into
 *      the sensors, control_tick() (which writes the Present items from them), LED, ready
 *      PING reply;
 *   4. EEPROM: one byte of a pending settings write when the EEPROM is ready (nvm.h);
 *   5. idle sleep unless an ISR set the wake flag during the pass.
 *
 * Replies (docs/firmware.md "Reply timing"): the sniff in the RX ISR frames a packet to this
 * servo and arms its reply at the last byte before the checksum, so the reply starts on time
 * whatever the main loop is doing; dxl_servo_prepare() is pure, so the rest is prepared while
 * the checksum is still on the wire. A write of the EEPROM area is answered like any other
 * write and stored in the background after its commit (dxl_after.h); only a write from the ID
 * or the Baud Rate on is left to the main loop, which applies a new baud after the reply.
 */
#include <avr/interrupt.h>
#include <util/atomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "adc.h"
#include "board.h"
#include "control.h"
#include "dxl_after.h"
#include "dxl_after_port.h"
#include "dxl_packet.h"
#include "dxl_protocol.h"
#include "dxl_servo.h"
#include "dxl_table.h"
#include "motor.h"
#include "nvm.h"
#include "timebase.h"
#include "uart.h"
#if DXL_HAS_BOOTLOADER
#include "boot_request.h"
#endif

/* Power-up blink (docs/policy.md "Power-up"): on-off twice, BOOT_BLINK_MS each phase. */
#define BOOT_BLINK_MS 100u
#define BOOT_BLINK_PHASES 4u

/* ADC conversions, one per control tick: the pot every other tick. */
static const DXL_FLASH uint8_t adc_sequence[] = {ADC_CH_POT, ADC_CH_SUPPLY, ADC_CH_POT, ADC_CH_TEMP};
#define ADC_SEQUENCE_LENGTH (sizeof adc_sequence / sizeof adc_sequence[0])

static dxl_finder_t finder;
/* The servo's state, its control table first (servo.table[CT_SIZE]); external so that it
 * keeps its name through LTO: a debugger reads it as `servo` (docs/debugging.md). */
dxl_servo_t servo;
/* The reply being prepared, armed or sent; while the link is idle it holds the ready reply
 * to a PING (refresh_ping_reply), whose first bytes FF FF ID also start a streamed reply. */
static dxl_response_t response;

/* Link state of the main loop; uart_reply_state() is the UART's. */
static bool armed;               /* the sniff armed the reply of the packet that ends just
                                    before uart_sniff_end in the ring; the UART may already
                                    have started it */
static bool finder_dirty;        /* bytes pushed or a result taken since dxl_finder_next() last
                                    said DXL_FIND_NONE */
static uint8_t after_reply;      /* DXL_AFTER_* to apply once the reply has left */

static uint8_t adc_slot;
static dxl_sensors_t sensors; /* the latest reading of each ADC channel, in the control's units */
/* Sniff: one that has matched some bytes ends when no byte came for SNIFF_MAX_MS (a byte at
 * 9600 baud takes about 1 ms). The bytes it held then reach the finder stamped up to
 * SNIFF_MAX_MS + 1 late, which is what the finder's 100 ms gap rule can be off by. */
#define SNIFF_MAX_MS 3u
static uint8_t sniff_age_ms;
static uint8_t sniff_seen_head; /* uart_rx_head at the last tick */
/* Another servo's packet the RX ISR skips (uart_skip_count), and a header the sniff frames
 * without storing it (uart_sniff 1..UART_SNIFF_LENGTH, uart_rx.S), end like any partial
 * packet when no byte came for more than DXL_PACKET_GAP_TIMEOUT_MS (docs/policy.md "Framing
 * and bus"): the skip stops, the header is dropped, as the finder drops what came before a gap.
 * Progress is the skip count or the header state changing between ticks (bytes that bring it
 * back to the same value within 1 ms every time for 100 ms could end either early: the rest
 * then reaches the sniff or the finder, which frame nothing of it). */
static uint8_t quiet_seen;
static uint8_t quiet_age_ms;
/* Control ticks run since power-up (wrapping): a host reads it by symbol to count missed ticks. */
volatile uint16_t control_tick_count;
/* What the last watchdog feed saw (feed_watchdog). */
static uint16_t fed_tick_count;
static uint8_t fed_rx_tail;

/* Test builds only (AX12_INJECT_HANG in firmware/CMakeLists.txt; docs/firmware.md "Watchdog"):
 * from HANG_AFTER_TICKS control ticks after power-up on, the main loop, the control tick or
 * the receive path stops. Never defined in a product build. */
#define HANG_AFTER_TICKS 1500u
#if defined(AX12_INJECT_HANG_MAIN) || defined(AX12_INJECT_HANG_TICK) || defined(AX12_INJECT_HANG_RX)
static bool hang_due(void) { return control_tick_count >= HANG_AFTER_TICKS; }
#endif
static uint8_t boot_blink_ms; /* into the current phase */
static uint8_t boot_blink_phase;

/* The board side of the after-reply policy (dxl_after_port.h); one servo, no port handle. */
void dxl_after_port_persist(void *port, const uint8_t *table) {
  (void)port;
  nvm_persist(table);
}

void dxl_after_port_set_baud(void *port, uint8_t baud_register) {
  (void)port;
  uart_set_baud(baud_register);
}

#if DXL_HAS_BOOTLOADER
/* The settings' store finishes first (a few bytes of 3.4 ms each), so the bootloader finds
 * them whole; the motor coasts. */
void dxl_after_port_enter_bootloader(void *port) {
  (void)port;
  while (nvm_busy()) {
    board_watchdog_kick();
    nvm_service();
  }
  motor_set_drive(0);
  boot_request_enter();
}
#endif

/* Starts the prepared (or rejected) packet's reply, its bytes final once prepared; what must
 * follow its end (dxl_after.h) is kept for service_reply(). */
static void start_reply(void) {
  after_reply = response.after;
  uart_reply_load(response.bytes, response.length, response.delay_us);
  uart_reply_start();
}

/* Whether the armed packet's reply is the streamed one the main loop prepares and commits
 * (else a PING answered with the ready reply, which needs nothing). */
static bool reply_is_streamed(const dxl_packet_t *packet) {
  return packet->instruction != DXL_INST_PING || packet->param_count != 0;
}

static void on_packet(const dxl_packet_t *packet) {
  dxl_servo_prepare(&servo, packet, &response);
  if (response.length != 0) {
    start_reply();
  }
  dxl_servo_commit(&servo, &response);
  dxl_after_commit(&servo, response.after, NULL);
  if (response.length == 0) {
    dxl_after_reply(&servo, response.after, NULL); /* no reply to wait for */
  }
}

static void on_bad_checksum(const dxl_packet_t *packet) {
  dxl_servo_reject_checksum(&servo, packet, &response);
  if (response.length != 0) {
    start_reply();
  }
}

/* The PING reply is rebuilt whenever the link is idle and nothing is armed (so no ISR reads
 * it): after every packet handled, every reply sent and every control tick, so it always
 * shows the table and conditions of the moment. */
static bool link_free(void);
/* Starts the RX ISR's sniff when nothing is held or under way: the finder holds no byte, the
 * ring is empty, the link idle and nothing armed, so the next byte is where the finder would
 * start its candidate (the sniffer never answers a packet the finder would not see), and every
 * earlier packet is committed (the sniff decides with the table of the moment). */
static __attribute__((noinline)) void sniff_start(void) {
  /* Callers: nothing armed. */
  if (uart_sniff == UART_SNIFF_OFF && link_free() && dxl_finder_idle(&finder)) { /* usually on */
    /* The delay from the table: after a packet that got no reply (another servo's, a broadcast
     * PING of profile ax12a) `response` holds the PING reply's bytes beside a header that
     * dxl_servo_prepare() cleared, delay 0 included. */
    uart_reply_load(response.bytes, DXL_PING_REPLY_BYTES,
                    (uint16_t)(DXL_RETURN_DELAY_UNIT_US * servo.table[CT_ADDR_RETURN_DELAY_TIME]));
    uart_sniff_start(servo.table[CT_ADDR_ID], dxl_servo_stream_mask(&servo));
  }
}

/* A sniff that has matched bytes is left alone: its PING is under way with this reply. One
 * still at byte 0 keeps running (stopping it would miss a PING that starts meanwhile): the
 * ISR reads the reply at the PING's checksum, at least 5 byte times later, long after the
 * rebuild and the reload (uart_reply_load) are done. */
static __attribute__((noinline)) void refresh_ping_reply(void) {
  const uint8_t sniff = uart_sniff;
  if (!armed && link_free() && (sniff == 0 || sniff == UART_SNIFF_OFF)) {
    /* A sniff at byte 0 needs 5 more byte times (800 cycles at 1 Mbps) before it could
     * start this reply: far more than this rebuild and load take, so no interrupt waits. */
    dxl_servo_ping_reply(&servo, &response);
    uart_reply_load(response.bytes, DXL_PING_REPLY_BYTES, response.delay_us);
    sniff_start();
  }
}

/* After a packet handled: the ready PING reply is rebuilt when the packet changed something
 * (a reply that used the buffer rebuilds it when it has left); another servo's packet, the
 * usual case on a busy bus, changes nothing. */
static void refresh_after(void) {
  if (response.action != DXL_ACTION_NONE) {
    refresh_ping_reply();
  }
}

/* The RX ISR armed a reply at a packet's last byte but one: the main loop takes it over (the
 * checksum is the byte before uart_sniff_end). */
static void adopt_sniffed(void) {
  if (!armed && uart_sniff == UART_SNIFF_ARMED) {
    uart_sniff = UART_SNIFF_OFF;
    armed = true;
  }
}

/* Bytes of the armed packet still in the ring or on the wire, its checksum included. */
static uint8_t armed_bytes_left(void) { return (uint8_t)(uart_sniff_end - uart_rx_tail); }

static bool link_free(void) { return uart_reply_state() == UART_REPLY_IDLE; }

/* Moves up to max_bytes waiting in the ring into the finder (as far as it has room), stamped
 * with the current millisecond, in one batch (a few cycles a byte); the finder examines them
 * in one dxl_finder_next() pass. Returns how many moved. */
static uint8_t push_waiting_bytes(uint8_t max_bytes) {
  const uint16_t now_ms = timebase_ms();
  uint16_t room;
  uint8_t *slot = dxl_finder_push_slot(&finder, &room, now_ms);
  uint8_t tail = uart_rx_tail;
  uint8_t count = (uint8_t)(uart_rx_head - tail);
  if (!armed && uart_sniff != UART_SNIFF_OFF) {
    /* Read after the head: the sniff holds the ring (it may drop a packet from it), or armed
     * at a byte already counted, whose packet goes through the armed path (adopt_sniffed). */
    return 0;
  }
  if (count > max_bytes) {
    count = max_bytes;
  }
  if (count > room) {
    count = (uint8_t)room;
  }
  for (uint8_t n = count; n != 0; n--) {
    *slot++ = uart_rx_ring[tail++ & UART_RX_RING_MASK];
  }
  uart_rx_tail = tail;
  dxl_finder_pushed(&finder, count, now_ms);
  return count;
}

static void service_rx(void) {
#ifdef AX12_INJECT_HANG_RX
  if (hang_due()) {
    return; /* the receive path takes no byte any more */
  }
#endif
  dxl_packet_t packet;
  for (;;) {
    adopt_sniffed();
    if (armed) {
      /* The sniff armed the reply of the packet in the ring (the main loop has not taken any
       * of its bytes): everything but the checksum goes to the finder first, and the reply is
       * prepared then, while the checksum is still on the wire. A PING answers with the ready
       * reply; anything else streamed its header and waits for the rest, published here
       * (dxl_servo.h "Streamed replies": the prepared reply of such a packet is non-empty
       * with nothing after it). */
      const uint8_t left = armed_bytes_left();
      if (left > 1) {
        if (push_waiting_bytes((uint8_t)(left - 1u)) == 0) {
          return;
        }
        (void)dxl_finder_next(&finder, &packet); /* the same candidate as the sniff: NONE */
        if (armed_bytes_left() == 1) {
          dxl_finder_candidate(&finder, &packet);
          if (reply_is_streamed(&packet)) {
            dxl_servo_prepare(&servo, &packet, &response);
            uart_reply_publish(response.length);
          }
        }
        continue;
      }
      if (push_waiting_bytes(1) == 0) {
        return; /* the checksum byte is still on the wire */
      }
      finder_dirty = true;
      armed = false;
      if (uart_reply_state() != UART_REPLY_IDLE) {
        /* The checksum matched and the reply is under way: the finder completes the same
         * packet (DXL_FIND_PACKET); commit what was prepared. */
        (void)dxl_finder_next(&finder, &packet);
        if (reply_is_streamed(&packet)) {
          dxl_servo_commit(&servo, &response);
          dxl_after_commit(&servo, response.after, NULL); /* a store at most (dxl_servo.h) */
        }
        after_reply = 0;
        finder_dirty = false;
        /* The reply may be DONE already (a control tick ran meanwhile), which service_reply()
         * left alone while this was armed: another pass takes it at once, not at the next
         * wake (the sniff would stay off until then). */
        board_wake_set();
      } else {
        refresh_ping_reply(); /* nothing was sent; a prepared reply may have taken the buffer */
      }
      continue; /* a mismatch is handled below like any byte */
    }
    if (!link_free()) {
      return; /* one reply at a time: the rest waits in the ring */
    }
    if (finder_dirty) {
      const dxl_find_result_t found = dxl_finder_next(&finder, &packet);
      if (found == DXL_FIND_NONE) {
        finder_dirty = false;
        return; /* back to the main loop (watchdog, tick) between batches */
      }
      if (found == DXL_FIND_PACKET) {
        on_packet(&packet);
        refresh_after();
        continue;
      }
      on_bad_checksum(&packet);
      refresh_after();
      /* One rejected candidate a pass (its rescan can take thousands of cycles): a flood of
       * garbage cannot starve the control tick. The wake flag brings the next pass at once. */
      board_wake_set();
      return;
    } else if (uart_rx_available() && push_waiting_bytes(UINT8_MAX) != 0) {
      finder_dirty = true;
    } else if (uart_sniff == UART_SNIFF_ARMED) {
      continue; /* adopt it */
    } else {
      sniff_start();
      return;
    }
  }
}

static void service_reply(void) {
  adopt_sniffed(); /* before DONE is taken for a reply of its own */
  if (!armed && uart_reply_state() == UART_REPLY_DONE) {
    uart_reply_finish();
    const uint8_t after = after_reply;
    after_reply = 0;
    dxl_after_reply(&servo, after, NULL);
    refresh_ping_reply();
  }
}

/* A finished conversion into the sensors the control tick reads (it writes the Present*
 * items from them). */
static void take_adc(uint8_t channel, uint16_t reading) {
  switch (channel) {
  case ADC_CH_POT:
    sensors.position_counts = reading;
    break;
  case ADC_CH_SUPPLY:
    sensors.voltage_dv = adc_supply_decivolts(reading);
    break;
  default:
    sensors.temperature_c = adc_temperature_c(reading);
    break;
  }
}

static void update_led(void) {
  if (boot_blink_phase < BOOT_BLINK_PHASES) {
    board_led_set((boot_blink_phase & 1u) == 0);
    if (++boot_blink_ms == BOOT_BLINK_MS) {
      boot_blink_ms = 0;
      boot_blink_phase++;
    }
    return;
  }
  board_led_set(control_led_on()); /* register 25, or the alarm blink (dxl_control.h) */
}

static void service_tick(void) {
  if (timebase_poll() == 0) {
    return;
  }
  const uint16_t now_ms = timebase_ms();
  /* A packet the RX ISR holds (a sniff part-way, or an armed reply whose checksum does not
   * come) is given up after SNIFF_MAX_MS without a byte, long before the finder's gap
   * timeout could split it: its bytes go to the finder, which applies the gap rule. */
  const uint8_t head = uart_rx_head;
  const uint8_t sniff = uart_sniff;
  if ((armed || (sniff > UART_SNIFF_LENGTH && sniff < UART_SNIFF_ARMED)) && head == sniff_seen_head) {
    if (++sniff_age_ms >= SNIFF_MAX_MS) {
      uart_sniff_stop_part_way();
      if (armed && uart_reply_disarm()) {
        armed = false;
        refresh_ping_reply(); /* a streamed reply may have been prepared into its buffer */
      }
    }
  } else {
    sniff_age_ms = 0;
    sniff_seen_head = head;
  }
  const uint8_t skip = uart_skip_count;
  const uint8_t quiet = skip != 0 ? skip : (sniff <= UART_SNIFF_LENGTH ? sniff : 0u);
  if (quiet != 0 && quiet == quiet_seen) {
    if (++quiet_age_ms > DXL_PACKET_GAP_TIMEOUT_MS) {
      /* A byte just now would have come after the gap: not the packet's. */
      uart_skip_count = 0;
      ATOMIC_BLOCK(ATOMIC_FORCEON) {
        if (uart_sniff == sniff) {
          uart_sniff = 0; /* (a skip: it is 0 already) */
        }
      }
    }
  } else {
    quiet_seen = quiet;
    quiet_age_ms = 0;
  }
  if (!armed && dxl_finder_poll(&finder, now_ms)) {
    finder_dirty = true; /* rescan what came before the gap */
  }
  if (!adc_busy()) {
    take_adc(adc_sequence[adc_slot], adc_result());
    adc_slot = (uint8_t)((adc_slot + 1u) % ADC_SEQUENCE_LENGTH);
    adc_start(adc_sequence[adc_slot]);
  }
#ifdef AX12_INJECT_HANG_TICK
  if (hang_due()) {
    return; /* the control tick does not run any more */
  }
#endif
  const uint8_t conditions = control_tick(&servo, &sensors);
  __asm__ __volatile__("" ::: "memory"); /* the RX ISR may have armed meanwhile */
  control_tick_count++;
  update_led();
  /* The ready PING reply follows the conditions (anything else that changes it comes with a
   * packet or a reply, which rebuild it): rebuilt only when its error byte would change. */
  if (conditions != response.bytes[DXL_STATUS_ERROR_OFFSET]) {
    refresh_ping_reply();
  }
}

/* The watchdog (docs/firmware.md "Watchdog"), fed here in the main loop only when, since the
 * last feed, a control tick has run and the receive path has taken bytes from the ring or has
 * none waiting: a hang of the loop, of the tick or of the receive path starves it, and 250 ms
 * later the MCU resets. (Bytes wait legitimately while the sniff holds a packet or a reply is
 * on the wire: at the slowest baud at most about 130 ms.) */
static void feed_watchdog(void) {
  const uint16_t ticks = control_tick_count;
  const uint8_t tail = uart_rx_tail;
  if (ticks != fed_tick_count && (tail != fed_rx_tail || tail == uart_rx_head)) {
    fed_tick_count = ticks;
    fed_rx_tail = tail;
    board_watchdog_kick();
  }
}

/* Work that no ISR flags: an EEPROM byte to write. If it becomes possible after this test,
 * EE_READY is already pending and ends the sleep at once. */
static bool work_without_interrupt(void) { return nvm_work_ready(); }

static void power_up(void) {
  board_init();
  motor_init();
  timebase_init();
  adc_init();
  /* Present values first: Goal Position = Present Position (docs/policy.md "Power-up"). */
  for (uint8_t slot = 1; slot < ADC_SEQUENCE_LENGTH; slot++) { /* every channel once */
    const uint8_t channel = adc_sequence[slot];
    take_adc(channel, adc_read_blocking(channel));
  }
  const uint8_t *const stored = nvm_load();
  dxl_servo_power_up(&servo, stored, sensors.position_counts); /* the first control tick writes
                                                                 the other Present items */
  if (stored == NULL) {
    nvm_persist(servo.table); /* no valid slot: factory defaults, written back */
  }
  adc_start(adc_sequence[0]);
  dxl_finder_init(&finder);
  refresh_ping_reply();
  uart_init(servo.table[CT_ADDR_BAUD_RATE]);
}

int main(void) {
  power_up();
  sei();
  for (;;) {
    board_wake_clear();
    feed_watchdog();
#ifdef AX12_INJECT_HANG_MAIN
    while (hang_due()) {
      /* the main loop is stuck */
    }
#endif
    service_reply();
    service_rx();
    service_tick();
    nvm_service();
    /* Work an ISR leaves (a received byte, a tick, a reply sent) sets the wake flag; a pass
     * that stops early with bytes waiting (a reply under way) is woken by the reply's
     * TX-complete. */
    if (!work_without_interrupt()) {
      board_sleep_unless_woken();
    }
  }
}
