/* Conversation files (test/conversations/README.md): a scenario on a Dynamixel bus, what the
 * master sends and exactly what must come back. Plain C11, no test framework, so every level
 * that replays the suite (host core, simavr) shares one reader.
 *
 * A file becomes a conv_t: the setup (profile filter, servo IDs, Baud Rate register, temperature)
 * and a list of steps in file order:
 *   CONV_STEP_EXCHANGE     a `>` line and the `<` lines after it: send[] goes out, and
 *                          exactly expect[] must come back (expect_len 0: nothing may come back).
 *                          Several `<` lines after one `>` are concatenated (one reply per line
 *                          reads best when several servos answer). A `>` without any `<` after
 *                          it is a parse error: every exchange states what comes back.
 *   CONV_STEP_MASTER_BAUD  `master-baud N`: the master's UART switches to Baud Rate register N.
 *   CONV_STEP_POWER_CYCLE  `power-cycle`: every servo restarts, EEPROM kept, RAM not.
 *
 * Bytes are hexadecimal pairs ("FF", "0x" prefix allowed); numbers in directives are decimal.
 * Errors are reported as "path:line: message".
 */
#ifndef CONVERSATION_H
#define CONVERSATION_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define CONV_MAX_SERVOS 32u
#define CONV_DEFAULT_ID 1u
#define CONV_DEFAULT_BAUD 1u           /* Baud Rate register value: 1 Mbps */
#define CONV_DEFAULT_TEMPERATURE_C 25u
#define CONV_PROFILE_MAX_CHARS 15u

typedef enum {
  CONV_STEP_EXCHANGE = 0,
  CONV_STEP_MASTER_BAUD,
  CONV_STEP_POWER_CYCLE,
} conv_step_kind_t;

typedef struct {
  conv_step_kind_t kind;
  unsigned line;       /* 1-based line of the `>` or directive, for messages */
  uint8_t *send;       /* EXCHANGE: bytes the master sends (send_len >= 1) */
  size_t send_len;
  uint8_t *expect;     /* EXCHANGE: bytes that must come back, in bus order; NULL when none */
  size_t expect_len;   /* 0 = nothing may come back (`< none`) */
  unsigned expect_line; /* EXCHANGE: line of the first `<` */
  uint8_t master_baud; /* MASTER_BAUD: Baud Rate register value */
} conv_step_t;

typedef struct {
  char path[256];                        /* as given to conv_load (truncated) */
  char profile[CONV_PROFILE_MAX_CHARS + 1]; /* "" = every profile, else "ax12" or "ax12a" */
  uint8_t servo_ids[CONV_MAX_SERVOS];    /* in the order listed */
  size_t servo_count;                    /* >= 1 */
  uint8_t baud;                          /* Baud Rate register of every servo and the master at start */
  uint8_t temperature_c;                 /* the servos' temperature, degrees C */
  conv_step_t *steps;
  size_t step_count;
} conv_t;

/* Reads and checks the file at path into *out. On failure returns false, writes
 * "path:line: message" into err (always NUL-terminated when err_len > 0) and leaves *out empty
 * (conv_free is still safe to call). */
bool conv_load(const char *path, conv_t *out, char *err, size_t err_len);

/* The same from text already in memory; name stands for the path in messages. */
bool conv_parse(const char *name, const char *text, conv_t *out, char *err, size_t err_len);

/* True when the scenario applies to the named profile ("ax12", "ax12a"). */
bool conv_applies_to_profile(const conv_t *conv, const char *profile_name);

/* Releases the steps; *conv is left empty. */
void conv_free(conv_t *conv);

#endif
