/* One AX-12 servo as physics: supply -> H-bridge -> DC motor -> 254:1 gears ->
 * output shaft with a load, plus the three analog signals the MCU reads
 * (docs/hardware.md) and the heat. Pure C11, no simavr; SI units in names.
 *
 * Sign convention: positive duty, torque, speed and angle are counter-clockwise
 * (CCW), the direction in which the position count rises. Output angle 0 is the
 * clockwise end of the pot track (0 mV, count 0); 150 deg is the centre (count 512).
 * The angle is not wrapped: the shaft may turn endlessly; the pot wraps it.
 *
 * Execution: one ax12_plant_t per servo, no globals, no allocation. A step costs
 * a few tens of ns per internal sub-step (max_substep_s, 250 us by default). */
#ifndef AX12_PLANT_PLANT_H
#define AX12_PLANT_PLANT_H

#include <stdbool.h>

#include "bridge.h"
#include "gearbox.h"
#include "load.h"
#include "motor.h"
#include "pot.h"
#include "supply.h"
#include "thermal.h"

typedef struct {
    ax12_motor_params_t motor;
    ax12_gearbox_params_t gearbox;
    ax12_pot_params_t pot;
    ax12_supply_params_t supply;  /* source_v is the world's supply, settable */
    ax12_thermal_params_t thermal;
    ax12_bridge_params_t bridge;  /* H-bridge: on-resistance, body diodes */
    double ambient_c;             /* the world's air temperature, settable */
    double max_substep_s;         /* internal integration step bound */
} ax12_plant_params_t;

typedef struct {
    double angle_rad;             /* output angle, unwrapped */
    double speed_rad_s;           /* output speed */
    bool stuck;                   /* output held by static friction (speed exactly 0) */
    double duty;                  /* last duty applied, -1..+1; exactly 0 = coast */
    double motor_current_a;       /* average winding current, + = CCW torque */
    double supply_current_a;      /* drawn from the supply: bridge input + standby */
    double terminal_v;            /* at the servo's connector */
    ax12_thermal_state_t thermal;
} ax12_plant_state_t;

typedef struct {
    ax12_plant_params_t params;
    ax12_load_t load;
    ax12_plant_state_t state;
} ax12_plant_t;

/* The calibrated AX-12 (docs/plant.md): 9.6 V supply through 0.1 ohm, 25 degC. */
ax12_plant_params_t ax12_plant_params_default(void);

/* At rest at 150 deg, no load, both thermal nodes at ambient, duty 0.
 * params NULL = ax12_plant_params_default(). */
void ax12_plant_init(ax12_plant_t *plant, const ax12_plant_params_t *params);

/* ax12_plant_init() with the default parameters but the supply: source_v behind source_r_ohm. */
void ax12_plant_init_on_supply(ax12_plant_t *plant, double source_v, double source_r_ohm);

/* Advance by dt_s (any value up to 1 ms is accurate; larger is stable) with the
 * H-bridge at duty (clamped to -1..+1; NaN = 0). The motor sees duty x terminal
 * voltage on average; duty exactly 0 is coast: every MOSFET off, the terminals free
 * until the back-EMF exceeds the supply plus two body-diode drops, which then brake
 * the motor and return current to the supply (bridge.h). dt_s <= 0 changes nothing. */
void ax12_plant_step(ax12_plant_t *plant, double duty, double dt_s);

/* The world. A new supply voltage shows at once in the readings; a new air
 * temperature is followed through the thermal model. */
void ax12_plant_set_supply_v(ax12_plant_t *plant, double source_v);
void ax12_plant_set_ambient_c(ax12_plant_t *plant, double ambient_c);
void ax12_plant_set_load(ax12_plant_t *plant, const ax12_load_t *load);
/* Places the output at angle_rad, at rest. */
void ax12_plant_set_angle_rad(ax12_plant_t *plant, double angle_rad);

/* Readings after the last step or setter. */
double ax12_plant_angle_rad(const ax12_plant_t *plant);
double ax12_plant_angle_deg(const ax12_plant_t *plant);
double ax12_plant_speed_rad_s(const ax12_plant_t *plant);
double ax12_plant_motor_current_a(const ax12_plant_t *plant);
double ax12_plant_supply_current_a(const ax12_plant_t *plant);
double ax12_plant_terminal_v(const ax12_plant_t *plant);
double ax12_plant_winding_temp_c(const ax12_plant_t *plant);
double ax12_plant_case_temp_c(const ax12_plant_t *plant);

/* The shaft driven by someone else (a rigid-body engine: plant_joint.h). The drive at the
 * output, N x Kt x winding current, at duty and output speed speed_rad_s, before the gears'
 * losses (ax12_gearbox_drive_share, the friction of plant_joint.h); *slope_nm_s_rad (when not
 * NULL) its fall per rad/s there, the back-EMF's damping of the bridge's path at that speed
 * (0 while the coasting bridge is open). */
double ax12_plant_output_drive_nm(const ax12_plant_t *plant, double duty, double speed_rad_s,
                                  double *slope_nm_s_rad);
/* Steps the electrics and the heat by dt_s at duty (as ax12_plant_step: the gears' friction
 * heat included) with the shaft turning at state.speed_rad_s, which this does not change: the
 * mechanics are not integrated. Returns the drive at that speed, as
 * ax12_plant_output_drive_nm gives it, and its slope in *slope_nm_s_rad (when not NULL).
 * dt_s <= 0 steps nothing. */
double ax12_plant_step_electrics(ax12_plant_t *plant, double duty, double dt_s, double *slope_nm_s_rad);

/* ADC inputs, mV, each clamped to the 0..5000 mV the pin can see. */
double ax12_plant_pot_mv(const ax12_plant_t *plant);          /* ADC0 */
double ax12_plant_supply_sense_mv(const ax12_plant_t *plant); /* ADC1: terminal V / 5 */
double ax12_plant_temp_sense_mv(const ax12_plant_t *plant);   /* ADC2: 500 mV + 10 mV/degC of the case */

#endif
