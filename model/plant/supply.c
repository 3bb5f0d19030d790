#include "supply.h"

double ax12_supply_current_a(const ax12_supply_params_t *s, double bridge_a)
{
    return bridge_a + s->standby_a;
}

double ax12_supply_terminal_v(const ax12_supply_params_t *s, double bridge_a)
{
    return s->source_v - s->source_r_ohm * ax12_supply_current_a(s, bridge_a);
}
