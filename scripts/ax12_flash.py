#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""scripts/ax12 flash: writes a new application to one servo over the Dynamixel bus, through
its bootloader (docs/bootloader.md, section "Updating over the bus").

Steps: the file is read and checked (python/ax12_app_image.py) before anything is sent, against
its own part's facts too (a part with a bootloader, its application area); INFO to the servo (an
application is asked into its bootloader with instruction 0x0A "BOOT"); the image checked
against the part INFO names; the pages written (each tried again, up to --retries more times,
after a lost or garbled answer or a read-back error): the record's page first with the record
erased, the image, the record's page last with the record; every written page read back and
compared (unless --no-verify); GO; then the application must answer a PING and a READ of its
Model Number and Firmware Version. A servo this command asked into its bootloader and then
refused (another part, another bootloader version, Ctrl-C) before the first page is sent GO, so
it runs its application again. Progress and steps on stderr, the result on stdout; every error
one line on stderr, a port lost mid-update (the adapter unplugged, the emulator gone) included.

Exit status: 0 done; 1 the servo, the port or the transfer failed (the message says where); 2 a
bad file, a file for another part or too large, bad arguments, or a port that cannot be opened.
"""
import argparse
import os
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "python"))

EXIT_DONE, EXIT_SERVO, EXIT_BAD_INPUT = 0, 1, 2
ANSWER_TIMEOUT_S = 0.3      # per request; the bootloader answers at once, the pty may hold bytes
ENTER_TIMEOUT_S = 1.5       # from the application's answer to BOOT to the bootloader's to INFO
BOOT_AGAIN_S = 0.1          # BOOT again while the application still answers (a store was under way)
START_TIMEOUT_S = 2.0       # from GO to the application's answer to PING


class BadInput(Exception):
    """Exit 2: a bad file or argument, or a port that cannot be opened."""


def arguments(argv):
    ap = argparse.ArgumentParser(
        prog="scripts/ax12 flash",
        description="Write an application (Intel HEX) to one servo over the Dynamixel bus, through "
                    "its bootloader (docs/bootloader.md \"Updating over the bus\").")
    ap.add_argument("firmware", metavar="FIRMWARE.hex",
                    help="the application's Intel HEX, e.g. build/firmware/ax12-ax12-atmega328p.hex")
    ap.add_argument("--port", required=True, metavar="DEV", help="the bus's serial port (a pty of ax12-emu too)")
    ap.add_argument("--id", required=True, type=int, metavar="N", dest="ident", help="the servo's ID, 0..253")
    ap.add_argument("--baud", type=int, default=1000000, metavar="BPS",
                    help="the servo's bit rate (default 1000000)")
    ap.add_argument("--retries", type=int, default=3, metavar="K",
                    help="how many more times a request is sent after a lost or garbled answer, a page "
                         "after a read-back error, and GO while the servo is still in its bootloader "
                         "(default 3)")
    ap.add_argument("--no-verify", action="store_true", help="do not read the pages back after writing")
    ap.add_argument("--build", default=os.path.join(REPO, "build"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if not 0 <= args.ident <= 253:
        ap.error(f"--id {args.ident}: a servo's ID is 0..253")
    if args.baud <= 0:
        ap.error(f"--baud {args.baud}: a bit rate is positive")
    if args.retries < 0:
        ap.error(f"--retries {args.retries}: 0 or more")
    return args


class TransferError(Exception):
    """Exit 1: what was written does not read back."""


def say(text):
    print(f"ax12 flash: {text}", file=sys.stderr, flush=True)


class Progress:
    """A bar on stderr when it is a terminal, redrawn in place; otherwise one line at the start
    and one at the end."""

    WIDTH = 40

    def __init__(self, label, total, stream=sys.stderr):
        self.label, self.total, self.stream = label, total, stream
        self.live = stream.isatty()
        if not self.live:
            print(f"ax12 flash: {label}: {total} pages", file=stream, flush=True)
        self.update(0)

    def update(self, done):
        if self.live:
            filled = self.WIDTH * done // max(self.total, 1)
            self.stream.write(f"\r{self.label} [{'#' * filled}{'.' * (self.WIDTH - filled)}] {done}/{self.total}")
            self.stream.flush()

    def finish(self):
        if self.live:
            self.stream.write("\n")
        else:
            print(f"ax12 flash: {self.label}: done", file=self.stream, flush=True)


def open_serial(device, baud):
    import serial  # pyserial, from the project's venv (scripts/setup)
    try:
        return serial.Serial(device, baud, timeout=0.05, write_timeout=2)
    except (serial.SerialException, OSError, ValueError) as error:
        raise BadInput(f"cannot open {device} at {baud} bps: {error}")


def enter_bootloader(client, baud, boot, asked=None):
    """The BootInfo of the servo's bootloader, asking a running application into it first
    (then asked(), before the request goes out)."""
    answer = client.info(attempts=2)
    if boot.parse_info(answer):
        return boot.parse_info(answer)
    if answer is None:
        # An application with Status Return Level 0 answers only PING.
        if client.ping(attempts=2) is None:
            raise boot.BootError(f"servo {client.ident} does not answer at {baud} bps")
    elif not (answer.code & boot.ERR_INSTRUCTION and not answer.params):
        raise boot.BootError(f"servo {client.ident} answers INFO with error 0x{answer.code:02X} and "
                             f"{len(answer.params)} parameters: neither an application nor the bootloader")
    say(f"servo {client.ident} runs its application: asking it into the bootloader")
    if asked is not None:
        asked()
    deadline = time.monotonic() + ENTER_TIMEOUT_S
    while time.monotonic() < deadline:
        reply = client.request_bootloader()
        if reply is not None and reply.code & boot.ERR_INSTRUCTION:
            raise boot.BootError(f"servo {client.ident}'s application does not know instruction 0x0A \"BOOT\": "
                                 f"it has no bootloader to enter (flash it over ISP: scripts/ax12 flash-isp)")
        asked = time.monotonic()
        while time.monotonic() - asked < BOOT_AGAIN_S:
            answer = client.info()
            info = boot.parse_info(answer)
            if info:
                return info
            if answer is not None and answer.code & boot.ERR_INSTRUCTION:
                break  # the application still runs: it stores its settings first; asked again
    raise boot.BootError(f"servo {client.ident} did not answer as a bootloader within {ENTER_TIMEOUT_S:g} s "
                         f"of the request to enter it")


def write_image(client, image, mcu, verify, begun=None):
    """The pages of the update in their order (ax12_app_image.update_pages: the record erased
    first, written last; begun() before the first), then (verify) every page as it must read
    now."""
    plan = image.update_pages(mcu)
    if begun is not None:
        begun()
    progress = Progress("writing", len(plan))
    for done, (address, data) in enumerate(plan, 1):
        client.page(address, data)
        progress.update(done)
    progress.finish()
    if not verify:
        return
    expected = dict(plan)  # the record's page as written last
    progress = Progress("verifying", len(expected))
    for done, (address, data) in enumerate(sorted(expected.items()), 1):
        got = client.read_page(address, len(data))
        if got != data:
            first = next(i for i in range(len(data)) if got[i] != data[i])
            raise TransferError(f"verify: flash 0x{address + first:04X} reads 0x{got[first]:02X}, "
                                f"written 0x{data[first]:02X}")
        progress.update(done)
    progress.finish()


STILL_IN_BOOTLOADER = "still in the bootloader"


def application_answer(client, boot):
    """(Model Number, Firmware Version) of the application once it answers PING and a READ of
    them; (None, None) when it answers PING but never the READ (Status Return Level 0);
    STILL_IN_BOOTLOADER when the READ is answered with Instruction Error."""
    deadline = time.monotonic() + START_TIMEOUT_S
    while client.ping() is None:
        if time.monotonic() > deadline:
            raise boot.BootError(f"servo {client.ident} does not answer PING after GO")
    while time.monotonic() <= deadline:
        answer = client.application_identity()
        if answer is not None and answer.code & boot.ERR_INSTRUCTION:
            return STILL_IN_BOOTLOADER
        if answer is not None and not answer.code and len(answer.params) == boot.IDENTITY_BYTES:
            return answer.params[0] | (answer.params[1] << 8), answer.params[2]
    if boot.parse_info(client.info()):
        return STILL_IN_BOOTLOADER
    return None, None


def start_application(client, boot, retries):
    """GO, then what application_answer finds; GO is sent again (up to retries more times)
    while the servo is still in its bootloader, as after a lost GO."""
    for _ in range(retries + 1):
        client.go()
        result = application_answer(client, boot)
        if result != STILL_IN_BOOTLOADER:
            return result
    raise boot.BootError(f"servo {client.ident} is still in its bootloader after GO ({retries + 1} attempts): "
                         f"the application in its flash is not valid")


def restart_application(client, boot):
    """GO to a servo this command asked into its bootloader and wrote nothing to, and the
    application's answer: one line on stderr either way. False when it does not run again."""
    try:
        client.go()
        started = application_answer(client, boot) != STILL_IN_BOOTLOADER
    except boot.BootError:
        started = False
    say(f"servo {client.ident}: nothing written; " + (
        "its application runs again" if started else
        "sent GO, but it did not start its application: it answers as a bootloader at its ID; run the command again"))
    return started


