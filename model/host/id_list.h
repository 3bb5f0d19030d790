/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `--ids` lists: "1", "1,2,3", "1-18", mixed ("1-4,7,10-12"). IDs 0..253 (254 is the
 * broadcast ID), each at most once. */
#ifndef SIM_ID_LIST_H
#define SIM_ID_LIST_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define ID_LIST_MAX_ID 253u

/* Parses text into ids[0..*count) in the order given. False with a one-line reason in err. */
bool id_list_parse(const char *text, uint8_t ids[ID_LIST_MAX_ID + 1u], size_t *count, char *err, size_t err_len);

#endif
