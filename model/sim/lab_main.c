/* SPDX-License-Identifier: GPL-3.0-or-later */
/* ax12-lab: experiments on one emulated AX-12 (the firmware ELF in simavr driving the plant),
 * observed through the protocol as a user would, for the figures of docs/control.md.
 *
 *   ax12-lab KIND [options]      KIND: step | compliance | speed-load | heating | report
 *
 * Each KIND writes CSV (a header line, then rows) to stdout; `report` writes `key,value`
 * lines. Simulated time only, as fast as the host allows. Exit status: 0, 2 for bad usage,
 * 1 for failures (missing ELF, a servo that stops answering). */
#define _GNU_SOURCE
#include <getopt.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "elf_symbols.h"
#include "master.h"
#include "plant_options.h"
#include "servo.h"
#include "world.h"

#ifndef AX12_DEFAULT_FIRMWARE_DIR
#define AX12_DEFAULT_FIRMWARE_DIR "firmware"
#endif

#define EXIT_USAGE 2
#define RPM_PER_RAD_S (60.0 / (2.0 * M_PI))
#define DEG_PER_RAD (180.0 / M_PI)
#define SPEED_RPM_PER_UNIT 0.111

enum {
  A_RETURN_DELAY = 5, A_CW_LIMIT = 6, A_CCW_LIMIT = 8, A_HIGHEST_TEMP = 11, A_ALARM_LED = 17,
  A_ALARM_SHUTDOWN = 18, A_TORQUE_ENABLE = 24, A_CW_MARGIN = 26, A_CCW_MARGIN = 27, A_CW_SLOPE = 28,
  A_CCW_SLOPE = 29, A_GOAL = 30, A_MOVING_SPEED = 32, A_TORQUE_LIMIT = 34, A_PRESENT_POSITION = 36,
  A_PRESENT_SPEED = 38, A_PRESENT_LOAD = 40, A_PRESENT_VOLTAGE = 42, A_PRESENT_TEMPERATURE = 43,
  A_MOVING = 46, A_PUNCH = 48,
};

static const char usage_text[] =
    "usage: ax12-lab KIND [options]\n"
    "Experiments on one emulated AX-12 (firmware ELF in simavr + plant), read through the\n"
    "protocol; CSV on stdout.\n"
    "  step         Present Position after a goal step 412 -> 612, compliance slopes\n"
    "               8, 16, 17, 32, 64, 128 (columns slope,t_ms,goal,position,speed,load)\n"
    "  compliance   goal 512, margins 1, punch 32, a load torque swept -2..+2 N m; Present\n"
    "               Load vs error for slopes 16, 32, 64, 128\n"
    "               (slope,t_ms,load_nm,goal,position,error,present_load)\n"
    "  speed-load   wheel mode at full drive against constant loads, supplies 7, 9.6, 10, 12 V\n"
    "               (supply_v,load_nm,present_speed,protocol_rpm,plant_rpm,present_load)\n"
    "  heating      stall at full drive against a spring until the overheating alarm\n"
    "               (t_s,present_temperature,limit,case_c,winding_c,current_a,torque_enable)\n"
    "  report       key,value figures for scripts/model_report\n"
    "options:\n"
    "  --profile NAME      ax12 (default) or ax12a\n"
    "  --firmware-dir DIR  where ax12-<profile>-atmega88.elf is (default: the build's)\n"
    "  --elf PATH          another firmware ELF\n"
    "  --source-r OHM      supply source resistance (default 0: the supply at the connector;\n"
    "                      heating: 0.1 as ax12-emu serve)\n"
    "  -h, --help          this text\n"
    "World (defaults as ax12-emu serve; step/compliance/heating use --supply and --ambient):\n";

typedef struct {
  world_t *world;
  master_t *master;
  servo_t *servo;
} lab_t;

typedef struct {
  char elf[PATH_MAX];
  const char *profile;
  plant_options_t world;
  double source_r;
  bool source_r_given;
} lab_options_t;

