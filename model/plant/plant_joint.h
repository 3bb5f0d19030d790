/* The output shaft as a hinge joint of a rigid-body engine (MuJoCo: model/robot,
 * docs/robot.md). The engine integrates the shaft's motion with the links on it; the plant
 * keeps the motor (the drive from the duty, its back-EMF, the supply, the heat) and the pot.
 *
 * Counted once: what the plant integrates itself for a free shaft (ax12_plant_step) belongs to
 * the joint here, set in the engine from these functions:
 *   armature      the gearbox's output inertia with the rotor's reflected inertia (N^2 J_rotor)
 *   damping       the gearbox's viscous friction, plus the back-EMF's slope of each step
 *   frictionloss  the brush friction through the ratio, the gearbox's Coulomb friction and
 *                 its efficiency as friction, (1 - efficiency) x |drive|
 * The engine's frictionloss is one value: it holds as much as it slides (the plant's
 * breakaway friction is 0.010 N m more than its sliding friction).
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

/* The drive over an interval, summed by ax12_plant_joint_step. */
typedef struct {
    double applied_nm_s;          /* integral of drive(w) + slope x w: the drive's value at speed 0 of its tangent */
    double slope_nm_s2_rad;       /* integral of the slope -d(drive)/d(speed), >= 0: the back-EMF's damping */
    double abs_drive_nm_s;        /* integral of |drive(w)| */
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

/* The joint's friction while the output carries drive_nm (brush, gear Coulomb, efficiency). */
double ax12_plant_joint_frictionloss_nm(const ax12_plant_t *plant, double drive_nm);

/* The joint's viscous friction (the back-EMF's damping comes with each step's terms). */
double ax12_plant_joint_viscous_nm_s_rad(const ax12_plant_t *plant);

#endif
