"""RK 512 send/fetch and the passive partner with its own memory: two si_serial stations on a
pty pair, and against `si rk512 serve` / `send` / `fetch`."""

import json
import subprocess

import pytest
import si_serial
from peers import wait_for_port


def test_send_and_fetch_against_a_passive_partner(pty_pair):
    a, b = pty_pair
    with si_serial.Rk512Station(b, serve=True, dbs={2: 64}, rx_latency=0) as plc, si_serial.Rk512Station(
        a, priority="high", rx_latency=0
    ) as host:
        host.send("DB2", 1, b"\xab\xcd\x12\x34")
        # DW numbers count words: DW1 is byte 2.
        assert plc.read_memory("DB2", 2, 4) == b"\xab\xcd\x12\x34"
        plc.write_memory("DB2", 10, b"\x55\x66")
        assert host.fetch("DB2", 5, 2) == b"\x55\x66"
        with pytest.raises(si_serial.DeviceException) as info:
            host.fetch("DB9", 0, 2)
        assert info.value.status == 0x0903
        assert info.value.error_number == 0x03


def test_a_silent_partner_is_no_response(pty_pair):
    a, _ = pty_pair
    with si_serial.Rk512Station(a, priority="high", ack_delay=0.05, connection_attempts=1, rx_latency=0) as host:
        with pytest.raises(si_serial.NoResponseError) as info:
            host.send("DB1", 0, b"\x00\x01")
    # 051AH "command telegram not sent", caused by the procedure's 0703H (QVZ after STX).
    assert info.value.status == 0x051A
    assert info.value.cause == 0x0703




@pytest.mark.parametrize(
    "area, start, keyword, value, allowed",
    [
        ("DW2", 0, "area", "DW2", "DB0 … DB255, DX0 … DX255, E/I, A/Q, M/F, T, Z/C"),
        ("DB256", 0, "area", "DB256", "DB0 … DB255, DX0 … DX255, E/I, A/Q, M/F, T, Z/C"),
        ("DB2", 256, "start", "256", "0 … 255"),
        ("M", 65536, "start", "65536", "0 … 65535"),
    ],
)
def test_a_bad_area_or_start_is_refused_before_the_line(pty_pair, area, start, keyword, value, allowed):
    a, _ = pty_pair
    with si_serial.Rk512Station(a, priority="high", rx_latency=0) as host:
        with pytest.raises(si_serial.ConfigError) as info:
            host.send(area, start, b"\x00\x01")
    assert (info.value.keyword, info.value.value, info.value.range) == (keyword, value, allowed)


def test_german_and_english_area_letters_name_the_same_memory(pty_pair):
    a, b = pty_pair
    with si_serial.Rk512Station(b, serve=True, dbs={2: 64}, rx_latency=0) as plc, si_serial.Rk512Station(
        a, priority="high", rx_latency=0
    ) as host:
        plc.write_memory("Q", 3, b"\x12")
        assert host.fetch("A", 3, 1) == host.fetch("q", 3, 1) == b"\x12"
        host.send("db2", 0, b"\x34\x56")
        assert plc.read_memory("DB2", 0, 2) == b"\x34\x56"
def test_bad_arguments_name_the_keyword():
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.Rk512Station("/nonexistent", response_timeout=0.001)
    assert info.value.keyword == "response_timeout"
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.Rk512Station("/nonexistent", max_block_len=5000)
    assert info.value.keyword == "max_block_len"


def test_against_the_si_cli_as_passive_partner(pty_pair, si_cli):
    a, b = pty_pair
    serve = subprocess.Popen([si_cli, "--json", "--port", b, "rk512", "serve"], stdout=subprocess.PIPE, text=True)
    try:
        wait_for_port(serve, b)
        with si_serial.Rk512Station(a, priority="high", rx_latency=0) as host:
            host.send("DB1", 0, b"\x11\x22\x33\x44")
            assert host.fetch("DB1", 1, 2) == b"\x33\x44"
    finally:
        serve.kill()
        serve.wait()


def test_the_si_cli_sends_and_fetches_from_si_serial_memory(pty_pair, si_cli):
    a, b = pty_pair
    with si_serial.Rk512Station(a, serve=True, dbs={6: 32}, rx_latency=0) as plc:
        sent = subprocess.run(
            [si_cli, "--json", "--port", b, "rk512", "send", "--db", "6", "--dw", "0", "1122", "3344"],
            capture_output=True,
            timeout=20,
        )
        assert sent.returncode == 0, sent
        assert plc.read_memory("DB6", 0, 4) == b"\x11\x22\x33\x44"
        fetched = subprocess.run(
            [si_cli, "--json", "--port", b, "rk512", "fetch", "--db", "6", "--dw", "1", "--count", "1"],
            capture_output=True,
            text=True,
            timeout=20,
        )
        assert fetched.returncode == 0, fetched
        # --count of a DB counts data words.
        assert json.loads(fetched.stdout)["hex"] == "33 44"