static lab_options_t opts;

static void die(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));
static void die(const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  fputs("ax12-lab: ", stderr);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fputc('\n', stderr);
  exit(1);
}

static void run_ms(lab_t *lab, double ms) {
  world_run_until(lab->world, lab->world->now + (sim_cycles_t)llround(ms * 1000.0 * SIM_CYCLES_PER_US));
}

static double now_ms(const lab_t *lab) { return sim_cycles_to_us(lab->world->now) / 1000.0; }

/* One instruction packet to ID 1 and its status packet (reply_len bytes); returns the reply. */
static const uint8_t *request(lab_t *lab, uint8_t instruction, const uint8_t *params, size_t n, size_t reply_len) {
  static uint8_t reply[64];
  uint8_t packet[64] = {0xFF, 0xFF, 1, (uint8_t)(n + 2u), instruction};
  uint8_t sum = (uint8_t)(1u + n + 2u + instruction);
  for (size_t i = 0; i < n; i++) {
    packet[5 + i] = params[i];
    sum = (uint8_t)(sum + params[i]);
  }
  packet[5 + n] = (uint8_t)~sum;
  master_rx_clear(lab->master);
  const sim_cycles_t end = master_send(lab->master, packet, n + 6u);
  const sim_cycles_t limit = end + sim_ms(20);
  world_run_until(lab->world, end);
  while (master_rx_count(lab->master) < reply_len && lab->world->now < limit) {
    world_run_until(lab->world, lab->world->now + sim_us(20));
  }
  if (master_rx_values(lab->master, reply, sizeof(reply)) < reply_len || reply[2] != 1) {
    die("servo did not answer (instruction %u) at %.1f ms", instruction, now_ms(lab));
  }
  return reply;
}

static void write_u8(lab_t *lab, uint8_t addr, uint8_t v) {
  (void)request(lab, 0x03, (const uint8_t[]){addr, v}, 2, 6);
}

static void write_u16(lab_t *lab, uint8_t addr, uint16_t v) {
  (void)request(lab, 0x03, (const uint8_t[]){addr, (uint8_t)(v & 0xFFu), (uint8_t)(v >> 8)}, 3, 6);
}

static uint16_t read_n(lab_t *lab, uint8_t addr, uint8_t n) {
  const uint8_t *r = request(lab, 0x02, (const uint8_t[]){addr, n}, 2, 6u + n);
  return n == 1 ? r[5] : (uint16_t)(r[5] | (r[6] << 8));
}

static uint8_t read_u8(lab_t *lab, uint8_t addr) { return (uint8_t)read_n(lab, addr, 1); }
static int signed_register(uint16_t v) { return (v & 0x400u) ? -(int)(v & 0x3FFu) : (int)(v & 0x3FFu); }

/* Present Position, Speed and Load in one READ. */
typedef struct {
  int position, speed, load;
} present_t;

static present_t read_present(lab_t *lab) {
  const uint8_t *r = request(lab, 0x02, (const uint8_t[]){A_PRESENT_POSITION, 6}, 2, 12);
  return (present_t){.position = r[5] | (r[6] << 8),
                     .speed = signed_register((uint16_t)(r[7] | (r[8] << 8))),
                     .load = signed_register((uint16_t)(r[9] | (r[10] << 8)))};
}

static ax12_plant_t make_plant(double supply_v, double default_source_r) {
  plant_options_t w = opts.world;
  w.supply_v = supply_v;
  ax12_plant_t plant;
  plant_options_build(&w, &plant);
  plant.params.supply.source_r_ohm = opts.source_r_given ? opts.source_r : default_source_r;
  return plant;
}

/* A fresh servo (EEPROM in memory, factory defaults) on a fresh plant, booted, Return Delay
 * Time 0 (fast polling), no alarm shutdown unless the experiment sets one. */
