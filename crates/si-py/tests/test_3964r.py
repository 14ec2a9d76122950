"""3964(R) send/recv: two si_serial links on a pty pair, and against the `si` CLI."""

import json
import subprocess
import time

import pytest
import si_serial
from peers import read_line, wait_for_port


def test_two_links_send_and_receive_both_ways(pty_pair):
    a, b = pty_pair
    with si_serial.Link3964R(a, priority="high", rx_latency=0) as high, si_serial.Link3964R(
        b, priority="low", rx_latency=0
    ) as low:
        high.send(b"\x10\x02hello")
        assert low.recv(timeout=2.0) == b"\x10\x02hello"
        low.send(b"back")
        assert high.recv(timeout=2.0) == b"back"


def test_a_silent_partner_is_no_response_with_the_status(pty_pair):
    a, _ = pty_pair
    with si_serial.Link3964R(a, ack_delay=0.05, connection_attempts=1, transmission_attempts=1, rx_latency=0) as link:
        with pytest.raises(si_serial.NoResponseError) as info:
            link.send(b"x")
    assert info.value.status == 0x0703  # QVZ exceeded after STX


def test_nothing_received_within_the_timeout(pty_pair):
    a, _ = pty_pair
    with si_serial.Link3964R(a, rx_latency=0) as link:
        start = time.monotonic()
        with pytest.raises(si_serial.NoResponseError):
            link.recv(timeout=0.2)
        assert time.monotonic() - start < 1.0


def test_bad_arguments_name_the_keyword():
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.Link3964R("/nonexistent", char_delay=0.001)
    assert info.value.keyword == "char_delay"
    assert info.value.range == "20 … 655350 ms"
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.Link3964R("/nonexistent", priority="middle")
    assert info.value.keyword == "priority"


def test_an_empty_block_is_refused(pty_pair):
    a, _ = pty_pair
    with si_serial.Link3964R(a, rx_latency=0) as link:
        with pytest.raises(si_serial.ConfigError) as info:
            link.send(b"")
    assert info.value.status == 0x1E41


def test_against_the_si_cli(pty_pair, si_cli):
    a, b = pty_pair
    recv = subprocess.Popen(
        [si_cli, "--json", "--port", b, "3964r", "recv", "--count", "1"],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        wait_for_port(recv, b)
        with si_serial.Link3964R(a, priority="high", rx_latency=0) as link:
            link.send(b"ABC")
            got = json.loads(read_line(recv))
            assert got["hex"] == "41 42 43"
            recv.wait(timeout=5)  # --count 1: it exits and releases the port
            sent = subprocess.run(
                [si_cli, "--port", b, "3964r", "send", "01", "02", "03"],
                capture_output=True,
                timeout=10,
            )
            assert sent.returncode == 0, sent
            assert link.recv(timeout=2.0) == b"\x01\x02\x03"
    finally:
        recv.kill()
        recv.wait()
