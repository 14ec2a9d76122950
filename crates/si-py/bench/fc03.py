"""FC03 (10 registers) in a blocking Python loop: si-serial vs pymodbus vs minimalmodbus.

One socat pty pair at 115200 bit/s (8N2: pyserial cannot set parity on a pty), one and the
same slave for all three clients: si-serial's ModbusSlave in a child process (so the slave
does not share the clients' GIL), answering as soon as a request is whole and its CRC checks
(frame_end="length"). Each client runs the loop for the same time; the result is
requests per second. Not a test: timing depends on the machine (see BENCHMARKS.md).

    python crates/si-py/bench/fc03.py [--seconds 5]
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time

# How si-serial's client ends a response: "length" (host extension: at the predicted length
# once the CRC checks) or "gap" (the module's 1 ms of silence at 115200 bit/s).
FRAME_END = os.environ.get("FRAME_END", "length")

SLAVE = r"""
import sys, time, si_serial
store = si_serial.ModbusStore(holding_registers=100)
store.set_registers("holding_registers", 0, list(range(10)))
with si_serial.ModbusSlave(sys.argv[1], address=1, store=store, baud=115200, parity="none",
                           stop_bits=2, rx_latency=0, frame_end="length"):
    print("ready", flush=True)
    sys.stdin.read()
"""


def loop(name, read, seconds):
    assert read() == list(range(10)), name
    n, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        read()
        n += 1
    rate = n / (time.perf_counter() - start)
    print(f"{name:14s} {rate:8.1f} requests/s  ({n} in {seconds} s)", flush=True)
    return rate


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=5.0)
    args = parser.parse_args()
    d = tempfile.mkdtemp(prefix="si-bench-")
    a, b = os.path.join(d, "a"), os.path.join(d, "b")
    socat = subprocess.Popen(["socat", f"pty,raw,echo=0,link={a}", f"pty,raw,echo=0,link={b}"])
    slave = None
    try:
        while not (os.path.exists(a) and os.path.exists(b)):
            time.sleep(0.01)
        slave = subprocess.Popen([sys.executable, "-c", SLAVE, b], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert "ready" in slave.stdout.readline()
        results = {}

        import si_serial

        with si_serial.RtuClient(a, baud=115200, parity="none", stop_bits=2, response_timeout=1.0, rx_latency=0,
                                frame_end=FRAME_END) as c:
            results["si-serial"] = loop("si-serial", lambda: c.read_holding_registers(0, 10, unit=1), args.seconds)

        from pymodbus.client import ModbusSerialClient

        client = ModbusSerialClient(a, baudrate=115200, parity="N", stopbits=2, bytesize=8, timeout=1, retries=0)
        client.connect()
        try:
            results["pymodbus"] = loop(
                "pymodbus", lambda: client.read_holding_registers(0, count=10, device_id=1).registers, args.seconds
            )
        finally:
            client.close()

        import minimalmodbus

        inst = minimalmodbus.Instrument(a, 1)
        inst.serial.baudrate = 115200
        inst.serial.parity = "N"
        inst.serial.stopbits = 2
        inst.serial.timeout = 1.0
        try:
            results["minimalmodbus"] = loop("minimalmodbus", lambda: inst.read_registers(0, 10), args.seconds)
        finally:
            inst.serial.close()

        si = results["si-serial"]
        print(f"si-serial / pymodbus = {si / results['pymodbus']:.2f}x, "
              f"si-serial / minimalmodbus = {si / results['minimalmodbus']:.2f}x")
    finally:
        if slave:
            slave.stdin.close()
            slave.wait(timeout=5)
        socat.terminate()
        socat.wait()
        shutil.rmtree(d, ignore_errors=True)


if __name__ == "__main__":
    main()
