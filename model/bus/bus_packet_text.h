/* SPDX-License-Identifier: MIT */
/* The bus monitor's records (bus_monitor.h) as text: the names of instructions, kinds and
 * status error bits, and one CSV line per record (`--log-bus`, docs/emulator.md "Bus log and
 * replay"). Pure functions of a record, no state. */
#ifndef MODEL_BUS_PACKET_TEXT_H
#define MODEL_BUS_PACKET_TEXT_H

#include <stddef.h>
#include <stdint.h>

#include "bus_monitor.h"

/* The names the CSV uses: "PING" ... "SYNC_WRITE" for the manual's instructions, NULL for
 * another code; the kind as a word ("instruction", "status", "garbage", "protocol2"). */
const char *bus_packet_instruction_name(uint8_t instruction);
const char *bus_packet_kind_name(bus_packet_kind_t kind);
/* The error bits of a status packet as names joined by '|' ("NONE" for 0), e.g.
 * "RANGE|CHECKSUM", whole names only; returns text. BUS_PACKET_ERROR_NAMES_MAX holds all 8. */
#define BUS_PACKET_ERROR_NAMES_MAX 80u
const char *bus_packet_error_names(uint8_t error, char *text, size_t text_len);

/* The CSV of records: the header line and one line per record, both ending in '\n'.
 * Columns: time_us (start, simulated), end_us, sender, kind, id, code (0xNN), code_name
 * (instruction name or UNKNOWN; error bit names), params (hex bytes separated by spaces),
 * checksum_ok (1/0), collision (1/0), line (truncated|noise, or empty), raw (hex). Fields of a
 * garbage or 2.0 record that do not apply are empty. BUS_PACKET_CSV_MAX holds any line. */
#define BUS_PACKET_CSV_HEADER \
  "time_us,end_us,sender,kind,id,code,code_name,params,checksum_ok,collision,line,raw\n"
#define BUS_PACKET_CSV_MAX 2400u
/* Writes the record's line into out (always terminated) and returns its length; a line that
 * does not fit is cut (returns the length written). */
size_t bus_packet_csv(const bus_packet_t *packet, char *out, size_t out_len);

#endif