static void lab_open(lab_t *lab, const ax12_plant_t *plant) {
  char err[512];
  eeprom_profile_t profile;
  if (!eeprom_profile_parse(opts.profile, &profile)) {
    die("unknown profile %s", opts.profile);
  }
  lab->world = world_create(opts.elf, "atmega88", profile, err, sizeof(err));
  if (!lab->world) {
    die("%s", err);
  }
  lab->servo = world_add_servo(lab->world, 1, 1, NULL, err, sizeof(err));
  if (!lab->servo) {
    die("%s", err);
  }
  servo_attach_plant(lab->servo, plant);
  lab->master = master_create(lab->world, 1000000.0);
  while (!servo_listening(lab->servo) && now_ms(lab) < 1000.0) {
    run_ms(lab, 1.0);
  }
  run_ms(lab, 500.0);
  write_u8(lab, A_RETURN_DELAY, 0);
  run_ms(lab, 10.0); /* the EEPROM write */
  write_u8(lab, A_ALARM_SHUTDOWN, 0);
}

static void lab_close(lab_t *lab) {
  master_destroy(lab->master);
  world_destroy(lab->world);
  memset(lab, 0, sizeof(*lab));
}

static void set_load(lab_t *lab, ax12_load_t load) { ax12_plant_set_load(&lab->servo->plant, &load); }

/* ---- step ---- */

static int kind_step(void) {
  static const uint8_t slopes[] = {8, 16, 17, 32, 64, 128};
  printf("slope,t_ms,goal,position,speed,load\n");
  for (size_t k = 0; k < sizeof(slopes); k++) {
    lab_t lab;
    const ax12_plant_t plant = make_plant(opts.world.supply_v, 0.1);
    lab_open(&lab, &plant);
    write_u8(&lab, A_CW_SLOPE, slopes[k]);
    write_u8(&lab, A_CCW_SLOPE, slopes[k]);
    write_u16(&lab, A_GOAL, 412);
    write_u8(&lab, A_TORQUE_ENABLE, 1);
    run_ms(&lab, 600.0);
    const double t0 = now_ms(&lab);
    write_u16(&lab, A_GOAL, 612);
    for (;;) {
      const double t = now_ms(&lab) - t0;
      if (t > 800.0) {
        break;
      }
      const present_t p = read_present(&lab);
      printf("%u,%.2f,612,%d,%d,%d\n", slopes[k], t, p.position, p.speed, p.load);
      run_ms(&lab, 2.0);
    }
    lab_close(&lab);
  }
  return 0;
}

/* ---- compliance ---- */

static int kind_compliance(void) {
  static const uint8_t slopes[] = {16, 32, 64, 128};
  const double peak_nm = 2.0, period_ms = 8000.0;
  printf("slope,t_ms,load_nm,goal,position,error,present_load\n");
  for (size_t k = 0; k < sizeof(slopes); k++) {
    lab_t lab;
    const ax12_plant_t plant = make_plant(opts.world.supply_v, 0.1);
    lab_open(&lab, &plant);
    write_u8(&lab, A_CW_MARGIN, 1);
    write_u8(&lab, A_CCW_MARGIN, 1);
    write_u8(&lab, A_CW_SLOPE, slopes[k]);
    write_u8(&lab, A_CCW_SLOPE, slopes[k]);
    write_u16(&lab, A_PUNCH, 32);
    write_u16(&lab, A_GOAL, 512);
    write_u8(&lab, A_TORQUE_ENABLE, 1);
    run_ms(&lab, 300.0);
    const double t0 = now_ms(&lab);
    for (;;) {
      const double t = now_ms(&lab) - t0;
      if (t > period_ms) {
        break;
      }
      /* Triangle 0 -> +peak -> -peak -> 0: the load pushes CCW, then CW. */
      const double x = t / period_ms;
      const double load = peak_nm * (x < 0.25 ? 4.0 * x : (x < 0.75 ? 2.0 - 4.0 * x : 4.0 * x - 4.0));
      set_load(&lab, ax12_load_constant(load));
      const present_t p = read_present(&lab);
      printf("%u,%.1f,%.4f,512,%d,%d,%d\n", slopes[k], t, load, p.position, 512 - p.position, p.load);
      run_ms(&lab, 10.0);
    }
    lab_close(&lab);
  }
  return 0;
}

