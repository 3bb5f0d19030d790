#include "conversation.h"

#include <ctype.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LINE_MAX_CHARS 4096u
#define BAUD_REGISTER_MAX 254u
#define SERVO_ID_MAX 253u

typedef struct {
  const char *name;
  unsigned line;
  char *err;
  size_t err_len;
  bool seen_content;   /* a line other than comments and blanks */
  bool seen_exchange;  /* a `>` (or any step) was read: setup directives are over */
  bool seen_servos, seen_baud, seen_temperature;
  conv_step_t *open;   /* the exchange whose `<` lines are being read */
  bool open_none;      /* it got `< none` */
  size_t step_capacity;
} parser_t;

static bool fail(parser_t *p, const char *fmt, ...) {
  if (p->err != NULL && p->err_len > 0) {
    int n = snprintf(p->err, p->err_len, "%s:%u: ", p->name, p->line);
    if (n < 0) {
      n = 0;
    }
    if ((size_t)n < p->err_len) {
      va_list ap;
      va_start(ap, fmt);
      vsnprintf(p->err + n, p->err_len - (size_t)n, fmt, ap);
      va_end(ap);
    }
  }
  return false;
}

static char *skip_space(char *s) {
  while (*s != '\0' && isspace((unsigned char)*s)) {
    s++;
  }
  return s;
}

static void trim_end(char *s) {
  size_t n = strlen(s);
  while (n > 0 && isspace((unsigned char)s[n - 1])) {
    s[--n] = '\0';
  }
}

static bool append_bytes(uint8_t **buf, size_t *len, const uint8_t *bytes, size_t count) {
  uint8_t *grown = realloc(*buf, *len + count);
  if (grown == NULL) {
    return false;
  }
  memcpy(grown + *len, bytes, count);
  *buf = grown;
  *len += count;
  return true;
}

/* Hex byte list: pairs such as "FF" or "0xFF", separated by white space. */
static bool parse_hex_bytes(parser_t *p, char *text, uint8_t **buf, size_t *len) {
  size_t count = 0;
  for (char *tok = strtok(text, " \t"); tok != NULL; tok = strtok(NULL, " \t")) {
    const char *digits = tok;
    if (digits[0] == '0' && (digits[1] == 'x' || digits[1] == 'X') && digits[2] != '\0') {
      digits += 2;
    }
    const size_t n = strlen(digits);
    if (n == 0 || n > 2 || !isxdigit((unsigned char)digits[0]) || (n == 2 && !isxdigit((unsigned char)digits[1]))) {
      return fail(p, "'%s' is not a hexadecimal byte", tok);
    }
    const uint8_t byte = (uint8_t)strtoul(digits, NULL, 16);
    if (!append_bytes(buf, len, &byte, 1)) {
      return fail(p, "out of memory");
    }
    count++;
  }
  if (count == 0) {
    return fail(p, "no bytes given");
  }
  return true;
}

static bool parse_number(parser_t *p, const char *what, const char *text, unsigned long max, unsigned long *value) {
  if (*text == '\0') {
    return fail(p, "%s: a number is missing", what);
  }
  for (const char *c = text; *c != '\0'; c++) {
    if (!isdigit((unsigned char)*c)) {
      return fail(p, "%s: '%s' is not a decimal number", what, text);
    }
  }
  errno = 0;
  *value = strtoul(text, NULL, 10);
  if (errno != 0 || *value > max) {
    return fail(p, "%s: %s is out of range 0..%lu", what, text, max);
  }
  return true;
}

static conv_step_t *new_step(parser_t *p, conv_t *c, conv_step_kind_t kind) {
  if (c->step_count == p->step_capacity) {
    const size_t capacity = p->step_capacity == 0 ? 16u : p->step_capacity * 2u;
    conv_step_t *grown = realloc(c->steps, capacity * sizeof *grown);
    if (grown == NULL) {
      fail(p, "out of memory");
      return NULL;
    }
    c->steps = grown;
    p->step_capacity = capacity;
  }
  conv_step_t *s = &c->steps[c->step_count++];
  memset(s, 0, sizeof *s);
  s->kind = kind;
  s->line = p->line;
  return s;
}

