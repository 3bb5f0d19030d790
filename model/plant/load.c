#include "load.h"

#include <math.h>

ax12_load_t ax12_load_none(void)
{
    ax12_load_t l = {.kind = AX12_LOAD_NONE};
    return l;
}

ax12_load_t ax12_load_constant(double torque_nm)
{
    ax12_load_t l = {.kind = AX12_LOAD_CONSTANT, .torque_nm = torque_nm};
    return l;
}

ax12_load_t ax12_load_spring(double spring_nm_rad, double rest_rad)
{
    ax12_load_t l = {.kind = AX12_LOAD_SPRING, .spring_nm_rad = spring_nm_rad,
                     .rest_rad = rest_rad};
    return l;
}

ax12_load_t ax12_load_arm(double mass_kg, double arm_m, double horizontal_rad)
{
    ax12_load_t l = {.kind = AX12_LOAD_ARM, .mass_kg = mass_kg, .arm_m = arm_m,
                     .horizontal_rad = horizontal_rad};
    return l;
}

double ax12_load_torque_nm(const ax12_load_t *l, double angle_rad)
{
    switch (l->kind) {
    case AX12_LOAD_CONSTANT:
        return l->torque_nm;
    case AX12_LOAD_SPRING:
        return -l->spring_nm_rad * (angle_rad - l->rest_rad);
    case AX12_LOAD_ARM:
        return -l->mass_kg * AX12_GRAVITY_M_S2 * l->arm_m * cos(angle_rad - l->horizontal_rad);
    case AX12_LOAD_NONE:
    default:
        return 0.0;
    }
}

double ax12_load_stiffness_nm_rad(const ax12_load_t *l, double angle_rad)
{
    double k = 0.0;
    switch (l->kind) {
    case AX12_LOAD_SPRING:
        k = l->spring_nm_rad;
        break;
    case AX12_LOAD_ARM:
        k = -l->mass_kg * AX12_GRAVITY_M_S2 * l->arm_m * sin(angle_rad - l->horizontal_rad);
        break;
    case AX12_LOAD_NONE:
    case AX12_LOAD_CONSTANT:
    default:
        break;
    }
    return k > 0.0 ? k : 0.0;
}

double ax12_load_inertia_kg_m2(const ax12_load_t *l)
{
    double j = l->inertia_kg_m2;
    if (l->kind == AX12_LOAD_ARM) {
        j += l->mass_kg * l->arm_m * l->arm_m;
    }
    return j;
}
