"""ASCII send/recv with the config's end criteria: two si_serial links on a pty pair, and
against the `si` CLI."""

import json
import subprocess

import pytest
import si_serial
from peers import read_line, wait_for_port


@pytest.mark.parametrize(
    "end_kwargs, sent, frames",
    [
        ({"end": "end-chars", "end_chars": (0x0D, 0x0A)}, b"one\r\ntwo\r\n", [b"one\r\n", b"two\r\n"]),
        ({"end": "fixed-length", "fixed_length": 4}, b"abcdefgh", [b"abcd", b"efgh"]),
        ({"end": "char-delay", "char_delay": 0.05}, b"whole frame", [b"whole frame"]),
    ],
)
def test_frames_are_cut_by_the_configured_end(pty_pair, end_kwargs, sent, frames):
    a, b = pty_pair
    with si_serial.AsciiLink(a, rx_latency=0) as tx, si_serial.AsciiLink(b, rx_latency=0, **end_kwargs) as rx:
        tx.send(sent)
        assert [rx.recv(timeout=2.0) for _ in frames] == frames


def test_nothing_received_within_the_timeout(pty_pair):
    a, _ = pty_pair
    with si_serial.AsciiLink(a, rx_latency=0) as link:
        with pytest.raises(si_serial.NoResponseError):
            link.recv(timeout=0.1)


def test_bad_arguments_name_the_keyword():
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.AsciiLink("/nonexistent", end="end-chars", end_chars=(0, 0))
    assert info.value.keyword == "end_chars"
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.AsciiLink("/nonexistent", max_frame_len=2000)
    assert info.value.keyword == "max_frame_len"
    assert info.value.status == 0x1E20


def test_against_the_si_cli(pty_pair, si_cli):
    a, b = pty_pair
    recv = subprocess.Popen(
        [si_cli, "--json", "--port", b, "ascii", "recv", "--end", "chars", "0D", "--count", "1"],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        wait_for_port(recv, b)
        with si_serial.AsciiLink(a, end="end-chars", end_chars=(0x0D, 0), rx_latency=0) as link:
            link.send(b"HI\r")
            got = json.loads(read_line(recv))
            assert got["frame"] == "48 49 0D", got
            recv.wait(timeout=5)
            sent = subprocess.run(
                [si_cli, "--port", b, "ascii", "send", "4F", "4B", "0D"], capture_output=True, timeout=10
            )
            assert sent.returncode == 0, sent
            assert link.recv(timeout=2.0) == b"OK\r"
    finally:
        recv.kill()
        recv.wait()
