/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "vcd_writer.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* Longest line put() is given. */
#define LINE_ROOM 256u

/* A variable's identifier: its index in base 94 over the printable characters '!'..'~'. */
static size_t id_code(size_t index, char out[8]) {
  size_t n = 0;
  do {
    out[n++] = (char)('!' + index % 94u);
    index /= 94u;
  } while (index && n < 7);
  out[n] = '\0';
  return n;
}

/* Adds one whole line (len <= LINE_ROOM); the buffer goes out first when it would not fit, so
 * the file always ends on a whole line. */
static void put(vcd_writer_t *w, const char *text, size_t len) {
  if (w->len + len > VCD_WRITER_BUFFER) {
    (void)vcd_writer_flush(w);
  }
  if (w->error) {
    return;
  }
  memcpy(w->buf + w->len, text, len);
  w->len += len;
}

static void putf(vcd_writer_t *w, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void putf(vcd_writer_t *w, const char *fmt, ...) {
  char line[LINE_ROOM];
  va_list ap;
  va_start(ap, fmt);
  const int n = vsnprintf(line, sizeof(line), fmt, ap);
  va_end(ap);
  if (n > 0) {
    put(w, line, (size_t)n < sizeof(line) ? (size_t)n : sizeof(line) - 1u);
  }
}

int vcd_writer_open(vcd_writer_t *w, const char *path, const char *version, char *err, size_t err_len) {
  memset(w, 0, sizeof(*w));
  w->fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (w->fd < 0) {
    snprintf(err, err_len, "cannot create %s: %s", path, strerror(errno));
    return -1;
  }
  w->buf = malloc(VCD_WRITER_BUFFER);
  if (!w->buf) {
    close(w->fd);
    w->fd = -1;
    snprintf(err, err_len, "out of memory");
    return -1;
  }
  char date[64] = "";
  const time_t now = time(NULL);
  struct tm tm;
  if (gmtime_r(&now, &tm)) {
    strftime(date, sizeof(date), "%Y-%m-%d %H:%M:%S UTC", &tm);
  }
  putf(w, "$date %s $end\n", date);
  putf(w, "$version %s $end\n", version);
  putf(w, "$comment one time unit = 100 ps; a 16 MHz cycle = %u units $end\n", VCD_TIME_UNITS_PER_CYCLE);
  putf(w, "$timescale 100 ps $end\n");
  return 0;
}

void vcd_writer_scope(vcd_writer_t *w, const char *name) {
  putf(w, "$scope module %s $end\n", name);
  w->scope_depth++;
}

void vcd_writer_scope_end(vcd_writer_t *w) {
  if (w->scope_depth) {
    w->scope_depth--;
    putf(w, "$upscope $end\n");
  }
}

int vcd_writer_var(vcd_writer_t *w, const char *name, unsigned width) {
  if (w->in_body || width < 1 || width > 32 || w->var_count >= VCD_WRITER_MAX_VARS) {
    return -1;
  }
  if (w->var_count == w->var_cap) {
    const size_t cap = w->var_cap ? 2 * w->var_cap : 64;
    vcd_var_t *vars = realloc(w->vars, cap * sizeof(*vars));
    if (!vars) {
      return -1;
    }
    w->vars = vars;
    w->var_cap = cap;
  }
  const size_t index = w->var_count++;
  w->vars[index] = (vcd_var_t){.width = (uint8_t)width};
  char id[8];
  id_code(index, id);
  putf(w, "$var wire %u %s %s $end\n", width, id, name);
  return (int)index;
}

void vcd_writer_initial(vcd_writer_t *w, int var, uint32_t value) {
  if (var >= 0 && (size_t)var < w->var_count && !w->in_body) {
    w->vars[var].value = value;
  }
}

/* One value line: "0!" for a wire, "b101 !" for a vector. */
static void put_value(vcd_writer_t *w, size_t index, uint32_t value) {
  char line[48];
  size_t n = 0;
  const vcd_var_t *v = &w->vars[index];
  if (v->width == 1) {
    line[n++] = (value & 1u) ? '1' : '0';
  } else {
    line[n++] = 'b';
    int top = (int)v->width - 1;
    while (top > 0 && !((value >> top) & 1u)) {
      top--; /* leading zeros are implied */
    }
    for (int bit = top; bit >= 0; bit--) {
      line[n++] = ((value >> bit) & 1u) ? '1' : '0';
    }
    line[n++] = ' ';
  }
  n += id_code(index, line + n);
  line[n++] = '\n';
  put(w, line, n);
}

static void put_time(vcd_writer_t *w, sim_cycles_t t) {
  putf(w, "#%" PRIu64 "\n", (uint64_t)t * VCD_TIME_UNITS_PER_CYCLE);
  w->last_time = t;
  w->time_written = true;
}

void vcd_writer_begin(vcd_writer_t *w, sim_cycles_t t) {
  while (w->scope_depth) {
    vcd_writer_scope_end(w);
  }
  putf(w, "$enddefinitions $end\n");
  w->in_body = true;
  put_time(w, t);
  putf(w, "$dumpvars\n");
  for (size_t i = 0; i < w->var_count; i++) {
    put_value(w, i, w->vars[i].value);
    w->vars[i].written = true;
  }
  putf(w, "$end\n");
}

void vcd_writer_change(vcd_writer_t *w, sim_cycles_t t, int var, uint32_t value) {
  if (!w->in_body || var < 0 || (size_t)var >= w->var_count) {
    return;
  }
  vcd_var_t *v = &w->vars[var];
  if (v->width < 32) {
    value &= (1u << v->width) - 1u;
  }
  if (v->written && v->value == value) {
    return;
  }
  if (!w->time_written || t > w->last_time) {
    put_time(w, t);
  }
  v->value = value;
  v->written = true;
  put_value(w, (size_t)var, value);
}

int vcd_writer_flush(vcd_writer_t *w) {
  size_t done = 0;
  while (!w->error && done < w->len) {
    const ssize_t n = write(w->fd, w->buf + done, w->len - done);
    if (n < 0) {
      if (errno == EINTR) {
        continue;
      }
      w->error = errno;
      break;
    }
    done += (size_t)n;
  }
  w->bytes_written += done;
  w->len = 0;
  return w->error ? -1 : 0;
}

int vcd_writer_close(vcd_writer_t *w, sim_cycles_t end) {
  if (w->fd < 0) {
    return -1;
  }
  if (w->in_body && (!w->time_written || end > w->last_time)) {
    put_time(w, end);
  }
  const int flushed = vcd_writer_flush(w);
  const int closed = close(w->fd);
  w->fd = -1;
  free(w->buf);
  free(w->vars);
  w->buf = NULL;
  w->vars = NULL;
  return flushed == 0 && closed == 0 && !w->error ? 0 : -1;
}
