# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 flash` (scripts/ax12_flash.py) against a servo without a simulator
(test/board/fake_boot_servo.py): the steps and what is written, the way into the bootloader
from a running application, retries and giving up, other IDs' answers ignored, verify, and
what it refuses (exit 2: bad files, files for a part without a bootloader or too large for
their part's application area, all before the port is opened; a file the servo's bootloader
does not take, after which a servo this command asked in runs its application again; bad
arguments; exit 1: a servo that does not answer or cannot take it, a port lost mid-update).
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
import fake_boot_servo  # noqa: E402
from fake_boot_servo import BEGIN, BOOT, END, GO, INFO, PAGE, PING, READ, FakeBootServo  # noqa: E402

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
    assert bytes(servo.flash[:len(image.data)]) == image.data
    assert servo._record_valid()
    assert bytes(servo.flash[0x7780:0x7800]) == image.record_page(128)


def test_a_servo_in_its_bootloader_is_written_verified_and_started(capsys):
    servo = FakeBootServo()
    code, opened = flash(servo)
    out, err = capsys.readouterr()
    assert code == 0, err
    assert opened == [("/dev/fake", 1000000)]
    assert_written(servo)
    pages = len(ax12_app_image.load(HEX_328P).pages(128))
    sent = instructions(servo)
    assert sent[:2] == [INFO, BEGIN]
    assert sent[2:2 + pages] == [PAGE] * pages
    assert sent[2 + pages] == END
    assert sent[3 + pages:3 + 2 * pages + 1] == [READ] * (pages + 1), "every page and the record read back"
    assert sent[3 + 2 * pages + 1] == GO
    assert [address for (i, params) in servo.requests if i == PAGE
            for address in [int.from_bytes(params[:2], "little")]] == [128 * n for n in range(pages)]
    assert servo.mode == "app" and servo.closed
    assert "written" in out and "verified" in out and "Model Number 12, Firmware Version 1" in out
    assert "bootloader 1 on an atmega328p" in err and "application not valid" in err


def test_a_running_application_is_asked_into_the_bootloader(capsys):
    servo = FakeBootServo(mode="app")
    code, _ = flash(servo)
    assert code == 0, capsys.readouterr().err
    assert instructions(servo)[:3] == [INFO, BOOT, INFO]
    assert servo.requests[1] == (BOOT, b"BOOT")
    assert_written(servo)


def test_an_application_without_the_boot_request_is_an_error(capsys):
    servo = FakeBootServo(mode="app", knows_boot=False)
    code, _ = flash(servo)
    assert code == 1
    assert "does not know instruction 0x0A" in capsys.readouterr().err
    assert BEGIN not in instructions(servo)


def test_a_silent_servo_is_an_error_naming_its_id_and_baud(capsys):
    servo = FakeBootServo()
    servo.silent = True
    code, _ = flash(servo, "--baud", "57600")
    assert code == 1
    assert "servo 2 does not answer at 57600 bps" in capsys.readouterr().err


@pytest.mark.parametrize("kind", ["drop", "checksum", 0x10, 0x20])
def test_a_page_is_sent_again_after_a_lost_garbled_or_failed_answer(capsys, kind):
    servo = FakeBootServo()
    servo.fault(PAGE, kind, times=2, after=5)
    code, _ = flash(servo)
    assert code == 0, capsys.readouterr().err
    pages = len(ax12_app_image.load(HEX_328P).pages(128))
    assert instructions(servo).count(PAGE) == pages + 2
    assert_written(servo)


def test_a_page_that_keeps_failing_is_given_up_after_the_retries(capsys):
    servo = FakeBootServo()
    servo.fault(PAGE, "drop", times=100, after=1)
    code, _ = flash(servo, "--retries", "2")
    err = capsys.readouterr().err
    assert code == 1
    assert "PAGE 0x0080: ID 2: no answer within 0.1 s (3 attempts)" in err
    assert instructions(servo).count(PAGE) == 1 + 3
    assert GO not in instructions(servo)


def test_a_range_error_is_not_retried(capsys):
    servo = FakeBootServo()
    servo.fault(PAGE, 0x08, times=1)
    code, _ = flash(servo)
    assert code == 1
    assert "PAGE 0x0000: servo 2 answered with address or length outside the application area" in \
        capsys.readouterr().err
    assert instructions(servo).count(PAGE) == 1


