/* The supply as the servo sees it at its connector: an EMF behind a source
 * resistance (pack, cable, connectors), feeding the H-bridge and the logic.
 * The logic (MCU, transceiver, regulator, LED) draws a constant standby current. */
#ifndef AX12_PLANT_SUPPLY_H
#define AX12_PLANT_SUPPLY_H

typedef struct {
    double source_v;      /* open-circuit supply voltage */
    double source_r_ohm;  /* source resistance */
    double standby_a;     /* logic current, drawn whatever the motor does (< 50 mA) */
} ax12_supply_params_t;

/* Current the servo draws: bridge input current (signed: negative when the
 * motor regenerates) plus the standby current. */
double ax12_supply_current_a(const ax12_supply_params_t *s, double bridge_a);

/* Voltage at the servo's connector while the bridge draws bridge_a. */
double ax12_supply_terminal_v(const ax12_supply_params_t *s, double bridge_a);

#endif
