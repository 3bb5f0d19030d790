# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 flash` (scripts/ax12_flash.py) against a servo without a simulator
(test/board/fake_boot_servo.py): the steps and what is written, the way into the bootloader
from a running application, retries and giving up, other IDs' answers ignored, verify, and
what it refuses (exit 2: bad files, files too large for their part's application area (a
merged HEX), all before the port is opened; a file for another part than the servo's, after
which a servo this command asked in runs its application again; bad arguments; exit 1: a servo
that does not answer or cannot take it, a port lost mid-update).
The same command against the emulated servos: test_flash_emulated.py."""

import os
import sys

import pytest
from intelhex import IntelHex

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(REPO, "python"))
sys.path.insert(0, os.path.join(REPO, "scripts"))
import ax12_build  # noqa: E402

ax12_build.ensure(os.path.join(REPO, "build"))

import ax12_app_image  # noqa: E402
import ax12_flash  # noqa: E402
import ax12_packets  # noqa: E402
from fake_boot_servo import BOOT, GO, INFO, PAGE, PING, READ, FakeBootServo  # noqa: E402

FIRMWARE_DIR = os.environ.get("AX12_FIRMWARE_DIR") or os.path.join(REPO, "build", "firmware")
HEX_328P = os.path.join(FIRMWARE_DIR, "ax12-ax12a-atmega328p.hex")
HEX_88 = os.path.join(FIRMWARE_DIR, "ax12-ax12-atmega88.hex")
HEX_328P_MERGED = os.path.join(FIRMWARE_DIR, "ax12-ax12a-atmega328p-merged.hex")


@pytest.fixture(autouse=True)
def short_timeouts(monkeypatch):
    monkeypatch.setattr(ax12_flash, "ANSWER_TIMEOUT_S", 0.1)
    monkeypatch.setattr(ax12_flash, "ENTER_TIMEOUT_S", 0.5)
    monkeypatch.setattr(ax12_flash, "START_TIMEOUT_S", 0.5)


def flash(servo, *args, hex_path=HEX_328P):
    opened = []

    def open_port(device, baud):
        opened.append((device, baud))
        return servo

    code = ax12_flash.main(["--port", "/dev/fake", "--id", str(servo.ident), *args, hex_path], open_port=open_port)
    return code, opened


def instructions(servo):
    return [instruction for instruction, _ in servo.requests]


def assert_written(servo, hex_path=HEX_328P):
    image = ax12_app_image.load(hex_path)
    assert bytes(servo.flash) == image.flash_bytes(servo.mcu)
    assert servo._record_valid()


def page_addresses(servo):
    return [int.from_bytes(params[:2], "little") for (i, params) in servo.requests if i == PAGE]


def test_a_servo_in_its_bootloader_is_written_verified_and_started(capsys):
    servo = FakeBootServo()
    code, opened = flash(servo)
    out, err = capsys.readouterr()
    assert code == 0, err
    assert opened == [("/dev/fake", 1000000)]
    assert_written(servo)
    image_pages = -(-len(ax12_app_image.load(HEX_328P).data) // 128)
    sent = instructions(servo)
    assert sent[0] == INFO
    assert sent[1:1 + image_pages + 2] == [PAGE] * (image_pages + 2)
    # The record's page first (its record erased) and last (with it), the image between.
    assert page_addresses(servo) == [0x7D80] + [128 * n for n in range(image_pages)] + [0x7D80]
    go = sent.index(GO)
    assert sent[1 + image_pages + 2:go] == [READ] * (image_pages + 1), "every page written read back"
    assert sent[go + 1:] == [PING, 0x02], "the application's PING and READ of its identity"
    assert servo.mode == "app" and servo.closed
    assert "written" in out and "verified" in out and "Model Number 12, Firmware Version 1" in out
    assert "bootloader 2 on an atmega328p" in err and "application area 0x0000-0x7DFF" in err


def test_the_record_is_erased_by_the_first_write_and_written_by_the_last(capsys):
    servo = FakeBootServo()
    seen = []
    answer = servo._answer_as_bootloader

    def watch(instruction, params):
        answer(instruction, params)
        if instruction == PAGE:
            seen.append(servo._record_valid())
    servo._answer_as_bootloader = watch
    servo.flash[:] = ax12_app_image.load(HEX_328P).flash_bytes("atmega328p")  # valid before
    assert servo._record_valid()
    code, _ = flash(servo, "--no-verify")
    assert code == 0, capsys.readouterr().err
    assert seen == [False] * (len(seen) - 1) + [True]


def test_a_running_application_is_asked_into_the_bootloader(capsys):
    servo = FakeBootServo(mode="app")
    code, _ = flash(servo)
    assert code == 0, capsys.readouterr().err
    assert instructions(servo)[:3] == [INFO, BOOT, INFO]
    assert servo.requests[1] == (BOOT, b"BOOT")
    assert_written(servo)


def test_an_application_storing_its_settings_is_asked_again(capsys):
    servo = FakeBootServo(mode="app")
    servo.boot_busy = 2
    code, _ = flash(servo)
    assert code == 0, capsys.readouterr().err
    assert instructions(servo)[:7] == [INFO, BOOT, INFO, BOOT, INFO, BOOT, INFO]
    assert_written(servo)


def test_an_application_without_the_boot_request_is_an_error(capsys):
    servo = FakeBootServo(mode="app", knows_boot=False)
    code, _ = flash(servo)
    assert code == 1
    assert "does not know instruction 0x0A" in capsys.readouterr().err
    assert PAGE not in instructions(servo)


def test_a_silent_servo_is_an_error_naming_its_id_and_baud(capsys):
    servo = FakeBootServo()
    servo.silent = True
    code, _ = flash(servo, "--baud", "57600")
    assert code == 1
    assert "servo 2 does not answer at 57600 bps" in capsys.readouterr().err


@pytest.mark.parametrize("kind", ["drop", "checksum", 0x20])
def test_a_page_is_sent_again_after_a_lost_garbled_or_failed_answer(capsys, kind):
    servo = FakeBootServo()
    servo.fault(PAGE, kind, times=2, after=5)
    code, _ = flash(servo)
    assert code == 0, capsys.readouterr().err
    writes = len(ax12_app_image.load(HEX_328P).update_pages("atmega328p"))
    assert instructions(servo).count(PAGE) == writes + 2
    assert_written(servo)


def test_a_request_sent_again_comes_after_bytes_that_end_any_packet_the_servo_took_up(capsys):
    servo = FakeBootServo()
    servo.fault(PAGE, "drop", times=1, after=3)
    code, _ = flash(servo)
    assert code == 0, capsys.readouterr().err
    dropped = ax12_packets.instruction_packet(2, PAGE, [*servo.requests[4][1]])  # its answer lost
    received = bytes(servo.received)
    at = received.index(dropped, received.index(dropped) + 1)  # sent again
    assert received[at - 256:at] == bytes(256), "256 bytes of 0x00 before it"
    assert received.count(bytes(256)) == 1, "only before the one sent again"


def test_a_late_answer_to_the_page_before_is_not_taken_for_this_one(capsys):
    servo = FakeBootServo()
    servo.fault(PAGE, "stale", times=1, after=6)
    code, _ = flash(servo)
    assert code == 0, capsys.readouterr().err
    writes = len(ax12_app_image.load(HEX_328P).update_pages("atmega328p"))
    assert instructions(servo).count(PAGE) == writes + 1, "the page whose answer was another's is sent again"
    assert_written(servo)


def test_a_page_that_keeps_failing_is_given_up_after_the_retries(capsys):
    servo = FakeBootServo()
    servo.fault(PAGE, "drop", times=100, after=1)
    code, _ = flash(servo, "--retries", "2")
    err = capsys.readouterr().err
    assert code == 1
    assert "PAGE 0x0000: ID 2: no answer within 0.1 s (3 attempts)" in err
    assert instructions(servo).count(PAGE) == 1 + 3
    assert GO not in instructions(servo)


def test_a_range_error_is_not_retried(capsys):
    servo = FakeBootServo()
    servo.fault(PAGE, 0x08, times=1)
    code, _ = flash(servo)
    assert code == 1
    assert "PAGE 0x7D80: servo 2 answered with address outside the application area" in capsys.readouterr().err
    assert instructions(servo).count(PAGE) == 1


def test_a_bootloader_of_another_version_is_refused(capsys, monkeypatch):
    servo = FakeBootServo()  # its INFO: version 1
    monkeypatch.setattr(servo, "_answer_as_bootloader",
                        lambda i, p: servo._send(0, bytes([1]) + servo.signature) if i == INFO else None)
    code, _ = flash(servo)
    assert code == 1
    assert "bootloader is version 1; this tool writes to version 2" in capsys.readouterr().err
    assert PAGE not in instructions(servo)


def test_status_packets_of_other_ids_are_ignored(capsys):
    servo = FakeBootServo()
    servo.other_id_first = True
    code, _ = flash(servo)
    assert code == 0, capsys.readouterr().err
    assert_written(servo)


def test_verify_reports_a_byte_that_reads_back_different(capsys):
    servo = FakeBootServo()
    servo.read_flip = 0x0123
    code, _ = flash(servo)
    assert code == 1
    assert "verify: flash 0x0123 reads" in capsys.readouterr().err
    assert GO not in instructions(servo)


def test_no_verify_reads_nothing_back(capsys):
    servo = FakeBootServo()
    code, _ = flash(servo, "--no-verify")
    out = capsys.readouterr().out
    assert code == 0
    assert READ not in instructions(servo)
    assert "not verified" in out


def test_a_servo_still_in_its_bootloader_after_go_is_an_error(capsys):
    servo = FakeBootServo()
    servo.stays_after_go = True
    code, _ = flash(servo)
    assert code == 1
    assert "still in its bootloader after GO (4 attempts): the application in its flash is not valid" in \
        capsys.readouterr().err


def test_a_lost_go_is_sent_again(capsys):
    servo = FakeBootServo()
    servo.fault(GO, "lost")
    code, _ = flash(servo)
    assert code == 0, capsys.readouterr().err
    assert instructions(servo).count(GO) == 2 and servo.mode == "app"


def test_an_application_at_status_return_level_0_is_asked_in_and_started(capsys):
    servo = FakeBootServo(mode="app")
    servo.status_return_level = 0
    code, _ = flash(servo)
    out, err = capsys.readouterr()
    assert code == 0, err
    assert instructions(servo)[:6] == [INFO, INFO, PING, BOOT, INFO, PAGE]
    assert_written(servo)
    assert "it answers PING, not READ (Status Return Level 0)" in out


def test_an_image_for_the_other_part_is_refused_before_a_write(capsys):
    servo = FakeBootServo()
    code, _ = flash(servo, hex_path=HEX_88)
    assert code == 2
    assert "built for the atmega88, the servo is an atmega328p" in capsys.readouterr().err
    assert instructions(servo) == [INFO]


def test_an_image_larger_than_its_parts_application_area_is_refused_before_the_port_is_opened(capsys, tmp_path):
    image = IntelHex(HEX_328P)
    image[0x7DFC] = 0x00  # the record
    big = tmp_path / "big.hex"
    image.write_hex_file(str(big))
    servo = FakeBootServo(mode="app")
    code, opened = flash(servo, hex_path=str(big))
    assert code == 2
    err = capsys.readouterr().err
    assert "is 32253 B, more than the atmega328p's application area 0x0000-0x7DFF: the image 0x0000-0x7DFB" in err
    assert opened == [] and servo.received == b""


def test_a_merged_hex_is_refused_before_the_port_is_opened_naming_the_file_flash_takes(capsys):
    servo = FakeBootServo(mode="app")
    code, opened = flash(servo, hex_path=HEX_328P_MERGED)
    assert code == 2
    err = capsys.readouterr().err
    assert "reaches into the boot section" in err and "flash-isp" in err and "ax12-<profile>-<mcu>.hex" in err
    assert opened == [] and servo.received == b""


def running_application(mcu="atmega328p"):
    """A servo of that part running a valid application."""
    servo = FakeBootServo(mode="app", mcu=mcu)
    app = bytes(range(256)) * 4
    servo.flash[:len(app)] = app
    servo.flash[-4:] = ax12_app_image.record(len(app), ax12_app_image.check_value(app))
    assert servo._record_valid()
    return servo


def test_a_servo_refused_after_it_entered_its_bootloader_runs_its_application_again(capsys):
    servo = running_application("atmega88")  # and the file is the ATmega328P's
    code, _ = flash(servo)
    err = capsys.readouterr().err
    assert code == 2, err
    assert "built for the atmega328p, the servo is an atmega88" in err
    sent = instructions(servo)
    assert sent[:3] == [INFO, BOOT, INFO] and PAGE not in sent
    assert sent[3] == GO, "GO right after the refusal"
    assert servo.mode == "app", "the servo left its bootloader"
    assert "nothing written; its application runs again" in err


def test_the_application_area_has_one_wording_in_the_steps_and_the_refusal(capsys, tmp_path):
    area = "application area 0x0000-0x7DFF: the image 0x0000-0x7DFB (32252 B at most), its record 0x7DFC-0x7DFF"
    assert ax12_app_image.area_text("atmega328p") == area
    code, _ = flash(FakeBootServo())
    steps = capsys.readouterr().err
    assert code == 0 and steps.count(area) == 1, steps
    image = IntelHex(HEX_328P)
    image[0x7DFC] = 0x00
    big = tmp_path / "big.hex"
    image.write_hex_file(str(big))
    flash(FakeBootServo(), hex_path=str(big))
    refusal = capsys.readouterr().err
    assert refusal.count(area) == 1, refusal


def test_an_unknown_part_after_entry_is_refused_and_the_application_started_again(capsys):
    servo = running_application()
    servo.signature = b"\x1e\x00\x00"
    code, _ = flash(servo)
    err = capsys.readouterr().err
    assert code == 1
    assert "signature 1E 00 00, no part this tool knows" in err
    assert instructions(servo)[3] == GO and servo.mode == "app"


def test_ctrl_c_after_entry_and_before_the_first_page_starts_the_application_again(capsys, monkeypatch):
    def interrupted(*_):
        raise KeyboardInterrupt
    monkeypatch.setattr(ax12_app_image, "mcu_of_signature", interrupted)
    servo = running_application()
    code, _ = flash(servo)
    assert code == 1
    assert servo.mode == "app" and PAGE not in instructions(servo)
    assert "its application runs again" in capsys.readouterr().err


class PortGoneAfterPages(FakeBootServo):
    """The port goes away (the emulator killed, the adapter unplugged) after `pages` PAGEs:
    pyserial raises SerialException from then on."""

    def __init__(self, pages, **kwargs):
        super().__init__(**kwargs)
        self.pages_left = pages

    def write(self, data):
        import serial
        if self.pages_left < 0:
            raise serial.SerialException("write failed: [Errno 5] Input/output error")
        if len(data) > 5 and data[4] == PAGE:
            self.pages_left -= 1
        return super().write(data)

    def read(self, count):
        import serial
        if self.pages_left < 0:
            raise serial.SerialException("device reports readiness to read but returned no data")
        return super().read(count)


def test_a_port_lost_mid_update_is_one_line_and_exit_1(capsys):
    servo = PortGoneAfterPages(3)
    code, _ = flash(servo)
    err = capsys.readouterr().err
    assert code == 1
    lines = err.strip().splitlines()
    assert lines[-1].startswith("ax12 flash: lost the port /dev/fake (") and "Traceback" not in err
    assert "stays in its bootloader" in lines[-1]


def bad_files(tmp_path):
    lines = open(HEX_328P).read().splitlines()
    first = lines[0]
    flipped = tmp_path / "flipped.hex"
    flipped.write_text("\n".join([first[:9] + "%02X" % (int(first[9:11], 16) ^ 0x80) + first[11:]] + lines[1:]) + "\n")
    short = tmp_path / "short.hex"
    short.write_text("\n".join(lines[:len(lines) // 2]) + "\n")
    text = tmp_path / "notes.hex"
    text.write_text("not a HEX file\n")
    return {"flipped data byte": flipped, "truncated": short, "not Intel HEX": text,
            "missing": tmp_path / "none.hex"}


@pytest.mark.parametrize("which", ["flipped data byte", "truncated", "not Intel HEX", "missing"])
def test_a_bad_file_is_refused_before_anything_is_sent(capsys, tmp_path, which):
    servo = FakeBootServo()
    code, opened = flash(servo, hex_path=str(bad_files(tmp_path)[which]))
    assert code == 2
    assert opened == [] and servo.received == b"", "the port is not even opened"
    assert capsys.readouterr().err.startswith("ax12 flash: ")


@pytest.mark.parametrize("args", [["--id", "254"], ["--baud", "0"], ["--retries", "-1"]])
def test_bad_arguments_exit_2(args):
    with pytest.raises(SystemExit) as exit_info:
        ax12_flash.main(["--port", "/dev/fake", "--id", "2", *args, HEX_328P], open_port=None)
    assert exit_info.value.code == 2


def test_a_port_that_cannot_be_opened_exits_2(capsys, tmp_path):
    code = ax12_flash.main(["--port", str(tmp_path / "no-such-port"), "--id", "2", HEX_328P])
    assert code == 2
    assert "cannot open" in capsys.readouterr().err
