"""Frame encode/decode per protocol, offline."""

import pytest
import si_serial


def test_modbus_request_and_response():
    # [Modbus/USS] §3.3.1: FC03, 10 registers from 0, unit 1.
    adu = si_serial.encode_modbus(1, b"\x03\x00\x00\x00\x0a")
    assert adu == bytes.fromhex("01030000000AC5CD")
    d = si_serial.decode_modbus_request(adu)
    assert (d["unit"], d["function"], d["address"]) == (1, 3, 0)
    with pytest.raises(si_serial.InvalidResponseError):
        si_serial.decode_modbus_request(adu[:-1] + b"\x00")
    response = si_serial.encode_modbus(1, b"\x03\x02\x12\x34")
    assert si_serial.decode_modbus_response(response)["pdu"] == b"\x03\x02\x12\x34"
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.encode_modbus(300, b"\x03")
    assert info.value.keyword == "unit"


def test_3964r_block_round_trip_and_bcc():
    block = si_serial.encode_3964r(b"\x10\x41")
    assert block[:3] == b"\x10\x10\x41"  # DLE doubled
    assert block[3:5] == b"\x10\x03"  # DLE ETX, then the BCC
    assert si_serial.decode_3964r(block) == b"\x10\x41"
    with pytest.raises(si_serial.InvalidResponseError):
        si_serial.decode_3964r(block[:-1] + bytes([block[-1] ^ 1]))
    assert si_serial.decode_3964r(si_serial.encode_3964r(b"x", block_check=False), block_check=False) == b"x"


def test_uss_telegram_round_trip():
    telegram = si_serial.encode_uss(5, bytes(12))
    assert telegram[0] == 0x02 and telegram[2] == 5
    assert si_serial.decode_uss(telegram) == (5, bytes(12))
    with pytest.raises(si_serial.InvalidResponseError):
        si_serial.decode_uss(telegram[:-1] + bytes([telegram[-1] ^ 0xFF]))


def test_rk512_telegrams():
    # A reaction telegram: 00 00 00 error number 0.
    d = si_serial.decode_rk512(b"\x00\x00\x00\x00")
    assert d["kind"] == "reaction" and d["error_number"] == 0
    with pytest.raises(si_serial.InvalidResponseError):
        si_serial.decode_rk512(b"\x00")
