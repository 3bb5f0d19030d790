/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "id_list.h"

#include <ctype.h>
#include <stdio.h>
#include <string.h>

/* Reads a decimal number at *p; false if there is none or it exceeds 999. */
static bool read_number(const char **p, unsigned *value) {
  const char *s = *p;
  unsigned v = 0;
  size_t digits = 0;
  while (isdigit((unsigned char)*s)) {
    v = v * 10u + (unsigned)(*s - '0');
    s++;
    if (++digits > 3) {
      return false;
    }
  }
  if (digits == 0) {
    return false;
  }
  *value = v;
  *p = s;
  return true;
}

bool id_list_parse(const char *text, uint8_t ids[ID_LIST_MAX_ID + 1u], size_t *count, char *err, size_t err_len) {
  bool seen[ID_LIST_MAX_ID + 1u];
  memset(seen, 0, sizeof(seen));
  *count = 0;
  const char *p = text;
  if (!*p) {
    snprintf(err, err_len, "empty ID list");
    return false;
  }
  for (;;) {
    unsigned first;
    unsigned last;
    if (!read_number(&p, &first)) {
      snprintf(err, err_len, "bad ID list '%s': expected a number at '%s'", text, p);
      return false;
    }
    last = first;
    if (*p == '-') {
      p++;
      if (!read_number(&p, &last)) {
        snprintf(err, err_len, "bad ID list '%s': expected a number at '%s'", text, p);
        return false;
      }
    }
    if (first > ID_LIST_MAX_ID || last > ID_LIST_MAX_ID) {
      snprintf(err, err_len, "ID %u is outside 0..%u", first > ID_LIST_MAX_ID ? first : last, ID_LIST_MAX_ID);
      return false;
    }
    if (last < first) {
      snprintf(err, err_len, "bad ID range %u-%u", first, last);
      return false;
    }
    for (unsigned id = first; id <= last; id++) {
      if (seen[id]) {
        snprintf(err, err_len, "ID %u listed twice", id);
        return false;
      }
      seen[id] = true;
      ids[(*count)++] = (uint8_t)id;
    }
    if (*p == '\0') {
      return true;
    }
    if (*p != ',') {
      snprintf(err, err_len, "bad ID list '%s': unexpected '%c'", text, *p);
      return false;
    }
    p++;
  }
}
