/* The conformance log: what the core tests send and hear, recorded for docs/conformance.md.
 *
 * When the environment variable AX12_CONFORMANCE_LOG names a file, every test case that calls
 * conformance_begin() appends one JSON object (one line) to it at conformance_end(): profile,
 * group, the test name as a sentence, the rule it checks, its facts (expected outcome fields)
 * and its steps in order: the bus it starts from, every exchange (bytes the master sent, bytes
 * it heard back, hex; "given" for setup, "when" for the checked packets; what changed in the
 * control tables), power cycles, master baud changes and notes. scripts/conformance runs the
 * tests with it and renders the document.
 *
 * Without the variable every function returns at once: no file I/O, no allocation. Nothing
 * here asserts, so recording never changes whether a test passes.
 *
 * The hooks sit in host_bus.c (host_bus_init, host_bus_send*, host_bus_power_cycle,
 * host_bus_set_master_baud) and bus_steps.c (given_write), so every step is recorded without
 * touching the tests themselves. The record lives in a shared anonymous mapping, so the steps
 * of a test body run in a forked child are kept too.
 */
#ifndef CONFORMANCE_LOG_H
#define CONFORMANCE_LOG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "host_bus.h"

/* Where a rule comes from. */
#define CONFORMANCE_POLICY "docs/policy.md"
#define CONFORMANCE_CONVERSATION "test/conversations"

bool conformance_enabled(void);

/* Starts a record (a record still open is written first). source/section/rule may be NULL. */
void conformance_begin(const char *group, const char *name, const char *source, const char *section,
                       const char *rule);
/* Writes the open record as one JSON line and closes it; nothing when none is open. */
void conformance_end(void);

/* Facts of the open record: "facts": {key: value, ...}. */
void conformance_fact_str(const char *key, const char *value);
void conformance_fact_int(const char *key, long value);
void conformance_fact_bool(const char *key, bool value);
/* A text field at the record's top level (e.g. "description"). */
void conformance_field_str(const char *key, const char *value);

/* Exchanges between given_begin and given_end are setup ("given"); the others are "when". */
void conformance_given_begin(void);
void conformance_given_end(void);

/* Nothing is recorded between pause and resume (reference buses built for comparison). */
void conformance_pause(void);
void conformance_resume(void);

/* A note attached to the next step recorded. Notes given before one step are joined. */
void conformance_note(const char *text);

/* A step described in words (e.g. a condition the test sets on the servo directly). */
void conformance_event(const char *text);

/* Hooks of the host bus. */
void conformance_on_bus_init(const host_bus_t *bus);
void conformance_on_send_begin(const host_bus_t *bus);
void conformance_on_send_end(const host_bus_t *bus, const uint8_t *sent, size_t count, size_t heard_from);
void conformance_on_power_cycle(const host_bus_t *bus);
void conformance_on_master_baud(const host_bus_t *bus, uint8_t baud_register);

/* A packet handed to the core's API directly (no bus): the bytes it stands for, the status
 * packet the core built, and what else the test looked at. */
void conformance_on_api_exchange(const uint8_t *sent, size_t sent_count, const uint8_t *reply, size_t reply_count,
                                 const char *note);

#endif
