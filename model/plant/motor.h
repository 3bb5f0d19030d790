/* DC motor of one AX-12, averaged over the 62.5 kHz PWM period.
 *
 * SI units throughout. The torque constant and the back-EMF constant are one
 * number (N*m/A == V*s/rad). The winding inductance is not modelled: its time
 * constant (L/R, about 50 us) is far below the mechanical one (about 20 ms) and
 * below any step the simulation takes, so the current follows the averaged
 * voltage at once (docs/plant.md). */
#ifndef AX12_PLANT_MOTOR_H
#define AX12_PLANT_MOTOR_H

typedef struct {
    double kt_nm_a;         /* torque constant = back-EMF constant (V*s/rad) */
    double r_25c_ohm;       /* winding resistance at 25 degC */
    double r_tempco_per_c;  /* relative resistance change per degC (copper: 0.00393) */
    double i_noload_a;      /* brush and bearing friction, as the current that balances it */
    double inertia_kg_m2;   /* rotor, on the motor shaft */
} ax12_motor_params_t;

/* Winding resistance at winding temperature winding_c. */
double ax12_motor_resistance_ohm(const ax12_motor_params_t *m, double winding_c);

/* Back-EMF at motor shaft speed motor_rad_s (signed). */
double ax12_motor_backemf_v(const ax12_motor_params_t *m, double motor_rad_s);

/* Electromagnetic torque on the motor shaft for a (signed) winding current. */
double ax12_motor_torque_nm(const ax12_motor_params_t *m, double current_a);

/* Magnitude of the brush and bearing friction torque on the motor shaft. */
double ax12_motor_friction_nm(const ax12_motor_params_t *m);

/* Average winding current with v_avg_v applied across the terminals, the shaft
 * turning at motor_rad_s and r_loop_ohm in the whole loop (winding + bridge + source). */
double ax12_motor_current_a(const ax12_motor_params_t *m, double v_avg_v,
                            double motor_rad_s, double r_loop_ohm);

#endif
