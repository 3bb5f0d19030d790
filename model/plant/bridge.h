/* The H-bridge between the supply and the motor, averaged over the 62.5 kHz PWM period: which
 * path the motor current takes (docs/plant.md "Electrical model").
 *
 * Driven (duty != 0): the motor sees duty x the supply through the on-resistance of one high
 * and one low MOSFET, current flowing either way (slow-decay PWM: a back-EMF above
 * duty x supply brakes and returns current to the supply).
 *
 * Coast (duty exactly 0: both inputs low, every MOSFET off, as the firmware leaves the bridge
 * with torque off or a drive of 0): the terminals float while the back-EMF stays within the
 * supply plus two body-diode drops. Beyond that, the body diode of one high-side MOSFET and of
 * the other leg's low-side MOSFET conduct: the motor returns current to the supply and brakes,
 * and the terminals are clamped to supply + 2 diode drops. No path drives the motor.
 *
 * A path is linear in the back-EMF: motor current I = (path_v - emf) / (winding + r_ohm). */
#ifndef AX12_PLANT_BRIDGE_H
#define AX12_PLANT_BRIDGE_H

#include <stdbool.h>

typedef struct {
    double on_r_ohm;  /* one high-side plus one low-side MOSFET, conducting */
    double diode_v;   /* forward drop of one MOSFET body diode at the motor's current */
} ax12_bridge_params_t;

typedef struct {
    bool open;            /* no path: no current whatever the back-EMF */
    bool diodes;          /* the body diodes conduct (coast); the current only brakes */
    double path_v;        /* voltage the path sets against the back-EMF, signed like duty */
    double r_ohm;         /* loop resistance outside the winding */
    double supply_share;  /* bridge input current (drawn from the supply) per motor current */
    double drop_v;        /* across the conducting diodes (their heat: drop_v x |I|) */
} ax12_bridge_path_t;

/* The path at duty (-1..+1; exactly 0 = coast) for a motor back-EMF of emf_v, with the supply
 * at supply_v at the connector when the bridge draws nothing and behind source_r_ohm. */
ax12_bridge_path_t ax12_bridge_path(const ax12_bridge_params_t *b, double duty, double supply_v,
                                    double source_r_ohm, double emf_v);

/* Back-EMF magnitude above which a coasting bridge's body diodes conduct. */
double ax12_bridge_clamp_v(const ax12_bridge_params_t *b, double supply_v);

/* Heat in the bridge, W, while motor_a flows through path. */
double ax12_bridge_loss_w(const ax12_bridge_params_t *b, const ax12_bridge_path_t *path,
                          double motor_a);

#endif
