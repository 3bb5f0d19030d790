/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_bus_play.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_COLUMNS 32
#define LINE_MAX_BYTES 8192

/* Splits line at commas in place (no field holds one: docs/emulator.md "The CSV"). */
static int split(char *line, char **fields) {
  int n = 0;
  fields[n++] = line;
  for (char *p = line; *p && n < MAX_COLUMNS; p++) {
    if (*p == ',') {
      *p = '\0';
      fields[n++] = p + 1;
    }
  }
  return n;
}

static void chomp(char *line) {
  size_t n = strlen(line);
  while (n && (line[n - 1] == '\n' || line[n - 1] == '\r')) {
    line[--n] = '\0';
  }
}

static bool parse_hex(const char *text, uint8_t **out, size_t *len) {
  *len = 0;
  *out = malloc(strlen(text) / 2u + 1u);
  if (!*out) {
    return false;
  }
  int nibble = -1;
  for (const char *p = text; *p; p++) {
    if (*p == ' ') {
      if (nibble >= 0) {
        return false;
      }
      continue;
    }
    if (!isxdigit((unsigned char)*p)) {
      return false;
    }
    const int digit = isdigit((unsigned char)*p) ? *p - '0' : tolower((unsigned char)*p) - 'a' + 10;
    if (nibble < 0) {
      nibble = digit;
    } else {
      (*out)[(*len)++] = (uint8_t)(nibble << 4 | digit);
      nibble = -1;
    }
  }
  return nibble < 0 && *len > 0;
}

static int fail(emu_bus_play_t *play, FILE *f, char *err, size_t err_len, const char *path, unsigned line,
                const char *what) {
  snprintf(err, err_len, "--play-bus %s, line %u: %s", path, line, what);
  if (f) {
    fclose(f);
  }
  emu_bus_play_free(play);
  return -1;
}

static int by_time(const void *a, const void *b) {
  const sim_cycles_t x = ((const emu_play_row_t *)a)->at, y = ((const emu_play_row_t *)b)->at;
  return x < y ? -1 : x > y;
}

int emu_bus_play_load(emu_bus_play_t *play, const char *path, char *err, size_t err_len) {
  memset(play, 0, sizeof(*play));
  FILE *f = fopen(path, "r");
  if (!f) {
    snprintf(err, err_len, "--play-bus %s: %s", path, strerror(errno));
    return -1;
  }
  char line[LINE_MAX_BYTES];
  char *fields[MAX_COLUMNS];
  unsigned number = 1;
  if (!fgets(line, sizeof line, f)) {
    return fail(play, f, err, err_len, path, number, "empty: no header row");
  }
  chomp(line);
  const int columns = split(line, fields);
  int time_col = -1, sender_col = -1, raw_col = -1;
  for (int i = 0; i < columns; i++) {
    time_col = strcmp(fields[i], "time_us") == 0 ? i : time_col;
    sender_col = strcmp(fields[i], "sender") == 0 ? i : sender_col;
    raw_col = strcmp(fields[i], "raw") == 0 ? i : raw_col;
  }
  if (time_col < 0 || sender_col < 0 || raw_col < 0) {
    return fail(play, f, err, err_len, path, number, "the header lacks time_us, sender or raw (a --log-bus CSV)");
  }
  size_t cap = 0;
  while (fgets(line, sizeof line, f)) {
    number++;
    chomp(line);
    if (!line[0]) {
      continue;
    }
    if (split(line, fields) != columns) {
      return fail(play, f, err, err_len, path, number, "a field count unlike the header's");
    }
    if (strcmp(fields[sender_col], "client") != 0) {
      continue;
    }
    char *end = NULL;
    errno = 0;
    const double time_us = strtod(fields[time_col], &end);
    if (errno || end == fields[time_col] || *end || !(time_us >= 0.0) || !isfinite(time_us)) {
      return fail(play, f, err, err_len, path, number, "time_us is not a time in microseconds");
    }
    if (play->count == cap) {
      cap = cap ? 2 * cap : 64;
      emu_play_row_t *rows = realloc(play->rows, cap * sizeof(*rows));
      if (!rows) {
        return fail(play, f, err, err_len, path, number, "out of memory");
      }
      play->rows = rows;
    }
    emu_play_row_t *row = &play->rows[play->count];
    row->at = (sim_cycles_t)llround(time_us * SIM_CYCLES_PER_US);
    if (!parse_hex(fields[raw_col], &row->bytes, &row->len)) {
      free(row->bytes);
      return fail(play, f, err, err_len, path, number, "raw is not bytes in hex");
    }
    play->count++;
  }
  fclose(f);
  if (play->count == 0) {
    return fail(play, NULL, err, err_len, path, number, "no client row to play");
  }
  qsort(play->rows, play->count, sizeof(*play->rows), by_time);
  return 0;
}

int emu_bus_play_start(emu_bus_play_t *play, world_t *world, double bps, char *err, size_t err_len) {
  play->master = world_add_master(world, bps);
  if (!play->master) {
    snprintf(err, err_len, "--play-bus: no room on the bus for its master");
    return -1;
  }
  snprintf(world->bus.nodes[play->master->node].name, sizeof(world->bus.nodes[play->master->node].name), "play");
  return 0;
}

sim_cycles_t emu_bus_play_next(const emu_bus_play_t *play) {
  return play->master && play->next < play->count ? play->rows[play->next].at : SIM_CYCLES_NEVER;
}

void emu_bus_play_poll(emu_bus_play_t *play, sim_cycles_t now) {
  if (!play->master) {
    return;
  }
  while (play->next < play->count && play->rows[play->next].at <= now) {
    const emu_play_row_t *row = &play->rows[play->next++];
    (void)master_send(play->master, row->bytes, row->len);
  }
  master_rx_clear(play->master); /* the answers are on the bus (and in --log-bus), not kept here */
}

void emu_bus_play_free(emu_bus_play_t *play) {
  for (size_t i = 0; i < play->count; i++) {
    free(play->rows[i].bytes);
  }
  free(play->rows);
  if (play->master) {
    master_destroy(play->master);
  }
  memset(play, 0, sizeof(*play));
}
