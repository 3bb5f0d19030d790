/* SPDX-License-Identifier: MIT */
#include "bus_packet_text.h"

#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>

const char *bus_packet_instruction_name(uint8_t instruction) {
  switch (instruction) {
  case 0x01:
    return "PING";
  case 0x02:
    return "READ";
  case 0x03:
    return "WRITE";
  case 0x04:
    return "REG_WRITE";
  case 0x05:
    return "ACTION";
  case 0x06:
    return "RESET";
  case 0x83:
    return "SYNC_WRITE";
  default:
    return NULL;
  }
}

const char *bus_packet_kind_name(bus_packet_kind_t kind) {
  switch (kind) {
  case BUS_PACKET_INSTRUCTION:
    return "instruction";
  case BUS_PACKET_STATUS:
    return "status";
  case BUS_PACKET_GARBAGE:
    return "garbage";
  case BUS_PACKET_PROTOCOL2:
    return "protocol2";
  }
  return "?";
}

const char *bus_packet_error_names(uint8_t error, char *text, size_t text_len) {
  /* The manual's error bits, bit 0 first. */
  static const char *const names[8] = {"VOLTAGE",  "ANGLE_LIMIT", "OVERHEATING", "RANGE",
                                       "CHECKSUM", "OVERLOAD",    "INSTRUCTION", "BIT7"};
  size_t used = 0;
  text[0] = '\0';
  if (error == 0) {
    snprintf(text, text_len, "NONE");
    return text;
  }
  for (unsigned bit = 0; bit < 8; bit++) {
    if ((error >> bit) & 1u) {
      const int n = snprintf(text + used, text_len - used, "%s%s", used ? "|" : "", names[bit]);
      if (n < 0 || (size_t)n >= text_len - used) {
        text[used] = '\0'; /* whole names only */
        break;
      }
      used += (size_t)n;
    }
  }
  return text;
}

typedef struct {
  char *out;
  size_t len, used;
} line_t;

static void put(line_t *l, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(line_t *l, const char *fmt, ...) {
  if (l->used + 1u >= l->len) {
    return;
  }
  va_list ap;
  va_start(ap, fmt);
  const int n = vsnprintf(l->out + l->used, l->len - l->used, fmt, ap);
  va_end(ap);
  if (n > 0) {
    l->used += (size_t)n < l->len - l->used ? (size_t)n : l->len - l->used - 1u;
  }
}

static void put_hex(line_t *l, const uint8_t *bytes, size_t count) {
  static const char digits[] = "0123456789ABCDEF";
  for (size_t i = 0; i < count && l->used + 4u < l->len; i++) {
    if (i) {
      l->out[l->used++] = ' ';
    }
    l->out[l->used++] = digits[bytes[i] >> 4];
    l->out[l->used++] = digits[bytes[i] & 0xFu];
  }
  l->out[l->used] = '\0';
}

/* Cycles as microseconds with four decimals, exactly (a cycle is 0.0625 us), and a comma. */
static void put_us(line_t *l, sim_cycles_t cycles) {
  _Static_assert(SIM_CYCLES_PER_US == 16u, "four decimals hold a cycle exactly");
  put(l, "%llu.%04u,", (unsigned long long)(cycles / SIM_CYCLES_PER_US),
      (unsigned)(cycles % SIM_CYCLES_PER_US) * 625u);
}

/* A name as a CSV field: no quoting needed once separators are replaced. */
static void put_name(line_t *l, const char *name) {
  for (const char *c = name; *c && l->used + 1u < l->len; c++) {
    l->out[l->used++] = (*c == ',' || *c == '"' || *c == '\n' || *c == '\r') ? '_' : *c;
  }
  l->out[l->used] = '\0';
}

size_t bus_packet_csv(const bus_packet_t *p, char *out, size_t out_len) {
  line_t l = {.out = out, .len = out_len, .used = 0};
  if (out_len == 0) {
    return 0;
  }
  out[0] = '\0';
  put_us(&l, p->start);
  put_us(&l, p->end);
  put_name(&l, p->sender_name ? p->sender_name : "");
  put(&l, ",%s,", bus_packet_kind_name(p->kind));
  const bool framed = p->kind == BUS_PACKET_INSTRUCTION || p->kind == BUS_PACKET_STATUS;
  if (framed) {
    char names[BUS_PACKET_ERROR_NAMES_MAX];
    const char *name = p->kind == BUS_PACKET_INSTRUCTION ? bus_packet_instruction_name(p->code)
                                                         : bus_packet_error_names(p->code, names, sizeof(names));
    put(&l, "%u,0x%02X,%s,", p->id, p->code, name ? name : "UNKNOWN");
    put_hex(&l, p->params, p->param_count);
    put(&l, ",%d,", p->checksum_ok ? 1 : 0);
  } else {
    put(&l, ",,,,,");
  }
  put(&l, "%d,%s%s%s,", p->collision ? 1 : 0, (p->line_flags & BUS_RX_TRUNCATED) ? "truncated" : "",
      (p->line_flags & BUS_RX_TRUNCATED) && p->noise_changed ? "|" : "", p->noise_changed ? "noise" : "");
  put_hex(&l, p->raw, p->raw_count);
  put(&l, "\n");
  return l.used;
}
