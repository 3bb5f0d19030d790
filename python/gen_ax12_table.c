/* Writes the Python module ax12_table: the control table as the firmware defines it (the
 * CT_ITEMS X-macro of firmware/core/ct_items.h, with dxl_table.h's access codes and sizes) and
 * the Protocol 1.0 constants of dxl_protocol.h, so that the scripts and tests never restate
 * them. Built and run at build time by python/CMakeLists.txt.
 *
 * Usage: gen_ax12_table OUT.py
 */
#include <ctype.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "dxl_protocol.h"
#include "dxl_table.h"
#include "protocol_constants.h" /* DXL_PROTOCOL_CONSTANTS(X): every #define of dxl_protocol.h */

/* The item's name as the manual spells it: MODEL_NUMBER -> Model Number, ALARM_LED -> Alarm
 * LED, HIGHEST_LIMIT_TEMP -> Highest Limit Temperature, RESERVED_10 -> reserved. */
static void write_title(FILE *out, const char *name) {
  static const char *const upper_words[] = {"ID", "LED", "CW", "CCW"};
  if (strncmp(name, "RESERVED", 8) == 0) {
    fputs("reserved", out);
    return;
  }
  const char *word = name;
  while (*word) {
    size_t len = strcspn(word, "_");
    bool upper = false;
    for (size_t i = 0; i < sizeof upper_words / sizeof upper_words[0]; i++) {
      upper = upper || (strlen(upper_words[i]) == len && strncmp(word, upper_words[i], len) == 0);
    }
    if (word != name) {
      fputc(' ', out);
    }
    if (len == 4 && strncmp(word, "TEMP", 4) == 0) {
      fputs("Temperature", out);
    } else {
      for (size_t i = 0; i < len; i++) {
        fputc(upper || i == 0 ? word[i] : tolower((unsigned char)word[i]), out);
      }
    }
    word += len;
    if (*word == '_') {
      word++;
    }
  }
}

static const char *access_name(enum ct_access access) {
  switch (access) {
    case CT_R:
      return "R";
    case CT_RW:
      return "RW";
    case CT_NONE:
      break;
  }
  return "NONE";
}

static bool starts_with(const char *text, const char *prefix) {
  return strncmp(text, prefix, strlen(prefix)) == 0;
}

static bool single_bit(unsigned long value) {
  return value != 0 && (value & (value - 1)) == 0;
}

typedef struct {
  const char *name; /* without DXL_ */
  unsigned long value;
} constant_t;

#define AS_CONSTANT(macro) {#macro + 4, (unsigned long)(macro)},
static const constant_t protocol_constants[] = {DXL_PROTOCOL_CONSTANTS(AS_CONSTANT)};
#undef AS_CONSTANT
#define CONSTANT_COUNT (sizeof protocol_constants / sizeof protocol_constants[0])

static void write_module(FILE *out) {
  fputs("# Generated at build time by python/gen_ax12_table.c from firmware/core/ct_items.h,\n"
        "# dxl_table.h and dxl_protocol.h. Do not edit: change the firmware's headers and rebuild.\n"
        "\"\"\"The AX-12 control table and the Protocol 1.0 constants, as the firmware defines them.\n"
        "\n"
        "ITEMS: one Item per control-table item, in address order. name is the firmware's (CT_ITEMS),\n"
        "title the manual's spelling; access is \"R\", \"RW\" or \"NONE\" (reserved) per profile; min and\n"
        "max bound a written value (16-bit items as the 16-bit value); defaults per profile are the\n"
        "factory values (items filled at power-up or measured hold the firmware's placeholder).\n"
        "Each item's address is also a constant of its name (GOAL_POSITION = 30).\n"
        "\"\"\"\n"
        "from collections import namedtuple\n\n"
        "Item = namedtuple(\"Item\", \"name title addr size access_ax12 access_ax12a min max default_ax12 "
        "default_ax12a\")\n\n"
        "ITEMS = (\n",
        out);
#define WRITE_ITEM(name, addr, size, acc, acc_a, min, max, def, def_a)                                   \
  fprintf(out, "    Item(\"%s\", \"", #name);                                                           \
  write_title(out, #name);                                                                             \
  fprintf(out, "\", %u, %u, \"%s\", \"%s\", %lu, %lu, %lu, %lu),\n", (unsigned)(addr), (unsigned)(size), \
          access_name(acc), access_name(acc_a), (unsigned long)(min), (unsigned long)(max),             \
          (unsigned long)(def), (unsigned long)(def_a));
  CT_ITEMS(WRITE_ITEM)
#undef WRITE_ITEM
  fputs(")\nBY_ADDR = {item.addr: item for item in ITEMS}\n\n# The address of each item.\n", out);

#define WRITE_ADDRESS(name, addr, size, acc, acc_a, min, max, def, def_a) \
  fprintf(out, "%s = %u\n", #name, (unsigned)(addr));
  CT_ITEMS(WRITE_ADDRESS)
#undef WRITE_ADDRESS
  fprintf(out, "\nTABLE_SIZE = %u  # addresses 0..%u\nEEPROM_SIZE = %u  # addresses 0..%u persist\n\n",
          (unsigned)CT_SIZE, (unsigned)CT_SIZE - 1, (unsigned)CT_EEPROM_SIZE, (unsigned)CT_EEPROM_SIZE - 1);

  fputs("# dxl_protocol.h\n", out);
  for (size_t i = 0; i < CONSTANT_COUNT; i++) {
    fprintf(out, "%s = %lu  # 0x%02lX\n", protocol_constants[i].name, protocol_constants[i].value,
            protocol_constants[i].value);
  }
  fputs("\n# Instruction code -> name.\nINSTRUCTIONS = {\n", out);
  for (size_t i = 0; i < CONSTANT_COUNT; i++) {
    if (starts_with(protocol_constants[i].name, "INST_")) {
      fprintf(out, "    0x%02lX: \"%s\",\n", protocol_constants[i].value, protocol_constants[i].name + 5);
    }
  }
  fputs("}\n\n# Bit of the error byte -> name.\nERROR_BITS = {\n", out);
  for (size_t i = 0; i < CONSTANT_COUNT; i++) {
    if (starts_with(protocol_constants[i].name, "ERR_") && single_bit(protocol_constants[i].value)) {
      fprintf(out, "    0x%02lX: \"%s\",\n", protocol_constants[i].value, protocol_constants[i].name + 4);
    }
  }
  fputs("}\n", out);
}

int main(int argc, char **argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: %s OUT.py\n", argv[0]);
    return 2;
  }
  char partial[4096];
  if (snprintf(partial, sizeof partial, "%s.partial", argv[1]) >= (int)sizeof partial) {
    fprintf(stderr, "gen_ax12_table: path too long\n");
    return 1;
  }
  FILE *out = fopen(partial, "w");
  if (out == NULL) {
    perror(partial);
    return 1;
  }
  write_module(out);
  if (ferror(out) | fclose(out) || rename(partial, argv[1]) != 0) {
    perror(argv[1]);
    return 1;
  }
  return 0;
}
