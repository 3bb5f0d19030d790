/* The output shaft as a hinge joint of a rigid-body engine (MuJoCo: model/robot,
 * docs/robot.md). The engine integrates the shaft's motion with the links on it; the plant
 * keeps the motor (the drive from the duty, its back-EMF, the supply, the heat) and the pot.
 *
 * Counted once: what the plant integrates itself for a free shaft (ax12_plant_step) belongs to
 * the joint here, set in the engine from these functions, as the plant's substep has it:
 *   armature      the gearbox's output inertia with the rotor's reflected inertia (N^2 J_rotor)
 *   a turning joint (|speed| >= AX12_JOINT_AT_REST_RAD_S): the drive times the share the
 *                 gears leave of it (efficiency when it pushes the motion, 2 - efficiency when
 *                 the motion back-drives it: ax12_gearbox_drive_share), its back-EMF slope times
 *                 the same share as damping with the viscous friction, and the sliding friction
 *                 (brush through the ratio, gear Coulomb) as frictionloss
 *   a joint at rest: the whole drive, its slope and the viscous friction as damping, and the
 *                 breakaway friction (brush, gear static, (1 - efficiency) x |drive|) as
 *                 frictionloss: what holds it until the torque passes it
 * The sign of the motion and of the drive are taken at the step's start, as the plant's
 * substep takes them; damping in the engine is implicit, so the step is stable at 1 ms.
 *
 * One interval between two engine steps: the plant is stepped with ax12_plant_joint_step
 * (every 100 us in the emulator) at the speed the engine gave last, its pot advancing at that
 * speed, and the drive is summed; ax12_plant_joint_take turns the sum into the joint's terms
 * for the engine's step (the drive linear in the joint's speed, the slope as damping, so the
 * engine integrates the back-EMF implicitly); after the step ax12_plant_joint_set_motion
 * gives the plant the joint's angle and speed. SI units; angles as in plant.h (output angle,
 * 150 deg at the pot's centre). */
#ifndef AX12_PLANT_PLANT_JOINT_H
#define AX12_PLANT_PLANT_JOINT_H

#include "plant.h"

/* Below this speed a joint is at rest: held by breakaway friction (MuJoCo's friction is a soft
 * constraint: a joint it holds keeps a speed of about 1e-6 rad/s). 0.001 rad/s takes 5 s to
 * move the pot by a count. */
#define AX12_JOINT_AT_REST_RAD_S 0.001

/* The drive over an interval, summed by ax12_plant_joint_step. */
typedef struct {
    double applied_nm_s;          /* integral of drive(w) + slope x w: the drive's value at speed 0 of its tangent */
    double slope_nm_s2_rad;       /* integral of the slope -d(drive)/d(speed), >= 0: the back-EMF's damping */
    double span_s;
} ax12_joint_drive_t;

/* The joint's terms for one engine step: the torque applied to the joint is
 * applied_nm - damping_nm_s_rad x speed, less the friction up to frictionloss_nm. */
typedef struct {
    double applied_nm;
    double damping_nm_s_rad;
    double frictionloss_nm;
} ax12_joint_torque_t;

/* Steps the plant's electrics and heat by dt_s at duty with the shaft at its last speed
 * (the pot's angle advancing at it) and adds the interval's drive to *acc. */
void ax12_plant_joint_step(ax12_plant_t *plant, double duty, double dt_s, ax12_joint_drive_t *acc);

/* The mean of *acc as the joint's terms (the plant's duty at speed now when *acc is empty);
 * clears *acc. */
ax12_joint_torque_t ax12_plant_joint_take(const ax12_plant_t *plant, ax12_joint_drive_t *acc);

/* The joint's angle and speed after the engine's step, as the output's. */
void ax12_plant_joint_set_motion(ax12_plant_t *plant, double angle_rad, double speed_rad_s);

/* The joint's armature: the gearbox's output inertia and the rotor through the ratio. */
double ax12_plant_joint_armature_kg_m2(const ax12_plant_t *plant);

/* The friction at the output while it turns carrying drive_nm (brush, gear Coulomb and the
 * efficiency's (1 - efficiency) x |drive|): with the drive, what the plant's substep makes of
 * it (drive + this = (2 - efficiency) x drive + Coulomb when the load back-drives the motor). */
double ax12_plant_joint_frictionloss_nm(const ax12_plant_t *plant, double drive_nm);
/* The friction that holds the output at rest against a drive of drive_nm (brush, gear static,
 * efficiency). */
double ax12_plant_joint_holding_friction_nm(const ax12_plant_t *plant, double drive_nm);

/* The joint's viscous friction (the back-EMF's damping comes with each step's terms). */
double ax12_plant_joint_viscous_nm_s_rad(const ax12_plant_t *plant);

#endif
