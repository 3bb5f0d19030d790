#include "packet_build.h"

#include <stdio.h>

size_t packet_build(uint8_t *out, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count) {
  out[0] = 0xFF;
  out[1] = 0xFF;
  out[2] = id;
  out[3] = (uint8_t)(count + 2u);
  out[4] = instruction;
  unsigned sum = id + out[3] + instruction;
  for (size_t i = 0; i < count; i++) {
    out[5 + i] = params[i];
    sum += params[i];
  }
  out[5 + count] = (uint8_t)(~sum & 0xFFu);
  return count + 6u;
}

const char *packet_hex(const uint8_t *bytes, size_t count, char *text, size_t text_len) {
  size_t used = 0;
  text[0] = '\0';
  if (count == 0) {
    snprintf(text, text_len, "(none)");
    return text;
  }
  for (size_t i = 0; i < count && used + 4 < text_len; i++) {
    used += (size_t)snprintf(text + used, text_len - used, i == 0 ? "%02X" : " %02X", bytes[i]);
  }
  return text;
}
