# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 conform`: what a record's packet does, and the packet rewritten for the device
under test (docs/conform.md "The cases").

A record's servo has its own ID and baud; the device has others. remap() rewrites a packet's IDs
(header, SYNC_WRITE slices, an ID written or read as data) and Baud Rate values (written or read)
and recomputes its checksum, off by as much as the record's was, so a packet sent with a wrong
checksum keeps one. Framing and checksums are python/ax12_packets.py's.
"""
import ax12_packets as P
import ax12_table as T


def _sync_slices(params):
    """The slices (ID, data...) of SYNC_WRITE parameters, or None when they do not divide."""
    if len(params) < 2 or params[1] == 0 or (len(params) - 2) % (params[1] + 1):
        return None
    size = params[1]
    return [params[2 + k * (size + 1):2 + (k + 1) * (size + 1)] for k in range((len(params) - 2) // (size + 1))]


def _code_and_params(data, f):
    body = P.body_of(data, f)
    return body[2], list(body[3:])


def writes_of(data):
    """What a well-formed instruction packet would write: [(ID or None, address, value)], ID None
    for WRITE and REG_WRITE, each slice's ID for SYNC_WRITE; "reset" for RESET."""
    f = P.frame(data)
    if f is None:
        return []
    code, params = _code_and_params(data, f)
    if code in (T.INST_WRITE, T.INST_REG_WRITE) and len(params) >= 2:
        return [(None, params[0] + i, v) for i, v in enumerate(params[1:])]
    if code == T.INST_SYNC_WRITE:
        out = []
        for s in _sync_slices(params) or ():
            out += [(s[0], params[0] + i, v) for i, v in enumerate(s[1:])]
        return out
    if code == T.INST_RESET:
        return "reset"
    return []


def read_window(data):
    """(first address, count) of a well-formed READ, else None."""
    f = P.frame(data)
    if f is None:
        return None
    code, params = _code_and_params(data, f)
    if code == T.INST_READ and len(params) == 2:
        return params[0], params[1]
    return None


def ids_in(data):
    """IDs a packet carries: its header's, SYNC_WRITE's slices', an ID written as data."""
    f = P.frame(data)
    if f is None:
        ident = P.header_ident(data)
        return set() if ident is None else {ident}
    out = {f.ident}
    w = writes_of(data)
    if w != "reset":
        for sid, addr, value in w:
            if sid is not None:
                out.add(sid)
            if addr == T.ID:
                out.add(value)
    return out


def remap(data, idmap, baudmap, window=None):
    """The packet's bytes with IDs and Baud Rate values mapped, its checksum recomputed off by as
    much as the original's was. window: the (start, length) of the READ a status packet
    answers. None when the bytes are not one packet and need a mapping that is not the identity."""
    data = list(data)
    f = P.frame(data)
    if f is None:
        ident = P.header_ident(data)
        if ident is not None and idmap.get(ident, ident) != ident:
            return None
        return data
    body = list(P.body_of(data, f))
    delta = (data[f.end - 1] - P.checksum(body)) & 0xFF
    code, params = body[2], body[3:]

    def at(addr, value):
        if addr == T.ID:
            return idmap.get(value, value)
        if addr == T.BAUD_RATE:
            return baudmap.get(value, value)
        return value

    if window is not None:
        if len(params) == window[1]:
            params = [at(window[0] + i, v) for i, v in enumerate(params)]
    elif code in (T.INST_WRITE, T.INST_REG_WRITE) and len(params) >= 2:
        params = params[:1] + [at(params[0] + i, v) for i, v in enumerate(params[1:])]
    elif code == T.INST_SYNC_WRITE and _sync_slices(params) is not None:
        out = params[:2]
        for s in _sync_slices(params):
            out += [idmap.get(s[0], s[0])] + [at(params[0] + i, v) for i, v in enumerate(s[1:])]
        params = out
    new = [idmap.get(f.ident, f.ident), body[1], code] + params
    return data[:f.start + f.header] + new + [(P.checksum(new) + delta) & 0xFF]
