"""Every protocol against the deterministic simulator, in virtual time, with the trace."""

import pytest
import si_serial


def test_modbus_master_and_slave_with_simatic_memory():
    sim = si_serial.Simulator(seed=1)
    store = si_serial.ModbusStore.simatic()
    master = sim.add_modbus_master("master", response_timeout=0.5)
    slave = sim.add_modbus_slave("slave", address=1, store=store)
    sim.connect(master, slave)
    sim.write_multiple_registers(master, 0, [0x1234, 0x5678])
    assert store.read_memory("DB6", 0, 4) == b"\x12\x34\x56\x78"
    assert sim.read_holding_registers(master, 0, 2) == [0x1234, 0x5678]
    # Register 512 is DB7.DBW0, above DB_Max = 6: exception 02 ([Modbus/USS] Table 3-20).
    with pytest.raises(si_serial.DeviceException) as info:
        sim.write_multiple_registers(master, 512, [1])
    assert info.value.exception_code == 2
    trace = sim.trace()
    assert trace[0]["kind"] == "tx" and trace[0]["station"] == "master"
    assert trace[0]["bytes"][:2] == b"\x01\x10"
    assert all(r["at"] <= sim.now for r in trace)


def test_modbus_silent_unit_times_out_in_virtual_time():
    sim = si_serial.Simulator()
    master = sim.add_modbus_master("master", response_timeout=0.1)
    slave = sim.add_modbus_slave("slave", address=1)
    sim.connect(master, slave)
    with pytest.raises(si_serial.NoResponseError) as info:
        sim.read_holding_registers(master, 0, 1, unit=9)
    assert info.value.status == 0x0830
    assert 0.1 <= sim.now < 1.0


def test_3964r_both_ways():
    sim = si_serial.Simulator()
    a = sim.add_3964r("a", priority="high")
    b = sim.add_3964r("b", priority="low")
    sim.connect(a, b)
    sim.send(a, b"hello")
    assert sim.recv(b) == b"hello"
    sim.send(b, b"\x10\x10")
    assert sim.recv(a) == b"\x10\x10"
    kinds = {r["kind"] for r in sim.trace()}
    assert {"tx", "rx"} <= kinds


def test_3964r_without_partner_gives_up_with_the_status():
    sim = si_serial.Simulator()
    a = sim.add_3964r("a")
    b = sim.add_ascii("silent")  # a partner that never answers STX with DLE
    sim.connect(a, b)
    with pytest.raises(si_serial.NoResponseError) as info:
        sim.send(a, b"x")
    assert info.value.status == 0x0703


def test_ascii_end_character():
    sim = si_serial.Simulator()
    a = sim.add_ascii("a")
    b = sim.add_ascii("b", end_char=0x0D)
    sim.connect(a, b)
    sim.send(a, b"one\rtwo\r")
    assert sim.recv(b) == b"one\r"
    assert sim.recv(b) == b"two\r"
    with pytest.raises(si_serial.NoResponseError):
        sim.recv(b, timeout=0.5)


def test_rk512_send_fetch_and_passive_memory():
    sim = si_serial.Simulator()
    host = sim.add_rk512("host", priority="high")
    plc = sim.add_rk512("plc", dbs={2: 64})
    sim.connect(host, plc)
    sim.rk512_send(host, "DB2", 1, b"\xab\xcd")
    assert sim.read_memory(plc, "DB2", 2, 2) == b"\xab\xcd"
    assert sim.rk512_fetch(host, "DB2", 1, 2) == b"\xab\xcd"
    with pytest.raises(si_serial.DeviceException) as info:
        sim.rk512_fetch(host, "DB3", 0, 2)
    assert info.value.status == 0x0903


def test_uss_master_and_drive_on_a_bus():
    sim = si_serial.Simulator()
    # Two-wire RS-485: every station hears its own sending and drops it.
    master = sim.add_uss_master("master", [(5, 4, 2)], local_echo=True)
    drive = sim.add_uss_drive("drive", address=5, local_echo=True)
    sim.bus([master, drive])
    assert sim.read_parameter(master, 5, 1082) == 50
    sim.run_for(0.5)
    assert any(r["station"] == "drive" and r["kind"] == "tx" for r in sim.trace())


def test_wrong_station_kind_is_a_config_error():
    sim = si_serial.Simulator()
    a = sim.add_ascii("a")
    with pytest.raises(si_serial.ConfigError) as info:
        sim.read_holding_registers(a, 0, 1)
    assert info.value.keyword == "station"
