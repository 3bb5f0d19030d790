/* Heat in one servo: two lumped nodes.
 *
 *   winding --r_winding_case--> case --r_case_ambient--> ambient
 *
 * The winding node (armature copper and iron) takes the I^2 R of the winding;
 * the case node (motor can, gears, PCB, housing) takes the bridge and logic
 * losses and the friction heat. The temperature sensor on the PCB reads the
 * case node. Integrated with backward Euler: stable for any step. */
#ifndef AX12_PLANT_THERMAL_H
#define AX12_PLANT_THERMAL_H

typedef struct {
    double winding_j_c;         /* heat capacity of the winding node, J/K */
    double case_j_c;            /* heat capacity of the case node, J/K */
    double winding_case_c_w;    /* thermal resistance winding -> case, K/W */
    double case_ambient_c_w;    /* thermal resistance case -> ambient, K/W */
} ax12_thermal_params_t;

typedef struct {
    double winding_c;
    double case_c;
} ax12_thermal_state_t;

/* Both nodes at ambient_c. */
void ax12_thermal_init(ax12_thermal_state_t *t, double ambient_c);

/* Advance by dt_s with winding_w into the winding node and case_w into the case node. */
void ax12_thermal_step(const ax12_thermal_params_t *p, ax12_thermal_state_t *t,
                       double winding_w, double case_w, double ambient_c, double dt_s);

#endif
