"""Modbus RTU against the `si` CLI on a pty pair: si_serial's client against `si modbus
serve`, and `si modbus read`/`write` against si_serial's slave."""

import json
import subprocess

import si_serial
from peers import wait_for_port


def test_client_against_si_modbus_serve(pty_pair, si_cli):
    a, b = pty_pair
    serve = subprocess.Popen([si_cli, "--port", b, "modbus", "serve", "--unit", "1"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for_port(serve, b)
        with si_serial.RtuClient(a, response_timeout=1.0, rx_latency=0) as client:
            # The CLI serves S_MODB's example conversion DB: registers are DB6 (Table 3-20).
            client.write_multiple_registers(0, [0x1234, 0x5678])
            assert client.read_holding_registers(0, 2) == [0x1234, 0x5678]
            assert client.diagnostics(0xA537) == 0xA537
    finally:
        serve.kill()
        serve.wait()


def test_si_modbus_read_and_write_against_the_slave(pty_pair, si_cli):
    a, b = pty_pair
    store = si_serial.ModbusStore(holding_registers=100)
    store.set_registers("holding_registers", 10, [111, 222])
    with si_serial.ModbusSlave(b, address=3, store=store, rx_latency=0):
        read = subprocess.run(
            [si_cli, "--json", "--port", a, "modbus", "read", "holding", "-u", "3", "--addr", "10", "--count", "2"],
            capture_output=True, text=True, timeout=20,
        )
        assert read.returncode == 0, read
        assert "111" in read.stdout and "222" in read.stdout, read.stdout
        json.loads(read.stdout.splitlines()[0])
        write = subprocess.run(
            [si_cli, "--port", a, "modbus", "write", "registers", "-u", "3", "--addr", "20", "7", "8"],
            capture_output=True, text=True, timeout=20,
        )
        assert write.returncode == 0, write
        assert store.get_registers("holding_registers", 20, 2) == [7, 8]
