/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "eeprom_store.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "dxl_image.h"
#include "state_file.h"

bool eeprom_profile_parse(const char *name, eeprom_profile_t *profile) {
  if (strcmp(name, "ax12") == 0) {
    *profile = EEPROM_PROFILE_AX12;
    return true;
  }
  if (strcmp(name, "ax12a") == 0) {
    *profile = EEPROM_PROFILE_AX12A;
    return true;
  }
  return false;
}

const char *eeprom_profile_name(eeprom_profile_t profile) {
  return profile == EEPROM_PROFILE_AX12A ? "ax12a" : "ax12";
}

/* The factory EEPROM area of either profile, from the one control-table definition
 * (ct_items.h; the same values ct_load_factory_defaults() gives a core built for that
 * profile). The host links no profile-specific core, so both columns are read here. */
static void factory_eeprom_area(uint8_t area[CT_EEPROM_SIZE], eeprom_profile_t profile) {
  memset(area, 0, CT_EEPROM_SIZE);
#define SIM_X_FACTORY(name, addr, size, acc, acc_a, min, max, def, def_a)                 \
  if ((addr) < CT_EEPROM_SIZE) {                                                      \
    const unsigned value = profile == EEPROM_PROFILE_AX12A ? (unsigned)(def_a) : (unsigned)(def); \
    area[(addr)] = (uint8_t)(value & 0xFFu);                                          \
    if ((size) == 2) {                                                                \
      area[(addr) + 1] = (uint8_t)(value >> 8);                                       \
    }                                                                                 \
  }
  CT_ITEMS(SIM_X_FACTORY)
#undef SIM_X_FACTORY
}

void eeprom_store_seed(uint8_t *eeprom, size_t size, eeprom_profile_t profile, uint8_t id, uint8_t baud_reg) {
  memset(eeprom, 0xFF, size);
  uint8_t area[CT_EEPROM_SIZE];
  factory_eeprom_area(area, profile);
  area[CT_ADDR_ID] = id;
  area[CT_ADDR_BAUD_RATE] = baud_reg;
  uint8_t image[DXL_IMAGE_BYTES];
  dxl_image_build(image, area);
  memcpy(eeprom, image, size < DXL_IMAGE_BYTES ? size : DXL_IMAGE_BYTES);
}

bool eeprom_store_image_fields(const uint8_t *eeprom, size_t size, uint8_t *id, uint8_t *baud_reg) {
  const uint8_t *const settings = size < DXL_IMAGE_BYTES ? NULL : dxl_image_settings(eeprom);
  if (settings == NULL) {
    return false;
  }
  if (id) {
    *id = settings[CT_ADDR_ID];
  }
  if (baud_reg) {
    *baud_reg = settings[CT_ADDR_BAUD_RATE];
  }
  return true;
}

static bool slot_blank(const uint8_t *slot) {
  for (size_t i = 0; i < DXL_IMAGE_SLOT_BYTES; i++) {
    if (slot[i] != 0xFFu) {
      return false;
    }
  }
  return true;
}

bool eeprom_store_cut_slot(const uint8_t *eeprom, size_t size) {
  if (size < DXL_IMAGE_BYTES) {
    return false;
  }
  unsigned valid = 0;
  bool damaged = false;
  for (uint8_t slot = 0; slot < DXL_IMAGE_SLOTS; slot++) {
    const uint8_t *const bytes = &eeprom[dxl_image_slot_offset(slot)];
    if (dxl_image_slot_is_valid(bytes)) {
      valid++;
    } else if (!slot_blank(bytes)) {
      damaged = true;
    }
  }
  return valid == 1u && damaged;
}

int eeprom_store_load(const char *path, uint8_t *eeprom, size_t size, char *err, size_t err_len) {
  memset(eeprom, 0xFF, size);
  off_t file_size;
  const int fd = state_file_open(path, &file_size, err, err_len);
  if (fd < 0) {
    return fd == STATE_FILE_ABSENT ? 0 : -1;
  }
  size_t got = 0;
  while (got < size) {
    const ssize_t n = read(fd, eeprom + got, size - got);
    if (n < 0 && errno == EINTR) {
      continue;
    }
    if (n < 0) {
      snprintf(err, err_len, "cannot read %s: %s", path, strerror(errno));
      close(fd);
      return -1;
    }
    if (n == 0) {
      break;
    }
    got += (size_t)n;
  }
  close(fd);
  return 1;
}

int eeprom_store_save(const char *path, const uint8_t *eeprom, size_t size, char *err, size_t err_len) {
  return state_file_replace(path, eeprom, size, err, err_len);
}

bool eeprom_store_file_fits(const char *path, size_t size, char *why, size_t why_len) {
  struct stat st;
  if (stat(path, &st) != 0) {
    return true; /* no file: the emulator seeds one */
  }
  if ((size_t)st.st_size != size) {
    snprintf(why, why_len, "%lld bytes, not the %zu of this MCU's EEPROM", (long long)st.st_size, size);
    return false;
  }
  return true;
}

int eeprom_store_set_aside(const char *path, char *aside, size_t aside_len) {
  for (unsigned n = 1; n < 1000u; n++) {
    snprintf(aside, aside_len, "%s.invalid-%u", path, n);
    struct stat st;
    if (lstat(aside, &st) != 0 && errno == ENOENT) {
      return rename(path, aside);
    }
  }
  errno = EEXIST;
  return -1;
}

void eeprom_store_path(char *out, size_t out_len, const char *dir, unsigned n) {
  snprintf(out, out_len, "%s/servo-%u.eeprom", dir, n);
}