/* ---- speed vs load ---- */

typedef struct {
  double present_speed; /* mean Present Speed, units (signed) */
  double protocol_rpm;  /* from Present Position over the window */
  double plant_rpm;     /* the shaft's mean speed over the window */
  double present_load;
  double current_a;     /* mean supply current */
} wheel_result_t;

/* Wheel mode at drive `drive` (bits 0..9, CCW) against a constant CW load from rest at 20 deg:
 * 300 ms to settle, then 300 ms of readings every 10 ms. */
static wheel_result_t wheel_run(double supply_v, double load_nm, uint16_t drive) {
  lab_t lab;
  ax12_plant_t plant = make_plant(supply_v, 0.0);
  ax12_plant_set_angle_rad(&plant, 20.0 / DEG_PER_RAD);
  lab_open(&lab, &plant);
  write_u16(&lab, A_CW_LIMIT, 0);
  write_u16(&lab, A_CCW_LIMIT, 0);
  write_u8(&lab, A_TORQUE_ENABLE, 1);
  set_load(&lab, ax12_load_constant(-load_nm));
  write_u16(&lab, A_MOVING_SPEED, drive);
  run_ms(&lab, 300.0);
  wheel_result_t r = {0};
  const double a0 = ax12_plant_angle_rad(&lab.servo->plant);
  const double t0 = now_ms(&lab);
  const present_t first = read_present(&lab);
  int n = 0;
  present_t p = first;
  for (int i = 0; i < 30; i++) {
    run_ms(&lab, 10.0);
    p = read_present(&lab);
    r.present_speed += p.speed;
    r.present_load += p.load;
    r.current_a += ax12_plant_supply_current_a(&lab.servo->plant);
    n++;
  }
  const double dt_s = (now_ms(&lab) - t0) / 1000.0;
  r.present_speed /= n;
  r.present_load /= n;
  r.current_a /= n;
  r.plant_rpm = (ax12_plant_angle_rad(&lab.servo->plant) - a0) / dt_s * RPM_PER_RAD_S;
  r.protocol_rpm = (p.position - first.position) * (300.0 / 1024.0) / 360.0 / dt_s * 60.0;
  lab_close(&lab);
  return r;
}

static int kind_speed_load(void) {
  static const double supplies[] = {7.0, 9.6, 10.0, 12.0};
  printf("supply_v,load_nm,present_speed,protocol_rpm,plant_rpm,present_load\n");
  for (size_t s = 0; s < sizeof(supplies) / sizeof(supplies[0]); s++) {
    for (double load = 0.0; load < 2.6; load += 0.1) {
      const wheel_result_t r = wheel_run(supplies[s], load, 1023);
      printf("%.1f,%.2f,%.1f,%.2f,%.2f,%.0f\n", supplies[s], load, r.present_speed, r.protocol_rpm, r.plant_rpm,
             r.present_load);
      fflush(stdout);
      if (r.plant_rpm <= 0.05) {
        break;
      }
    }
  }
  return 0;
}

/* ---- heating ---- */

