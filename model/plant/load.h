/* External load on the output shaft. Angles and torques are output-side and
 * signed like the output: positive = counter-clockwise = position count rising. */
#ifndef AX12_PLANT_LOAD_H
#define AX12_PLANT_LOAD_H

#define AX12_GRAVITY_M_S2 9.80665

typedef enum {
    AX12_LOAD_NONE = 0,
    AX12_LOAD_CONSTANT,  /* torque_nm, whatever the angle */
    AX12_LOAD_SPRING,    /* -spring_nm_rad * (angle - rest_rad) */
    AX12_LOAD_ARM        /* point mass_kg at arm_m under gravity */
} ax12_load_kind_t;

typedef struct {
    ax12_load_kind_t kind;
    double torque_nm;       /* CONSTANT: torque on the output, + = CCW */
    double spring_nm_rad;   /* SPRING: stiffness, >= 0 */
    double rest_rad;        /* SPRING: output angle of zero torque */
    double mass_kg;         /* ARM: point mass */
    double arm_m;           /* ARM: distance of the mass from the axis */
    double horizontal_rad;  /* ARM: output angle at which the arm is horizontal and
                               turning CCW lifts it; hanging straight down is
                               horizontal_rad - pi/2 */
    double inertia_kg_m2;   /* extra rigid inertia on the output (any kind) */
} ax12_load_t;

ax12_load_t ax12_load_none(void);
ax12_load_t ax12_load_constant(double torque_nm);
ax12_load_t ax12_load_spring(double spring_nm_rad, double rest_rad);
ax12_load_t ax12_load_arm(double mass_kg, double arm_m, double horizontal_rad);

/* Torque the load applies to the output at output angle angle_rad. */
double ax12_load_torque_nm(const ax12_load_t *l, double angle_rad);

/* Restoring stiffness -d(torque)/d(angle) at angle_rad, clamped to >= 0: used
 * only to integrate stable equilibria implicitly. */
double ax12_load_stiffness_nm_rad(const ax12_load_t *l, double angle_rad);

/* Inertia the load adds to the output. */
double ax12_load_inertia_kg_m2(const ax12_load_t *l);

#endif
