"""The DP window host against the `si` CLI's simulated module (`si dp-coord module`), whose
line is one end of a socat pty pair with a si_serial 3964(R) link at the other; and the
monitor over traces the CLI recorded (`--record`)."""

import subprocess
import time

import pytest
import si_serial
from peers import read_line


class CliModule:
    """`si dp-coord module`: one DP cycle per line, the host's output window in, the
    module's input window out."""

    def __init__(self, si_cli, port):
        self.proc = subprocess.Popen(
            [si_cli, "--port", port, "dp-coord", "module", "--window", "8", "--protocol", "3964r"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )
        self.start = time.monotonic()
        self.input = bytes(8)

    def run(self, host, result, timeout=10.0):
        """DP cycles of about 2 ms until `result()` is not None."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            output = host.cycle(time.monotonic() - self.start, self.input)
            self.proc.stdin.write(output.hex() + "\n")
            self.proc.stdin.flush()
            self.input = bytes.fromhex(read_line(self.proc).strip())
            done = result()
            if done is not None:
                return done
            time.sleep(0.002)
        pytest.fail("the window job did not end")

    def close(self):
        self.proc.stdin.close()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def test_window_host_sends_and_receives_through_the_cli_module(pty_pair, si_cli):
    a, b = pty_pair
    module = CliModule(si_cli, a)
    # The CLI module has the low priority (its default): the partner takes the high one.
    with si_serial.Link3964R(b, priority="high", rx_latency=0) as partner:
        try:
            host = si_serial.WindowHost(window=8)
            sent = host.send(b"22 chars through an 8!")
            assert module.run(host, lambda: host.result(sent)) is True
            assert partner.recv(timeout=5.0) == b"22 chars through an 8!"

            partner.send(b"and back to the host")
            received = None

            def poll():
                nonlocal received
                if received is None:
                    received = host.receive()
                got = host.result(received)
                if got == b"":  # no message yet: ask again
                    received = None
                    return None
                return got

            assert module.run(host, poll) == b"and back to the host"
        finally:
            module.close()


def test_monitor_a_trace_the_cli_simulator_recorded(tmp_path, si_cli):
    path = tmp_path / "modbus.jsonl"
    run = subprocess.run([si_cli, "sim", "modbus", "--record", str(path)],
                         capture_output=True, text=True, timeout=30)
    assert run.returncode == 0, run
    frames = [r for r in si_serial.monitor_trace(str(path), "modbus") if r["kind"] == "frame"]
    # The scenario: FC16 write, FC03 read back, ..., last a request answered with exception 02.
    assert [f["from"] for f in frames] == ["master", "slave"] * (len(frames) // 2)
    assert frames[0]["bytes"][:2] == b"\x01\x10"
    assert frames[2]["bytes"][:2] == b"\x01\x03"
    assert frames[3]["bytes"][3:7] == frames[0]["bytes"][7:11]  # the registers written, read back
    flagged = [f for f in frames if any(flag.startswith("!!") for flag in f["flags"])]
    assert flagged == [frames[-1]] and frames[-1]["bytes"][1:3] == b"\x86\x02", flagged


def test_monitor_a_trace_the_cli_recorded_on_a_pty(pty_pair, tmp_path, si_cli):
    """`si modbus read --record` on a real (pty) line against si_serial's slave."""
    a, b = pty_pair
    path = tmp_path / "line.jsonl"
    store = si_serial.ModbusStore(holding_registers=100)
    store.set_registers("holding_registers", 10, [111, 222])
    with si_serial.ModbusSlave(b, address=3, store=store, rx_latency=0):
        read = subprocess.run(
            [si_cli, "--port", a, "modbus", "read", "holding", "-u", "3", "--addr", "10",
             "--count", "2", "--record", str(path)],
            capture_output=True, text=True, timeout=20,
        )
    assert read.returncode == 0, read
    frames = [r for r in si_serial.monitor_trace(str(path), "modbus") if r["kind"] == "frame"]
    assert len(frames) == 2, frames
    request, response = frames
    assert request["bytes"] == si_serial.encode_modbus(3, b"\x03\x00\x0a\x00\x02")
    assert response["bytes"] == si_serial.encode_modbus(3, b"\x03\x04\x00\x6f\x00\xde")
    assert response["start"] > request["end"]