/* The open exchange (if any) must have its expectation before anything else comes. */
static bool close_exchange(parser_t *p) {
  if (p->open != NULL && p->open->expect_len == 0 && !p->open_none) {
    const unsigned line = p->line;
    p->line = p->open->line;
    fail(p, "'>' has no '<' line after it (write '< none' when nothing may come back)");
    p->line = line;
    return false;
  }
  p->open = NULL;
  p->open_none = false;
  return true;
}

static bool parse_servos(parser_t *p, conv_t *c, char *text) {
  c->servo_count = 0;
  for (char *tok = strtok(text, ", \t"); tok != NULL; tok = strtok(NULL, ", \t")) {
    unsigned long id;
    if (!parse_number(p, "servos", tok, SERVO_ID_MAX, &id)) {
      return false;
    }
    if (c->servo_count == CONV_MAX_SERVOS) {
      return fail(p, "servos: more than %u servos", CONV_MAX_SERVOS);
    }
    for (size_t i = 0; i < c->servo_count; i++) {
      if (c->servo_ids[i] == id) {
        return fail(p, "servos: ID %lu listed twice", id);
      }
    }
    c->servo_ids[c->servo_count++] = (uint8_t)id;
  }
  if (c->servo_count == 0) {
    return fail(p, "servos: no ID given");
  }
  return true;
}

static bool setup_allowed(parser_t *p, const char *what, bool *seen) {
  if (p->seen_exchange) {
    return fail(p, "'%s' must come before the first '>'", what);
  }
  if (*seen) {
    return fail(p, "'%s' given twice", what);
  }
  *seen = true;
  return true;
}

static bool parse_line(parser_t *p, conv_t *c, char *line) {
  char *hash = strchr(line, '#');
  if (hash != NULL) {
    *hash = '\0';
  }
  trim_end(line);
  char *s = skip_space(line);
  if (*s == '\0') {
    return true;
  }
  const bool first_content = !p->seen_content;
  p->seen_content = true;

  if (*s == '<') {
    if (p->open == NULL) {
      return fail(p, "'<' without a '>' before it");
    }
    char *rest = skip_space(s + 1);
    if (strcmp(rest, "none") == 0) {
      if (p->open->expect_len != 0 || p->open_none) {
        return fail(p, "'< none' must be the only '<' line of its exchange");
      }
      p->open_none = true;
      p->open->expect_line = p->line;
      return true;
    }
    if (p->open_none) {
      return fail(p, "'< none' must be the only '<' line of its exchange");
    }
    if (p->open->expect_len == 0) {
      p->open->expect_line = p->line;
    }
    return parse_hex_bytes(p, rest, &p->open->expect, &p->open->expect_len);
  }

  if (!close_exchange(p)) {
    return false;
  }

  if (*s == '>') {
    conv_step_t *step = new_step(p, c, CONV_STEP_EXCHANGE);
    if (step == NULL) {
      return false;
    }
    p->seen_exchange = true;
    p->open = step;
    return parse_hex_bytes(p, skip_space(s + 1), &step->send, &step->send_len);
  }

  char *word = s;
  while (*s != '\0' && !isspace((unsigned char)*s)) {
    s++;
  }
  if (*s != '\0') {
    *s++ = '\0';
  }
  char *arg = skip_space(s);
  unsigned long value;

  if (strcmp(word, "profile") == 0) {
    if (!first_content) {
      return fail(p, "'profile' must be the first directive");
    }
    if (strcmp(arg, "ax12") != 0 && strcmp(arg, "ax12a") != 0) {
      return fail(p, "profile: '%s' is not ax12 or ax12a", arg);
    }
    strcpy(c->profile, arg);
    return true;
  }
  if (strcmp(word, "servos") == 0) {
    return setup_allowed(p, word, &p->seen_servos) && parse_servos(p, c, arg);
  }
  if (strcmp(word, "baud") == 0) {
    if (!setup_allowed(p, word, &p->seen_baud) || !parse_number(p, word, arg, BAUD_REGISTER_MAX, &value)) {
      return false;
    }
    c->baud = (uint8_t)value;
    return true;
  }
  if (strcmp(word, "temperature") == 0) {
    if (!setup_allowed(p, word, &p->seen_temperature) || !parse_number(p, word, arg, 255u, &value)) {
      return false;
    }
    c->temperature_c = (uint8_t)value;
    return true;
  }
  if (strcmp(word, "master-baud") == 0) {
    if (!parse_number(p, word, arg, BAUD_REGISTER_MAX, &value)) {
      return false;
    }
    conv_step_t *step = new_step(p, c, CONV_STEP_MASTER_BAUD);
    if (step == NULL) {
      return false;
    }
    step->master_baud = (uint8_t)value;
    p->seen_exchange = true;
    return true;
  }
  if (strcmp(word, "power-cycle") == 0) {
    if (*arg != '\0') {
      return fail(p, "power-cycle takes no argument");
    }
    p->seen_exchange = true;
    return new_step(p, c, CONV_STEP_POWER_CYCLE) != NULL;
  }
  return fail(p, "unknown directive '%s'", word);
}

