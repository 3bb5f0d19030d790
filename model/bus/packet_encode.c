/* SPDX-License-Identifier: MIT */
#include "packet_encode.h"

#include <stdio.h>

uint8_t packet_checksum(const uint8_t *id_to_last_param, size_t count) {
  unsigned sum = 0;
  for (size_t i = 0; i < count; i++) {
    sum += id_to_last_param[i];
  }
  return (uint8_t)(~sum & 0xFFu);
}

size_t packet_encode(uint8_t *out, uint8_t id, uint8_t code, const uint8_t *params, size_t count) {
  out[0] = 0xFF;
  out[1] = 0xFF;
  out[2] = id;
  out[3] = (uint8_t)(count + 2u);
  out[4] = code;
  for (size_t i = 0; i < count; i++) {
    out[5 + i] = params[i];
  }
  out[5 + count] = packet_checksum(&out[2], count + 3u);
  return count + PACKET_OVERHEAD;
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
