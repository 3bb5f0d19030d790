#include "conformance_log.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#include "dxl_protocol.h"
#include "policy_table.h"

#ifndef AX12_PROFILE_NAME
#define AX12_PROFILE_NAME "unknown"
#endif

#define ENV_NAME "AX12_CONFORMANCE_LOG"

typedef struct {
  bool open;
  bool truncated;
  int given_depth;
  int paused;
  unsigned step_count;
  unsigned fact_count;
  size_t head_len;
  size_t facts_len;
  size_t note_len;
  size_t steps_len;
  size_t before_count;
  uint8_t before[HOST_BUS_MAX_SERVOS][CT_SIZE];
  char head[16384];
  char facts[8192];
  char note[8192];
  char steps[1u << 20];
} conformance_state_t;

static int enabled = -1; /* -1: not asked yet */
static const char *log_path;
static conformance_state_t *S;

bool conformance_enabled(void) {
  if (enabled < 0) {
    log_path = getenv(ENV_NAME);
    enabled = log_path != NULL && log_path[0] != '\0';
    if (enabled) {
      /* shared with forked children, so steps they record reach the parent's record */
      void *p = mmap(NULL, sizeof *S, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
      if (p == MAP_FAILED) {
        fprintf(stderr, "conformance log: cannot map the record, not recording\n");
        enabled = 0;
      } else {
        S = p;
        memset(S, 0, sizeof *S);
      }
    }
  }
  return enabled == 1;
}

static bool recording(void) { return conformance_enabled() && S->open && S->paused == 0; }

/* --- text buffers --------------------------------------------------------------------- */

__attribute__((format(printf, 4, 5))) static void put(char *buf, size_t cap, size_t *len, const char *fmt, ...) {
  if (*len >= cap) {
    S->truncated = true;
    return;
  }
  va_list ap;
  va_start(ap, fmt);
  const int n = vsnprintf(buf + *len, cap - *len, fmt, ap);
  va_end(ap);
  if (n < 0 || (size_t)n >= cap - *len) {
    S->truncated = true;
    *len = cap;
    buf[cap - 1] = '\0';
    return;
  }
  *len += (size_t)n;
}

static void put_json_string(char *buf, size_t cap, size_t *len, const char *s) {
  put(buf, cap, len, "\"");
  for (const unsigned char *c = (const unsigned char *)(s != NULL ? s : ""); *c != '\0'; c++) {
    if (*c == '"' || *c == '\\') {
      put(buf, cap, len, "\\%c", *c);
    } else if (*c == '\n') {
      put(buf, cap, len, "\\n");
    } else if (*c < 0x20) {
      put(buf, cap, len, "\\u%04x", *c);
    } else {
      put(buf, cap, len, "%c", *c);
    }
  }
  put(buf, cap, len, "\"");
}

static void put_hex(char *buf, size_t cap, size_t *len, const uint8_t *bytes, size_t count) {
  put(buf, cap, len, "\"");
  for (size_t i = 0; i < count; i++) {
    put(buf, cap, len, i == 0 ? "%02X" : " %02X", bytes[i]);
  }
  put(buf, cap, len, "\"");
}

#define HEAD S->head, sizeof S->head, &S->head_len
#define FACTS S->facts, sizeof S->facts, &S->facts_len
#define STEPS S->steps, sizeof S->steps, &S->steps_len

/* --- records -------------------------------------------------------------------------- */

void conformance_begin(const char *group, const char *name, const char *source, const char *section,
                       const char *rule) {
  if (!conformance_enabled()) {
    return;
  }
  conformance_end();
  memset(S, 0, offsetof(conformance_state_t, before));
  S->open = true;
  S->head[0] = S->facts[0] = S->note[0] = S->steps[0] = '\0';
  put(HEAD, "{\"profile\":");
  put_json_string(HEAD, AX12_PROFILE_NAME);
  put(HEAD, ",\"group\":");
  put_json_string(HEAD, group);
  put(HEAD, ",\"name\":");
  put_json_string(HEAD, name);
  if (source != NULL || rule != NULL) {
    put(HEAD, ",\"rule\":{\"source\":");
    put_json_string(HEAD, source);
    put(HEAD, ",\"section\":");
    put_json_string(HEAD, section);
    put(HEAD, ",\"text\":");
    put_json_string(HEAD, rule);
    put(HEAD, "}");
  }
}

void conformance_end(void) {
  if (!conformance_enabled() || !S->open) {
    return;
  }
  S->open = false;
  FILE *f = fopen(log_path, "a");
  if (f == NULL) {
    fprintf(stderr, "conformance log: cannot open %s\n", log_path);
    return;
  }
  fprintf(f, "%s,\"facts\":{%s},\"steps\":[%s]%s}\n", S->head, S->facts, S->steps,
          S->truncated ? ",\"truncated\":true" : "");
  fclose(f);
}

static void fact_key(const char *key) {
  put(FACTS, S->fact_count++ == 0 ? "" : ",");
  put_json_string(FACTS, key);
  put(FACTS, ":");
}

void conformance_fact_str(const char *key, const char *value) {
  if (!recording()) {
    return;
  }
  fact_key(key);
  put_json_string(FACTS, value);
}

void conformance_fact_int(const char *key, long value) {
  if (!recording()) {
    return;
  }
  fact_key(key);
  put(FACTS, "%ld", value);
}

void conformance_fact_bool(const char *key, bool value) {
  if (!recording()) {
    return;
  }
  fact_key(key);
  put(FACTS, value ? "true" : "false");
}

void conformance_field_str(const char *key, const char *value) {
  if (!recording()) {
    return;
  }
  put(HEAD, ",");
  put_json_string(HEAD, key);
  put(HEAD, ":");
  put_json_string(HEAD, value);
}

void conformance_given_begin(void) {
  if (conformance_enabled()) {
    S->given_depth++;
  }
}

void conformance_given_end(void) {
  if (conformance_enabled() && S->given_depth > 0) {
    S->given_depth--;
  }
}

void conformance_pause(void) {
  if (conformance_enabled()) {
    S->paused++;
  }
}

void conformance_resume(void) {
  if (conformance_enabled() && S->paused > 0) {
    S->paused--;
  }
}

void conformance_note(const char *text) {
  if (!recording()) {
    return;
  }
  put(S->note, sizeof S->note, &S->note_len, "%s%s", S->note_len == 0 ? "" : " ", text);
}

/* Opens a step object: {"kind":kind,"role":...,"note":... (the pending note)}. */
static void step_begin(const char *kind) {
  put(STEPS, "%s{\"kind\":", S->step_count++ == 0 ? "" : ",");
  put_json_string(STEPS, kind);
  put(STEPS, ",\"role\":");
  /* the bus a test starts from is always setup */
  put_json_string(STEPS, S->given_depth > 0 || strcmp(kind, "bus") == 0 ? "given" : "when");
  if (S->note_len != 0) {
    put(STEPS, ",\"note\":");
    put_json_string(STEPS, S->note);
    S->note_len = 0;
    S->note[0] = '\0';
  }
}

void conformance_event(const char *text) {
  if (!recording()) {
    return;
  }
  step_begin("event");
  put(STEPS, ",\"text\":");
  put_json_string(STEPS, text);
  put(STEPS, "}");
}

/* --- host bus hooks ------------------------------------------------------------------- */

void conformance_on_bus_init(const host_bus_t *bus) {
  if (!recording()) {
    return;
  }
  step_begin("bus");
  put(STEPS, ",\"ids\":[");
  for (size_t i = 0; i < bus->servo_count; i++) {
    put(STEPS, "%s%u", i == 0 ? "" : ",", bus->servos[i].servo.table[CT_ADDR_ID]);
  }
  put(STEPS, "],\"baud\":%u,\"temperature\":%u}", bus->master_baud, bus->temperature_c);
}

void conformance_on_send_begin(const host_bus_t *bus) {
  if (!recording()) {
    return;
  }
  S->before_count = bus->servo_count;
  for (size_t i = 0; i < bus->servo_count; i++) {
    memcpy(S->before[i], bus->servos[i].servo.table, CT_SIZE);
  }
}

static unsigned item_value(const uint8_t *table, const pol_item_t *item) {
  return item->size_bytes == 2 ? (unsigned)(table[item->addr] | (table[item->addr + 1] << 8)) : table[item->addr];
}

static void put_changes(const host_bus_t *bus) {
  put(STEPS, ",\"changes\":[");
  unsigned n = 0;
  for (size_t s = 0; s < S->before_count && s < bus->servo_count; s++) {
    const uint8_t *before = S->before[s];
    const uint8_t *after = bus->servos[s].servo.table;
    for (size_t i = 0; i < POL_ITEM_COUNT; i++) {
      const pol_item_t *item = &pol_items[i];
      const unsigned was = item_value(before, item);
      const unsigned now = item_value(after, item);
      if (was == now) {
        continue;
      }
      char text[160];
      if (S->before_count > 1) {
        snprintf(text, sizeof text, "ID %u: %s %u \u2192 %u", before[CT_ADDR_ID], item->name, was, now);
      } else {
        snprintf(text, sizeof text, "%s %u \u2192 %u", item->name, was, now);
      }
      put(STEPS, "%s", n++ == 0 ? "" : ",");
      put_json_string(STEPS, text);
    }
  }
  put(STEPS, "]");
}

void conformance_on_send_end(const host_bus_t *bus, const uint8_t *sent, size_t count, size_t heard_from) {
  if (!recording()) {
    return;
  }
  step_begin("exchange");
  put(STEPS, ",\"sent\":");
  put_hex(STEPS, sent, count);
  put(STEPS, ",\"heard\":");
  put_hex(STEPS, bus->heard + heard_from, bus->heard_len > heard_from ? bus->heard_len - heard_from : 0);
  if (bus->collision) {
    put(STEPS, ",\"collision\":true");
  }
  put_changes(bus);
  put(STEPS, "}");
}

void conformance_on_power_cycle(const host_bus_t *bus) {
  (void)bus;
  if (!recording()) {
    return;
  }
  step_begin("power-cycle");
  put(STEPS, "}");
}

void conformance_on_master_baud(const host_bus_t *bus, uint8_t baud_register) {
  (void)bus;
  if (!recording()) {
    return;
  }
  step_begin("master-baud");
  put(STEPS, ",\"baud\":%u}", baud_register);
}

void conformance_on_api_exchange(const uint8_t *sent, size_t sent_count, const uint8_t *reply, size_t reply_count,
                                 const char *note) {
  if (!recording()) {
    return;
  }
  if (note != NULL) {
    conformance_note(note);
  }
  step_begin("exchange");
  put(STEPS, ",\"via\":\"core API\",\"sent\":");
  put_hex(STEPS, sent, sent_count);
  put(STEPS, ",\"heard\":");
  put_hex(STEPS, reply, reply_count);
  put(STEPS, "}");
}