static int kind_heating(void) {
  lab_t lab;
  const ax12_plant_t plant = make_plant(opts.world.supply_v, 0.1);
  lab_open(&lab, &plant);
  write_u8(&lab, A_ALARM_LED, 0x04);
  write_u8(&lab, A_ALARM_SHUTDOWN, 0x04); /* overheating only: the stall itself may go on */
  const uint8_t limit = read_u8(&lab, A_HIGHEST_TEMP);
  write_u16(&lab, A_GOAL, 1000);
  write_u8(&lab, A_TORQUE_ENABLE, 1);
  /* A stiff spring toward 150 deg: the servo winds it up a little and stalls at full drive. */
  set_load(&lab, ax12_load_spring(20.0, 150.0 / DEG_PER_RAD));
  printf("t_s,present_temperature,limit,case_c,winding_c,current_a,torque_enable\n");
  const double t0 = now_ms(&lab);
  double off_since = -1.0;
  for (;;) {
    const double t = (now_ms(&lab) - t0) / 1000.0;
    const int temp = read_u8(&lab, A_PRESENT_TEMPERATURE);
    const int enabled = read_u8(&lab, A_TORQUE_ENABLE);
    const ax12_plant_t *p = &lab.servo->plant;
    printf("%.1f,%d,%u,%.2f,%.2f,%.3f,%d\n", t, temp, limit, ax12_plant_case_temp_c(p), ax12_plant_winding_temp_c(p),
           ax12_plant_supply_current_a(p), enabled);
    if (!enabled && off_since < 0.0) {
      off_since = t;
    }
    if ((off_since >= 0.0 && t > off_since + 60.0) || t > 900.0) {
      break;
    }
    run_ms(&lab, 500.0);
  }
  lab_close(&lab);
  return 0;
}

/* ---- report ---- */

