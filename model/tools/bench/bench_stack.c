/* SPDX-License-Identifier: GPL-3.0-or-later */
#include <stdio.h>
#include <stdlib.h>

#include "elf_symbols.h"
#include "servo_stack.h"

#include "bench_commands.h"
#include "bench_rig.h"
#include "bench_workload.h"
#include "dxl_protocol.h"
#include "dxl_table.h"

/* The deepest stack after a workload of every instruction. */

#define STACK_PAINT_BYTE 0xC5u /* docs/firmware.md: unused RAM is painted at reset */

void bench_stack(void) {
  bench_rig_t r;
  bench_rig_open(&r, 30);
  uint8_t p[300];
  static const uint8_t read_all[] = {0, CT_SIZE}, write_led[] = {CT_ADDR_LED, 1}, reg[] = {CT_ADDR_GOAL_POSITION, 0, 2},
                       return_delay_0[] = {CT_ADDR_RETURN_DELAY_TIME, 0};
  bench_exchange(&r, p, packet_encode(p, 1, DXL_INST_PING, NULL, 0), 6);
  bench_exchange(&r, p, packet_encode(p, 1, DXL_INST_READ, read_all, 2), 56);
  bench_exchange(&r, p, packet_encode(p, 1, DXL_INST_WRITE, write_led, 2), 6);
  bench_exchange(&r, p, packet_encode(p, 1, DXL_INST_WRITE, return_delay_0, 2), 6);
  bench_exchange(&r, p, packet_encode(p, 1, DXL_INST_REG_WRITE, reg, 3), 6);
  bench_exchange(&r, p, packet_encode(p, 1, DXL_INST_ACTION, NULL, 0), 6);
  bench_exchange(&r, p, packet_encode(p, 1, 0x07, NULL, 0), 6);                  /* unknown instruction */
  bench_exchange(&r, p, bench_sync_write_goals(p, 30, 0, true), 0);  /* the finder's (LENGTH 154) */
  bench_exchange(&r, p, bench_sync_write_goals(p, 30, 1, false), 0); /* held by the sniff (LENGTH 94) */
  uint8_t bad[] = {DXL_HEADER_BYTE, DXL_HEADER_BYTE, 1, 2, DXL_INST_PING, 0x00}; /* bad checksum */
  bench_exchange(&r, bad, sizeof bad, 6);
  bench_exchange(&r, p, packet_encode(p, 1, DXL_INST_RESET, NULL, 0), 6);                  /* RESET */
  world_run_until(r.world, r.world->now + MS(200));
  uint16_t statics_end;
  if (!elf_ram_end_of_statics(bench_elf_path, &statics_end)) bench_die("no end-of-statics symbol in the ELF", NULL);
  unsigned deepest = 0;
  for (size_t i = 0; i < r.world->servo_count; i++) {
    const unsigned depth = servo_stack_depth(r.world->servos[i], statics_end, STACK_PAINT_BYTE);
    if (depth > deepest) deepest = depth;
  }
  printf("{\"stack_deepest_bytes\": %u, \"statics_end\": %u}\n", deepest, statics_end);
  bench_rig_close(&r);
}

