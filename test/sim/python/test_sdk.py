# SPDX-License-Identifier: GPL-3.0-or-later
"""ROBOTIS DynamixelSDK (PyPI dynamixel-sdk, Protocol 1.0) against ax12-emu in real time:
ping, model number, a write and a read back, as a user would through the pty."""
import dynamixel_sdk as sdk

import ax12_table as T


def open_port(device):
    port = sdk.PortHandler(device)
    assert port.openPort()
    assert port.setBaudRate(1000000)
    return port, sdk.PacketHandler(1.0)


def test_the_sdk_pings_and_reads_model_number_12(emulator, tmp_path):
    emu = emulator("--realtime", "--state-dir", str(tmp_path))
    port, handler = open_port(emu.device)
    try:
        model, result, error = handler.ping(port, 1)
        assert result == sdk.COMM_SUCCESS, handler.getTxRxResult(result)
        assert error == 0
        assert model == 12
        value, result, error = handler.read2ByteTxRx(port, 1, T.MODEL_NUMBER)
        assert (value, result, error) == (12, sdk.COMM_SUCCESS, 0)
        result, error = handler.write1ByteTxRx(port, 1, T.LED, 1)
        assert (result, error) == (sdk.COMM_SUCCESS, 0)
        value, result, error = handler.read1ByteTxRx(port, 1, T.LED)
        assert (value, result, error) == (1, sdk.COMM_SUCCESS, 0)
        _, result, _ = handler.ping(port, 2)
        assert result == sdk.COMM_RX_TIMEOUT
    finally:
        port.closePort()


def test_the_sdk_pings_every_servo_of_a_bus(emulator, tmp_path):
    emu = emulator("--realtime", "--ids", "1-6", "--state-dir", str(tmp_path))
    port, handler = open_port(emu.device)
    try:
        for ident in range(1, 7):
            model, result, error = handler.ping(port, ident)
            assert (model, result, error) == (12, sdk.COMM_SUCCESS, 0), ident
    finally:
        port.closePort()