/* The largest CW load (N m) the servo still turns against from rest at full drive, 1 mN m. */
static double stall_torque(double supply_v) {
  double lo = 0.5, hi = 2.5;
  while (hi - lo > 0.002) {
    const double mid = 0.5 * (lo + hi);
    const wheel_result_t r = wheel_run(supply_v, mid, 1023);
    if (r.plant_rpm > 0.05 && r.protocol_rpm > 0.0) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return lo;
}

/* Joint mode cruise at Moving Speed `units` from 100 to 900: mean Present Speed and shaft rpm
 * over the middle of the travel. */
static void cruise(double supply_v, uint16_t units, double *present_units, double *plant_rpm) {
  lab_t lab;
  ax12_plant_t plant = make_plant(supply_v, 0.0);
  ax12_plant_set_angle_rad(&plant, 100.0 * 300.0 / 1024.0 / DEG_PER_RAD);
  lab_open(&lab, &plant);
  write_u16(&lab, A_MOVING_SPEED, units);
  write_u16(&lab, A_GOAL, 100);
  write_u8(&lab, A_TORQUE_ENABLE, 1);
  run_ms(&lab, 50.0);
  write_u16(&lab, A_GOAL, 900);
  double sum = 0.0, a0 = 0.0, t0 = 0.0;
  int n = 0;
  for (int i = 0; i < 3000; i++) {
    run_ms(&lab, 5.0);
    const present_t p = read_present(&lab);
    if (p.position >= 350 && p.position <= 650) {
      if (n == 0) {
        a0 = ax12_plant_angle_rad(&lab.servo->plant);
        t0 = now_ms(&lab);
      }
      sum += p.speed;
      n++;
    } else if (p.position > 650) {
      break;
    }
  }
  *present_units = n ? sum / n : 0.0;
  *plant_rpm = n ? (ax12_plant_angle_rad(&lab.servo->plant) - a0) / ((now_ms(&lab) - t0) / 1000.0) * RPM_PER_RAD_S : 0.0;
  lab_close(&lab);
}

/* Current at stall: full drive against a stiff spring (the shaft barely moves). Returns the
 * supply current (motor + logic); *motor_a the motor's. */
static double stall_current(double supply_v, double *motor_a) {
  lab_t lab;
  const ax12_plant_t plant = make_plant(supply_v, 0.0);
  lab_open(&lab, &plant);
  write_u16(&lab, A_GOAL, 1000);
  write_u8(&lab, A_TORQUE_ENABLE, 1);
  set_load(&lab, ax12_load_spring(50.0, 150.0 / DEG_PER_RAD));
  run_ms(&lab, 500.0);
  const double a = ax12_plant_supply_current_a(&lab.servo->plant);
  *motor_a = ax12_plant_motor_current_a(&lab.servo->plant);
  lab_close(&lab);
  return a;
}

static int kind_report(void) {
  printf("key,value\n");
  for (int v = 0; v < 2; v++) {
    const double volts = v == 0 ? 7.0 : 10.0;
    const wheel_result_t r = wheel_run(volts, 0.0, 1023);
    printf("noload_rpm_plant_%.0fv,%.3f\n", volts, r.plant_rpm);
    printf("noload_rpm_protocol_%.0fv,%.3f\n", volts, r.protocol_rpm);
    printf("noload_present_speed_%.0fv,%.1f\n", volts, r.present_speed);
    printf("noload_current_%.0fv,%.4f\n", volts, r.current_a);
    printf("stall_torque_%.0fv,%.4f\n", volts, stall_torque(volts));
    double motor_a;
    printf("stall_current_%.0fv,%.4f\n", volts, stall_current(volts, &motor_a));
    printf("stall_motor_current_%.0fv,%.4f\n", volts, motor_a);
    fflush(stdout);
  }
  static const uint16_t speeds[] = {50, 100, 200, 300, 400};
  for (size_t i = 0; i < sizeof(speeds) / sizeof(speeds[0]); i++) {
    double units, rpm;
    cruise(10.0, speeds[i], &units, &rpm);
    printf("cruise_%u_present_speed,%.1f\n", speeds[i], units);
    printf("cruise_%u_plant_rpm,%.3f\n", speeds[i], rpm);
  }
  /* Standby: torque off, at rest. */
  {
    lab_t lab;
    const ax12_plant_t plant = make_plant(9.6, 0.0);
    lab_open(&lab, &plant);
    run_ms(&lab, 100.0);
    printf("standby_current,%.4f\n", ax12_plant_supply_current_a(&lab.servo->plant));
    lab_close(&lab);
  }
  /* The control tick, measured on the MCU: from the entry of the Timer1 COMPB ISR (the 1 kHz
   * tick, tiny_isr.S) until the core sleeps again, i.e. the ISR plus the main loop's tick work
   * (ADC, control_tick, LED, packet finder poll). Over 2 s of joint-mode moves; first with
   * the bus idle, then with the master reading Present* every 2 ms (packet work that falls
   * inside a tick's busy time counts too). */
  uint32_t entry;
  if (!elf_symbol_address(opts.elf, "__vector_12", &entry)) {
    die("no __vector_12 (TIMER1_COMPB) in %s", opts.elf);
  }
  for (int polled = 0; polled < 2; polled++) {
    lab_t lab;
    const ax12_plant_t plant = make_plant(9.6, 0.0);
    lab_open(&lab, &plant);
    write_u8(&lab, A_TORQUE_ENABLE, 1);
    write_u16(&lab, A_GOAL, 900);
    run_ms(&lab, 1.0);
    servo_set_probe(lab.servo, entry);
    const double t0 = now_ms(&lab);
    bool back = false;
    while (now_ms(&lab) - t0 < 2000.0) {
      if (polled) {
        (void)read_present(&lab);
      }
      run_ms(&lab, 2.0);
      if (!back && now_ms(&lab) - t0 > 1000.0) {
        if (!polled) { /* the bus-idle figure leaves this packet's work out */
          lab.servo->probe_pc = 0;
          lab.servo->probe_inside = false;
        }
        write_u16(&lab, A_GOAL, 100);
        lab.servo->probe_pc = entry;
        back = true;
      }
    }
    const servo_t *s = lab.servo;
    const char *tag = polled ? "polled" : "idle";
    printf("tick_calls_%s,%llu\n", tag, (unsigned long long)s->probe_calls);
    printf("tick_cycles_max_%s,%llu\n", tag, (unsigned long long)s->probe_max_cycles);
    printf("tick_cycles_mean_%s,%.1f\n", tag,
           s->probe_calls ? (double)s->probe_total_cycles / (double)s->probe_calls : 0.0);
    lab_close(&lab);
  }
  return 0;
}

int main(int argc, char **argv) {
  if (argc < 2 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0) {
    FILE *out = argc < 2 ? stderr : stdout;
    fputs(usage_text, out);
    fputs(plant_options_help, out);
    return argc < 2 ? EXIT_USAGE : 0;
  }
  const char *kind = argv[1];
  int (*fn)(void) = NULL;
  if (strcmp(kind, "step") == 0) {
    fn = kind_step;
  } else if (strcmp(kind, "compliance") == 0) {
    fn = kind_compliance;
  } else if (strcmp(kind, "speed-load") == 0) {
    fn = kind_speed_load;
  } else if (strcmp(kind, "heating") == 0) {
    fn = kind_heating;
  } else if (strcmp(kind, "report") == 0) {
    fn = kind_report;
  } else {
    fprintf(stderr, "ax12-lab: unknown KIND '%s' (see ax12-lab --help)\n", kind);
    return EXIT_USAGE;
  }
  enum { OPT_PROFILE = 256, OPT_FIRMWARE_DIR, OPT_ELF, OPT_SOURCE_R };
  static const struct option long_options[] = {
      {"profile", required_argument, NULL, OPT_PROFILE},
      {"firmware-dir", required_argument, NULL, OPT_FIRMWARE_DIR},
      {"elf", required_argument, NULL, OPT_ELF},
      {"source-r", required_argument, NULL, OPT_SOURCE_R},
      PLANT_LONG_OPTIONS,
      {"help", no_argument, NULL, 'h'},
      {NULL, 0, NULL, 0},
  };
  opts.profile = "ax12";
  plant_options_default(&opts.world);
  const char *firmware_dir = AX12_DEFAULT_FIRMWARE_DIR;
  char err[256];
  opterr = 0;
  optind = 2;
  int c;
  while ((c = getopt_long(argc, argv, ":h", long_options, NULL)) != -1) {
    switch (c) {
    case OPT_PROFILE:
      if (strcmp(optarg, "ax12") != 0 && strcmp(optarg, "ax12a") != 0) {
        fprintf(stderr, "ax12-lab: unknown profile '%s' (ax12 or ax12a)\n", optarg);
        return EXIT_USAGE;
      }
      opts.profile = optarg;
      break;
    case OPT_FIRMWARE_DIR:
      firmware_dir = optarg;
      break;
    case OPT_ELF:
      snprintf(opts.elf, sizeof(opts.elf), "%s", optarg);
      break;
    case OPT_SOURCE_R: {
      char *end = NULL;
      opts.source_r = strtod(optarg, &end);
      if (!end || *end || end == optarg || !(opts.source_r >= 0.0 && opts.source_r <= 10.0)) {
        fprintf(stderr, "ax12-lab: bad --source-r '%s': ohms, 0..10\n", optarg);
        return EXIT_USAGE;
      }
      opts.source_r_given = true;
      break;
    }
    case 'h':
      fputs(usage_text, stdout);
      fputs(plant_options_help, stdout);
      return 0;
    case ':':
      fprintf(stderr, "ax12-lab: option %s needs a value\n", argv[optind - 1]);
      return EXIT_USAGE;
    default:
      if (plant_option_name(c) != NULL) {
        if (!plant_options_parse(&opts.world, plant_option_name(c), optarg, err, sizeof(err))) {
          fprintf(stderr, "ax12-lab: %s\n", err);
          return EXIT_USAGE;
        }
        break;
      }
      fprintf(stderr, "ax12-lab: unknown option '%s'\n", argv[optind - 1]);
      return EXIT_USAGE;
    }
  }
  if (optind < argc) {
    fprintf(stderr, "ax12-lab: unexpected argument '%s'\n", argv[optind]);
    return EXIT_USAGE;
  }
  if (!opts.elf[0]) {
    snprintf(opts.elf, sizeof(opts.elf), "%s/ax12-%s-atmega88.elf", firmware_dir, opts.profile);
  }
  if (access(opts.elf, R_OK) != 0) {
    fprintf(stderr, "ax12-lab: firmware ELF %s not readable (build the firmware, or pass --elf)\n", opts.elf);
    return 1;
  }
  return fn();
}
