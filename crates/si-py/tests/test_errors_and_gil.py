"""The exception tree, a silent partner's bound, and the GIL released while a job waits."""

import os
import threading
import time

import pytest
import si_serial


def test_exception_tree():
    assert issubclass(si_serial.SiError, OSError)
    for cls in (
        si_serial.NoResponseError,
        si_serial.InvalidResponseError,
        si_serial.ProtocolError,
        si_serial.DeviceException,
    ):
        assert issubclass(cls, si_serial.SiError)
    assert issubclass(si_serial.ConfigError, ValueError)


@pytest.mark.parametrize(
    "kwargs, keyword, value",
    [
        ({"response_timeout": 0.01}, "response_timeout", "10"),
        ({"char_delay_multiplier": 11}, "char_delay_multiplier", "11"),
        ({"baud": 1234}, "baud", "1234"),
        ({"mode": "fast"}, "mode", '"fast"'),
        ({"retries": 300}, "retries", "300"),
        ({"response_timeout": -1.0}, "response_timeout", "-1"),
    ],
)
def test_a_bad_argument_raises_config_error_naming_it(kwargs, keyword, value):
    # The config is checked before the port is opened: no such port is needed.
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.RtuClient("/nonexistent", **kwargs)
    e = info.value
    assert e.keyword == keyword
    assert str(e).startswith(keyword)
    assert e.value == value
    assert e.range
    assert e.range in str(e)


def test_the_response_time_range_and_status_come_from_the_manual():
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.RtuClient("/nonexistent", response_timeout=0.049)
    # [Modbus/USS] §3.4.3, Table 3-17: 50 … 655000 ms; 0E23H.
    assert info.value.range == "50 … 655000 ms"
    assert info.value.status == 0x0E23
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.ModbusSlave("/nonexistent", address=0)
    assert info.value.keyword == "address"


def test_a_refused_job_is_a_config_error_with_its_status(pty_pair):
    a, _ = pty_pair
    with si_serial.RtuClient(a, rx_latency=0) as client:
        with pytest.raises(si_serial.ConfigError) as info:
            client.read_holding_registers(0, 128)
        assert info.value.status == 0x0E45
        with pytest.raises(si_serial.ConfigError) as info:
            client.read_holding_registers(-1, 1)
        assert info.value.keyword == "address"


def test_a_silent_partner_raises_no_response_error_within_the_bound(pty_pair):
    a, _ = pty_pair
    with si_serial.RtuClient(a, baud=19200, response_timeout=0.1, rx_latency=0) as client:
        start = time.monotonic()
        with pytest.raises(si_serial.NoResponseError) as info:
            client.read_holding_registers(0, 10, unit=3)
        elapsed = time.monotonic() - start
    assert info.value.status == 0x0830
    assert "response" in info.value.status_text
    # The documented bound: job_bound (si-modbus "Bounds"); and not before the response time.
    assert 0.1 <= elapsed <= client.job_bound, (elapsed, client.job_bound)


def _answer_once(path, answer):
    """Reads one 8-byte request from the pty `path` and writes `answer` (a fake slave)."""
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
    try:
        request = b""
        while len(request) < 8:
            request += os.read(fd, 8 - len(request))
        os.write(fd, answer)
    finally:
        os.close(fd)


@pytest.mark.parametrize(
    "answer, status",
    [
        # FC03 from unit 3, one register, its CRC's bytes swapped: 0E57H.
        (bytes.fromhex("03 03 02 00 2a 5b 40"), 0x0E57),
        # A well-formed answer to another function (FC04): 0E51H.
        (bytes.fromhex("03 04 02 00 2a 41 2f"), 0x0E51),
    ],
    ids=["crc", "function"],
)
def test_an_answer_failing_the_checks_raises_invalid_response_error(pty_pair, answer, status):
    # [Modbus/USS] §3.6: the response checks 0E50H-0E57H fail the job; not a silent partner.
    a, b = pty_pair
    with si_serial.RtuClient(a, response_timeout=1.0, rx_latency=0) as client:
        slave = threading.Thread(target=_answer_once, args=(b, answer))
        slave.start()
        try:
            with pytest.raises(si_serial.InvalidResponseError) as info:
                client.read_holding_registers(0, 1, unit=3)
        finally:
            slave.join(timeout=5)
    assert info.value.status == status


def test_the_gil_is_released_while_a_job_waits(pty_pair):
    a, _ = pty_pair
    counted = 0
    stop = threading.Event()

    def count():
        nonlocal counted
        while not stop.is_set():
            counted += 1

    with si_serial.RtuClient(a, response_timeout=0.3, rx_latency=0) as client:
        counter = threading.Thread(target=count)
        counter.start()
        try:
            time.sleep(0.05)
            before = counted
            with pytest.raises(si_serial.NoResponseError):
                client.read_holding_registers(0, 1, unit=9)
            during = counted - before
        finally:
            stop.set()
            counter.join()
    # 0.3 s of waiting: a thread that could not run would not count at all.
    assert during > 10_000, during


def test_a_closed_client_raises_protocol_error(pty_pair):
    a, _ = pty_pair
    client = si_serial.RtuClient(a, rx_latency=0)
    client.close()
    client.close()
    with pytest.raises(si_serial.ProtocolError):
        client.read_coils(0, 1)


def test_a_with_block_keeps_its_own_exception_and_closes_the_slave(pty_pair):
    a, _ = pty_pair
    with pytest.raises(KeyError, match="the test's own"):
        with si_serial.ModbusSlave(a, address=1) as slave:
            raise KeyError("the test's own")
    # Closed by __exit__: the port is free for the next user.
    slave.close()
    si_serial.ModbusSlave(a, address=1).close()

def test_a_device_exception_carries_its_code():
    with si_serial.TcpServer(store=si_serial.ModbusStore(holding_registers=10)) as server:
        with si_serial.TcpClient("127.0.0.1", server.port) as client:
            with pytest.raises(si_serial.DeviceException) as info:
                client.read_holding_registers(8, 5)
    assert info.value.exception_code == 2
    assert info.value.status == 0x0E62
