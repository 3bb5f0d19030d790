/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "sim_log.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include <sim_avr.h>

static int max_level = LOG_ERROR;

static void sim_logger(avr_t *avr, const int level, const char *format, va_list ap) {
  (void)avr;
  if (level > max_level || level == LOG_NONE) {
    return;
  }
  fputs("simavr: ", stderr);
  vfprintf(stderr, format, ap);
}

void sim_log_install(void) {
  static int installed;
  if (installed) {
    return;
  }
  installed = 1;
  const char *env = getenv("SIM_LOG_LEVEL");
  if (env && *env) {
    max_level = atoi(env);
  }
  avr_global_logger_set(sim_logger);
}