static void conv_init(conv_t *c, const char *name) {
  memset(c, 0, sizeof *c);
  snprintf(c->path, sizeof c->path, "%s", name);
  c->servo_ids[0] = CONV_DEFAULT_ID;
  c->servo_count = 1;
  c->baud = CONV_DEFAULT_BAUD;
  c->temperature_c = CONV_DEFAULT_TEMPERATURE_C;
}

bool conv_parse(const char *name, const char *text, conv_t *out, char *err, size_t err_len) {
  conv_init(out, name);
  if (err != NULL && err_len > 0) {
    err[0] = '\0';
  }
  parser_t p = {.name = name, .err = err, .err_len = err_len};
  char line[LINE_MAX_CHARS];
  const char *cursor = text;
  bool ok = true;
  while (ok && *cursor != '\0') {
    p.line++;
    const char *eol = strchr(cursor, '\n');
    const size_t n = eol != NULL ? (size_t)(eol - cursor) : strlen(cursor);
    if (n >= sizeof line) {
      ok = fail(&p, "line longer than %u characters", LINE_MAX_CHARS - 1u);
      break;
    }
    memcpy(line, cursor, n);
    line[n] = '\0';
    ok = parse_line(&p, out, line);
    cursor += n + (eol != NULL ? 1u : 0u);
  }
  if (ok) {
    ok = close_exchange(&p);
  }
  if (ok && out->step_count == 0) {
    p.line = p.line == 0 ? 1u : p.line;
    ok = fail(&p, "no '>' exchange in the file");
  }
  if (!ok) {
    conv_free(out);
  }
  return ok;
}

bool conv_load(const char *path, conv_t *out, char *err, size_t err_len) {
  conv_init(out, path);
  FILE *f = fopen(path, "rb");
  if (f == NULL) {
    if (err != NULL && err_len > 0) {
      snprintf(err, err_len, "%s:0: cannot open: %s", path, strerror(errno));
    }
    return false;
  }
  char *text = NULL;
  size_t len = 0;
  char chunk[4096];
  size_t got;
  bool ok = true;
  while ((got = fread(chunk, 1, sizeof chunk, f)) > 0) {
    char *grown = realloc(text, len + got + 1);
    if (grown == NULL) {
      ok = false;
      break;
    }
    text = grown;
    memcpy(text + len, chunk, got);
    len += got;
  }
  fclose(f);
  if (!ok) {
    free(text);
    if (err != NULL && err_len > 0) {
      snprintf(err, err_len, "%s:0: out of memory", path);
    }
    return false;
  }
  if (text == NULL) {
    text = calloc(1, 1);
    if (text == NULL) {
      return false;
    }
  }
  text[len] = '\0';
  if (strlen(text) != len) {
    free(text);
    if (err != NULL && err_len > 0) {
      snprintf(err, err_len, "%s:0: contains a NUL byte", path);
    }
    return false;
  }
  ok = conv_parse(path, text, out, err, err_len);
  free(text);
  return ok;
}

bool conv_applies_to_profile(const conv_t *conv, const char *profile_name) {
  return conv->profile[0] == '\0' || strcmp(conv->profile, profile_name) == 0;
}

void conv_free(conv_t *conv) {
  for (size_t i = 0; i < conv->step_count; i++) {
    free(conv->steps[i].send);
    free(conv->steps[i].expect);
  }
  free(conv->steps);
  conv->steps = NULL;
  conv->step_count = 0;
}
