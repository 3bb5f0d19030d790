/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "flash_store.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "state_file.h"

static const char MAGIC[8] = {'A', 'X', '1', '2', 'F', 'L', 'S', 'H'};

uint64_t flash_store_identity(const uint8_t *flash, size_t size) {
  uint64_t hash = 0xcbf29ce484222325ull; /* FNV-1a's offset basis and prime */
  for (size_t i = 0; i < size; i++) {
    hash = (hash ^ flash[i]) * 0x100000001b3ull;
  }
  return hash;
}

static void put_le(uint8_t *out, uint64_t value, unsigned bytes) {
  for (unsigned i = 0; i < bytes; i++) {
    out[i] = (uint8_t)(value >> (8u * i));
  }
}

static uint64_t get_le(const uint8_t *in, unsigned bytes) {
  uint64_t value = 0;
  for (unsigned i = 0; i < bytes; i++) {
    value |= (uint64_t)in[i] << (8u * i);
  }
  return value;
}

static int read_all(int fd, uint8_t *out, size_t size) {
  size_t got = 0;
  while (got < size) {
    const ssize_t n = read(fd, out + got, size - got);
    if (n < 0 && errno == EINTR) {
      continue;
    }
    if (n <= 0) {
      return -1;
    }
    got += (size_t)n;
  }
  return 0;
}

int flash_store_load(const char *path, uint64_t identity, uint8_t *flash, size_t size, char *err, size_t err_len) {
  off_t file_size;
  const int fd = state_file_open(path, &file_size, err, err_len);
  if (fd < 0) {
    return fd == STATE_FILE_ABSENT ? FLASH_STORE_ABSENT : -1;
  }
  uint8_t header[FLASH_STORE_HEADER_BYTES];
  if ((size_t)file_size != FLASH_STORE_HEADER_BYTES + size || read_all(fd, header, sizeof header) != 0 ||
      memcmp(header, MAGIC, sizeof MAGIC) != 0 || get_le(header + 8, 4) != size ||
      get_le(header + 12, 4) != FLASH_STORE_VERSION) {
    close(fd);
    return FLASH_STORE_INVALID;
  }
  if (get_le(header + 16, 8) != identity) {
    close(fd);
    return FLASH_STORE_OTHER_BUILD;
  }
  uint8_t *bytes = malloc(size);
  if (!bytes) {
    snprintf(err, err_len, "out of memory");
    close(fd);
    return -1;
  }
  const int r = read_all(fd, bytes, size);
  close(fd);
  if (r != 0) {
    free(bytes);
    return FLASH_STORE_INVALID; /* cut short while being read */
  }
  memcpy(flash, bytes, size);
  free(bytes);
  return FLASH_STORE_LOADED;
}

int flash_store_save(const char *path, uint64_t identity, const uint8_t *flash, size_t size, char *err,
                     size_t err_len) {
  uint8_t *file = malloc(FLASH_STORE_HEADER_BYTES + size);
  if (!file) {
    snprintf(err, err_len, "out of memory");
    return -1;
  }
  memcpy(file, MAGIC, sizeof MAGIC);
  put_le(file + 8, size, 4);
  put_le(file + 12, FLASH_STORE_VERSION, 4);
  put_le(file + 16, identity, 8);
  memcpy(file + FLASH_STORE_HEADER_BYTES, flash, size);
  const int r = state_file_replace(path, file, FLASH_STORE_HEADER_BYTES + size, err, err_len);
  free(file);
  return r;
}

void flash_store_path_beside(char *out, size_t out_len, const char *eeprom_path) {
  static const char suffix[] = ".eeprom";
  const size_t len = strlen(eeprom_path);
  const size_t suffix_len = sizeof suffix - 1;
  if (len >= suffix_len && strcmp(eeprom_path + len - suffix_len, suffix) == 0) {
    snprintf(out, out_len, "%.*s.flash", (int)(len - suffix_len), eeprom_path);
  } else {
    snprintf(out, out_len, "%s.flash", eeprom_path);
  }
}