def port_errors():
    """What a serial port raises when it goes away under a transfer: the device unplugged, the
    emulator behind a pty gone (pyserial's SerialException, OSError from a write, termios.error
    from a flush)."""
    import termios

    import serial
    return (serial.SerialException, OSError, termios.error)


def main(argv=None, open_port=open_serial):
    args = arguments(argv)
    import ax12_build
    ax12_build.ensure(args.build)
    import ax12_app_image as image_module
    import ax12_boot_client as boot
    import ax12_fuses
    from ax12_servo_port import ServoPort

    port = None
    # The servo's state as far as this command moved it: asked into its bootloader by it, and
    # whether the first page went out (it erases the record: from then on the application is not
    # valid until the record's page is written last).
    moved = {"asked": False, "begun": False}
    client = None

    def leave_refused(code):
        """A refusal after this command asked the servo in and before the first page: GO first."""
        if moved["asked"] and not moved["begun"] and client is not None:
            if not restart_application(client, boot):
                return EXIT_SERVO
        return code

    try:
        image = image_module.load(args.firmware)
        image.check_flashable()
        port = open_port(args.port, args.baud)
        client = boot.BootClient(ServoPort(port, args.ident, ANSWER_TIMEOUT_S), args.retries)
        info = enter_bootloader(client, args.baud, boot, asked=lambda: moved.update(asked=True))
        mcu = image_module.mcu_of_signature(info.signature)
        if mcu is None:
            raise boot.BootError(f"servo {args.ident}'s bootloader reports the signature "
                                 f"{info.signature.hex(' ').upper()}, no part this tool knows")
        if info.version != boot.VERSION:
            raise boot.BootError(f"servo {args.ident}'s bootloader is version {info.version}; this tool "
                                 f"writes to version {boot.VERSION} (docs/bootloader.md)")
        part = ax12_fuses.MCUS[mcu]
        say(f"servo {args.ident}: bootloader {info.version} on an {mcu}, page {part.page_bytes} B, "
            f"{image_module.area_text(mcu)}")
        image.check_target(mcu)
        write_image(client, image, mcu, not args.no_verify, begun=lambda: moved.update(begun=True))
        model, version = start_application(client, boot, args.retries)
    except (image_module.ImageError, BadInput) as error:
        say(str(error))
        return leave_refused(EXIT_BAD_INPUT)
    except (boot.BootError, TransferError) as error:
        say(str(error))
        return leave_refused(EXIT_SERVO)
    except KeyboardInterrupt:
        if moved["begun"]:
            say("interrupted: a servo stopped once its first page (the record erased) was written stays in its "
                "bootloader; run the command again")
            return EXIT_SERVO
        say("interrupted")
        return leave_refused(EXIT_SERVO)
    except port_errors() as error:
        if sys.stderr.isatty():
            sys.stderr.write("\n")  # past a progress bar
        say(f"lost the port {args.port} ({error}); " + (
            f"servo {args.ident} stays in its bootloader: run the command again once the bus is back"
            if moved["begun"] else "nothing was written"))
        return EXIT_SERVO
    finally:
        if port is not None:
            try:
                port.close()
            except port_errors():
                pass
    pages = len(image.update_pages(mcu))
    started = (f"Model Number {model}, Firmware Version {version}" if model is not None
               else "it answers PING, not READ (Status Return Level 0)")
    print(f"servo {args.ident}: {os.path.basename(args.firmware)} written ({len(image.data)} B, {pages} pages)"
          f"{', verified' if not args.no_verify else ', not verified'}; the application runs: {started}")
    return EXIT_DONE


if __name__ == "__main__":
    sys.exit(main())
