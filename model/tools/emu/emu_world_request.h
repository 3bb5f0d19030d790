/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The control protocol's "world" request: a servo's (or every servo's) supply, air and load
 * changed while it runs, with the names and ranges of serve's world options plus "load-none"
 * (docs/dashboard.md). */
#ifndef EMU_WORLD_REQUEST_H
#define EMU_WORLD_REQUEST_H

#include <stddef.h>

#include <cjson/cJSON.h>

#include "emu_status.h"

/* {"id": slot or "all", "set": {...}}: every selected servo's new world checked, then applied
 * to its plant (no "set": only read). The answer, or NULL with err set and nothing changed. */
cJSON *emu_world_request(emu_servos_t *v, const cJSON *req, char *err, size_t err_len);

#endif
