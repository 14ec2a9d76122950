"""The monitors: over a trace file the simulator wrote, and over live bytes."""

import si_serial


def test_monitor_a_simulated_modbus_trace_file(tmp_path):
    sim = si_serial.Simulator()
    master = sim.add_modbus_master("master", response_timeout=0.5)
    slave = sim.add_modbus_slave("slave", address=1)
    sim.connect(master, slave)
    sim.write_multiple_registers(master, 0, [1, 2])
    sim.read_holding_registers(master, 0, 2)
    path = tmp_path / "line.jsonl"
    sim.write_trace(str(path))
    records = si_serial.monitor_trace(str(path), "modbus")
    frames = [r for r in records if r["kind"] == "frame"]
    assert [r["from"] for r in frames] == ["master", "slave", "master", "slave"]
    assert frames[2]["bytes"][:2] == b"\x01\x03"
    assert not any(f.startswith("!!") for r in frames for f in r["flags"])


def test_monitor_a_3964r_trace_file(tmp_path):
    sim = si_serial.Simulator()
    a, b = sim.add_3964r("a", priority="high"), sim.add_3964r("b")
    sim.connect(a, b)
    sim.send(a, b"hello")
    path = tmp_path / "line.jsonl"
    sim.write_trace(str(path))
    labels = [r["label"] for r in si_serial.monitor_trace(str(path), "3964r")]
    assert "STX" in labels and "DLE" in labels


def test_live_bytes_with_a_bad_crc():
    monitor = si_serial.Monitor("modbus", stations=["master", "slave"], baud=19200)
    request = si_serial.encode_modbus(1, b"\x03\x00\x00\x00\x01")
    records = monitor.push(request, at=0.010, station=0)
    records += monitor.idle(0.020)
    bad = bytearray(si_serial.encode_modbus(1, b"\x03\x02\x12\x34"))
    bad[-1] ^= 0xFF
    records += monitor.push(bytes(bad), at=0.030, station=1)
    records += monitor.idle(0.050)
    frames = [r for r in records if r["kind"] == "frame"]
    assert frames[0]["from"] == "master" and frames[0]["bytes"] == request
    assert any(f.startswith("!!") for f in frames[-1]["flags"])
    assert monitor.counters()
