/* SPDX-License-Identifier: GPL-3.0-or-later */
/* ax12-emu: emulated AX-12 servos on a pseudo-terminal (docs/emulator.md).
 *
 *   ax12-emu serve [options]
 *
 * stdout carries exactly one line, `ready: <device>`, once a client can connect; everything
 * else goes to stderr. Exit status: 0 after SIGINT / SIGTERM / SIGHUP (state persisted),
 * 2 for bad command-line input, 1 for other failures. */
#include <stdio.h>
#include <string.h>

#include "emu_options.h"
#include "emu_serve.h"

int main(int argc, char **argv) {
  if (argc < 2) {
    emu_print_usage(stderr);
    return EMU_EXIT_USAGE;
  }
  if (strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "help") == 0) {
    emu_print_usage(stdout);
    return 0;
  }
  if (strcmp(argv[1], "serve") == 0) {
    serve_options_t o;
    const int parsed = emu_parse_serve_options(argc - 1, argv + 1, &o);
    return parsed >= 0 ? parsed : emu_serve(&o);
  }
  fprintf(stderr, "ax12-emu: unknown command '%s' (see ax12-emu --help)\n", argv[1]);
  return EMU_EXIT_USAGE;
}
