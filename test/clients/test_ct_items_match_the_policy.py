"""The control table as the firmware defines it (ax12_table, generated from
firmware/core/ct_items.h and dxl_protocol.h at build time) against the table as the policy
states it (ax12_policy, written by hand): item by item, so a wrong address, size, access, range,
default or name in ct_items.h fails here and names the item. Needs no emulator."""
import pytest

import ax12_policy as P
import ax12_table as T

ACCESS = {"R": P.R, "RW": P.RW, "NONE": P.NONE}  # the generated spelling -> the policy's


def test_the_firmware_has_an_item_at_each_address_of_the_policy_and_no_other():
    assert [item.addr for item in T.ITEMS] == [item.addr for item in P.TABLE]


def test_the_items_cover_the_table_without_gaps():
    ends = [item.addr + item.size for item in T.ITEMS]
    assert [item.addr for item in T.ITEMS] == [0] + ends[:-1]
    assert ends[-1] == T.TABLE_SIZE == P.LAST_ADDR + 1
    assert T.EEPROM_SIZE == P.EEPROM_END


def _as_the_policy_states(item, policy):
    """The generated item's facts, in the policy's terms, where the policy states them."""
    facts = {"title": "reserved" if policy.name.startswith("reserved") else policy.name,
             "size": policy.size, "access ax12": policy.access,
             "access ax12a": P.ACCESS_AX12A.get(policy.addr, policy.access)}
    got = {"title": item.title, "size": item.size, "access ax12": ACCESS[item.access_ax12],
           "access ax12a": ACCESS[item.access_ax12a]}
    if policy.lo is not None:
        facts["range"], got["range"] = (policy.lo, policy.hi), (item.min, item.max)
    for profile, default in (("ax12", item.default_ax12), ("ax12a", item.default_ax12a)):
        if P.default(policy, profile) is not P.RUNTIME:
            facts["default " + profile], got["default " + profile] = P.default(policy, profile), default
    return got, facts


@pytest.mark.parametrize("policy", P.TABLE, ids=[f"{item.addr} {item.name}" for item in P.TABLE])
def test_the_item_is_the_one_the_policy_states(policy):
    item = T.BY_ADDR.get(policy.addr)
    assert item is not None, f"ct_items.h has no item at address {policy.addr} ({policy.name})"
    got, facts = _as_the_policy_states(item, policy)
    assert got == facts, f"{item.name} (address {item.addr}) in ct_items.h"
    assert getattr(T, item.name) == policy.addr


def test_the_error_bits_are_the_policys():
    assert sorted(T.ERROR_BITS) == sorted(P.ERROR_BITS)
    for bit, name in T.ERROR_BITS.items():
        assert name.replace("_", " ").lower() in P.ERROR_BITS[bit].lower(), (bit, name, P.ERROR_BITS[bit])
    assert T.ERR_CONDITIONS == sum(P.ERROR_CONDITIONS)
    assert T.ERR_EVENTS == sum(set(P.ERROR_BITS) - P.ERROR_CONDITIONS)
