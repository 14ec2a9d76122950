"""USS master: parameters, PZD and the cycle's events against `si uss sim-slave` on a pty pair."""

import subprocess
import time

import pytest
import si_serial
from peers import wait_for_port


@pytest.fixture
def drive(pty_pair, si_cli):
    """`si uss sim-slave` at node 5 (PKW 4, PZD 2) on one end; the other end's path."""
    a, b = pty_pair
    proc = subprocess.Popen(
        [si_cli, "uss", "sim-slave", "--address", "5", "--port", b],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    wait_for_port(proc, b)
    yield a
    proc.kill()
    proc.wait()


def test_parameters_pzd_and_events_against_the_si_cli_drive(drive):
    with si_serial.UssMaster(drive, [(5, 4, 2)], response_timeout=0.1, rx_latency=0) as master:
        # P1082 (max frequency, 0 … 650, default 50) of the CLI's simulated drive.
        assert master.read_parameter(5, 1082) == 50
        assert master.write_parameter(5, 1082, 120) == 120
        assert master.read_parameter(5, 1082) == 120
        # P964 is read-only: the drive answers with a PKW error number.
        with pytest.raises(si_serial.DeviceException) as info:
            master.write_parameter(5, 964, 1)
        assert info.value.error_number is not None
        master.set_control(5, [0x047F, 1000])
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline:
            event = master.next_event(timeout=1.0)
            if event and event["kind"] == "response" and event["address"] == 5:
                break
        else:
            pytest.fail("no response event from node 5")
        assert len(master.get_status(5)) == 2


def test_a_silent_node_is_no_response(pty_pair):
    a, _ = pty_pair
    with si_serial.UssMaster(a, [(7, 4, 2)], response_timeout=0.02, retries=1, rx_latency=0) as master:
        with pytest.raises(si_serial.NoResponseError) as info:
            master.read_parameter(7, 1082)
        assert info.value.status in (0x1404, 0x1408)
        event = master.next_event(timeout=1.0)
        assert event is not None


def test_bad_arguments_name_the_keyword():
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.UssMaster("/nonexistent", [(40, 4, 2)])
    assert info.value.keyword == "nodes"
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.UssMaster("/nonexistent", [(1, 4, 2)], response_timeout=20.0)
    assert info.value.keyword == "response_timeout"
