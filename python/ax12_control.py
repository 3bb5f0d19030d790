# SPDX-License-Identifier: GPL-3.0-or-later
"""A client of a running `ax12-emu serve`'s control socket (docs/dashboard.md "The control
socket"): one JSON object a line each way. Used by `ax12 world`, the dashboard and the tests.
"""
import json
import os
import select
import socket

DEFAULT_SOCKET_NAME = "control.sock"


def default_state_dir():
    """The emulator's default state directory: $XDG_STATE_HOME/ax12 when that is an absolute
    path, else ~/.local/state/ax12 (as model/host/state_dir.c)."""
    xdg = os.environ.get("XDG_STATE_HOME", "")
    if xdg.startswith("/"):
        return os.path.join(xdg, "ax12")
    return os.path.join(os.path.expanduser("~"), ".local", "state", "ax12")


def default_socket_path(state_dir=None):
    return os.path.join(state_dir or default_state_dir(), DEFAULT_SOCKET_NAME)


class ControlError(Exception):
    """The emulator refused a request ({"ok": false}), or the socket failed."""


class Control:
    """A connection to the control socket. request() sends one request and returns its reply;
    events pushed meanwhile (telemetry) are kept in self.events."""

    def __init__(self, path, timeout_s=5.0):
        self.path = path
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.settimeout(timeout_s)
        try:
            self.sock.connect(path)
        except OSError as e:
            self.sock.close()
            raise ControlError("cannot reach the emulator's control socket %s: %s "
                               "(is `scripts/ax12 serve` running with this state directory, or "
                               "give its --control path)" % (path, e.strerror or e)) from None
        self.buffer = b""
        self.events = []

    def close(self):
        self.sock.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def read_line(self):
        """The next line from the emulator, as a dict."""
        while b"\n" not in self.buffer:
            try:
                chunk = self.sock.recv(65536)
            except socket.timeout:
                raise ControlError("the emulator did not answer in time") from None
            if not chunk:
                raise ControlError("the emulator closed the control socket")
            self.buffer += chunk
        line, self.buffer = self.buffer.split(b"\n", 1)
        return json.loads(line)

    def next_event(self, timeout_s):
        """The next event pushed to a subscriber (one kept while a request waited first), or
        None when none comes within timeout_s."""
        if self.events:
            return self.events.pop(0)
        if b"\n" not in self.buffer:
            readable, _, _ = select.select([self.sock], [], [], max(timeout_s, 0.0))
            if not readable:
                return None
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ControlError("the emulator closed the control socket")
            self.buffer += chunk
            if b"\n" not in self.buffer:
                return None
        return self.read_line()

    def request(self, op, **fields):
        """Sends {"op": op, ...}; returns the reply; ControlError with the emulator's message
        when it says no."""
        message = dict(fields, op=op)
        self.sock.sendall(json.dumps(message).encode() + b"\n")
        while True:
            reply = self.read_line()
            if "event" in reply:
                self.events.append(reply)
                continue
            if not reply.get("ok"):
                raise ControlError(reply.get("error", "refused"))
            return reply
