/* The 254:1 spur gear train between motor and output, seen from the output.
 *
 * Losses are friction at the output: a load-independent Coulomb part, a viscous
 * part and a part proportional to the torque the teeth carry, (1 - efficiency)
 * times the drive torque (motor torque x ratio). While the motor drives, the
 * output receives efficiency x drive; when the load back-drives the motor the
 * same friction opposes the load, so the gears hold more than they lift.
 * Static friction (breakaway) is the Coulomb part raised to static_nm. */
#ifndef AX12_PLANT_GEARBOX_H
#define AX12_PLANT_GEARBOX_H

typedef struct {
    double ratio;             /* motor turns per output turn */
    double efficiency;        /* share of the drive torque that reaches the output, 0..1 */
    double coulomb_nm;        /* sliding friction at the output, independent of load */
    double static_nm;         /* breakaway friction at the output, >= coulomb_nm */
    double viscous_nm_s_rad;  /* viscous friction at the output, N*m per rad/s */
    double inertia_kg_m2;     /* output side: last gear, shaft and horn */
} ax12_gearbox_params_t;

/* Output-side torque for a motor shaft torque (lossless: motor torque x ratio). */
double ax12_gearbox_drive_nm(const ax12_gearbox_params_t *g, double motor_nm);

/* Output speed to motor shaft speed. */
double ax12_gearbox_motor_rad_s(const ax12_gearbox_params_t *g, double output_rad_s);

/* Share of the drive torque left at the output after the load-dependent gear
 * friction, for a drive of sign drive_sign (-1, 0, +1) and motion in direction
 * dir_sign (-1, +1): efficiency when the drive pushes the motion, 2 - efficiency
 * when the motion back-drives the motor (the friction then adds to the drive). */
double ax12_gearbox_drive_share(const ax12_gearbox_params_t *g, double drive_sign,
                                double dir_sign);

/* Magnitude of the friction at the output while sliding, carrying drive_nm. */
double ax12_gearbox_sliding_friction_nm(const ax12_gearbox_params_t *g, double drive_nm);

/* Magnitude of the friction at the output that must be overcome to start moving. */
double ax12_gearbox_breakaway_friction_nm(const ax12_gearbox_params_t *g, double drive_nm);

/* Inertia at the output: output side plus the motor rotor seen through the ratio. */
double ax12_gearbox_output_inertia_kg_m2(const ax12_gearbox_params_t *g,
                                         double motor_inertia_kg_m2);

#endif
