// SPDX-License-Identifier: GPL-3.0-or-later
/* ax12-bench: the figures of scripts/bench that come from simulated cycles (exact), printed
 * as one JSON object on stdout. Wall-clock figures (simulation speed) are measured here too,
 * once per call; scripts/bench takes medians over several calls.
 *
 *   ax12-bench turnaround ELF [REQUESTS]   reply start after the request's stop bit, RDT 0
 *   ax12-bench rdt ELF                     reply start error against 2 us x RDT
 *   ax12-bench sustained ELF SERVOS SECONDS [garbage]
 *                                          back-to-back SYNC_WRITE at 1 Mbps: bytes lost; with
 *                                          garbage, each with a bad checksum (a garbage flood)
 *   ax12-bench speed ELF SERVOS SECONDS    simulated seconds per wall second, idle and loaded
 *   ax12-bench stack ELF                   deepest stack after a workload of every instruction
 *   ax12-bench awake ELF                   share of cycles the MCU is awake: idle, holding
 *                                          a position (control loop alone), full bus load
 *   ax12-bench profile ELF SERVOS SECONDS [loop|sync|garbage]
 *                                          awake cycles by instruction address, holding and
 *                                          under a load: the client loop, back-to-back
 *                                          SYNC_WRITEs, or those with bad checksums
 *                                          (scripts/firmware_profile)
 *   ax12-bench robot ELF ROBOT SECONDS     a robot's servos (--robot NAME|FILE.xml) on their
 *                                          plants, its physics in lock-step: speed holding
 *                                          and under the client loop, the physics' steps
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_commands.h"
#include "bench_rig.h"

int main(int argc, char **argv) {
  if (argc < 3) {
    fprintf(stderr, "usage: ax12-bench turnaround|rdt|sustained|speed|stack|awake|profile|robot ELF [args]\n");
    return 2;
  }
  bench_elf_path = argv[2];
  if (strcmp(argv[1], "turnaround") == 0) {
    bench_turnaround(argc > 3 ? (unsigned)atoi(argv[3]) : 200);
  } else if (strcmp(argv[1], "rdt") == 0) {
    bench_rdt();
  } else if (strcmp(argv[1], "sustained") == 0 && argc > 4) {
    bench_sustained((unsigned)atoi(argv[3]), atof(argv[4]), argc > 5 && strcmp(argv[5], "garbage") == 0);
  } else if (strcmp(argv[1], "awake") == 0) {
    bench_awake();
  } else if (strcmp(argv[1], "stack") == 0) {
    bench_stack();
  } else if (strcmp(argv[1], "speed") == 0 && argc > 4) {
    bench_speed((unsigned)atoi(argv[3]), atof(argv[4]));
  } else if (strcmp(argv[1], "robot") == 0 && argc > 4) {
    bench_robot(argv[3], atof(argv[4]));
  } else if (strcmp(argv[1], "profile") == 0 && argc > 4) {
    const char *load = argc > 5 ? argv[5] : "loop";
    bench_profile((unsigned)atoi(argv[3]), atof(argv[4]),
                  strcmp(load, "sync") == 0      ? BENCH_LOAD_SYNC_WRITES
                  : strcmp(load, "garbage") == 0 ? BENCH_LOAD_GARBAGE
                                                 : BENCH_LOAD_CLIENT_LOOP);
  } else {
    fprintf(stderr, "ax12-bench: unknown command or missing arguments\n");
    return 2;
  }
  return 0;
}