def test_an_image_crc_mismatch_at_end_is_an_error_and_no_go(capsys):
    servo = FakeBootServo()
    servo.fault(END, 0x10)
    code, _ = flash(servo)
    assert code == 1
    assert "END: servo 2 answered with CRC does not match" in capsys.readouterr().err
    assert instructions(servo).count(END) == 1 and GO not in instructions(servo)


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
    assert "still in its bootloader after GO" in capsys.readouterr().err


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
    assert instructions(servo)[:6] == [INFO, INFO, PING, BOOT, INFO, BEGIN]
    assert_written(servo)
    assert "it answers PING, not READ (Status Return Level 0)" in out


def test_an_image_for_a_part_without_a_bootloader_is_refused_before_the_port_is_opened(capsys):
    servo = FakeBootServo(mode="app")
    code, opened = flash(servo, hex_path=HEX_88)
    assert code == 2
    assert "built for the atmega88, which has no bootloader" in capsys.readouterr().err
    assert opened == [] and servo.received == b"", "no servo is asked into its bootloader"


def test_an_image_larger_than_its_parts_application_area_is_refused_before_the_port_is_opened(capsys, tmp_path):
    image = IntelHex(HEX_328P)
    image[0x7780] = 0x00  # the record page
    big = tmp_path / "big.hex"
    image.write_hex_file(str(big))
    servo = FakeBootServo(mode="app")
    code, opened = flash(servo, hex_path=str(big))
    assert code == 2
    err = capsys.readouterr().err
    assert "is 30593 B, more than the atmega328p's application area 0x0000-0x77FF: the image 0x0000-0x777F" in err
    assert opened == [] and servo.received == b""


def test_a_merged_hex_is_refused_before_the_port_is_opened_naming_the_file_flash_takes(capsys):
    servo = FakeBootServo(mode="app")
    code, opened = flash(servo, hex_path=HEX_328P_MERGED)
    assert code == 2
    err = capsys.readouterr().err
    assert "reaches into the boot section" in err and "flash-isp" in err and "ax12-<profile>-<mcu>.hex" in err
    assert opened == [] and servo.received == b""


def running_application(app_area):
    """A servo running a valid application in an application area of app_area bytes."""
    servo = FakeBootServo(mode="app", app_area=app_area)
    app = bytes(range(256)) * 4
    servo.flash[:len(app)] = app
    record_at = app_area - servo.page_bytes
    servo.flash[record_at:record_at + 8] = b"AXAP" + len(app).to_bytes(2, "little") + \
        ax12_app_image.crc16(app).to_bytes(2, "little")
    assert servo._record_valid()
    return servo


def too_small_area():
    """An application area (whole pages) the image of HEX_328P does not fit."""
    return len(ax12_app_image.load(HEX_328P).data) // 128 * 128


def test_a_servo_refused_after_it_entered_its_bootloader_runs_its_application_again(capsys):
    servo = running_application(too_small_area())
    code, _ = flash(servo)
    err = capsys.readouterr().err
    assert code == 2, err
    sent = instructions(servo)
    assert sent[:3] == [INFO, BOOT, INFO] and BEGIN not in sent
    assert sent[3] == GO, "GO right after the refusal"
    assert servo.mode == "app", "the servo left its bootloader"
    assert "nothing written; its application runs again" in err


def test_the_application_area_has_one_wording_in_the_steps_and_the_refusal(capsys):
    size = too_small_area()
    servo = running_application(size)
    flash(servo)
    err = capsys.readouterr().err
    area = "application area 0x0000-0x%04X: the image 0x0000-0x%04X (%d B at most), its record 0x%04X-0x%04X" % (
        size - 1, size - 129, size - 128, size - 128, size - 1)
    assert err.count(area) == 2, err


def test_an_unknown_part_after_entry_is_refused_and_the_application_started_again(capsys, monkeypatch):
    servo = running_application(0x7800)
    servo.mcu = "unknown"
    monkeypatch.setitem(fake_boot_servo.SIGNATURES, "unknown", b"\x1e\x00\x00")
    code, _ = flash(servo)
    err = capsys.readouterr().err
    assert code == 1
    assert "signature 1E 00 00, no part this tool knows" in err
    assert instructions(servo)[3] == GO and servo.mode == "app"


def test_ctrl_c_after_entry_and_before_begin_starts_the_application_again(capsys, monkeypatch):
    def interrupted(*_):
        raise KeyboardInterrupt
    monkeypatch.setattr(ax12_app_image, "mcu_of_signature", interrupted)
    servo = running_application(0x7800)
    code, _ = flash(servo)
    assert code == 1
    assert servo.mode == "app" and BEGIN not in instructions(servo)
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
