"""si-serial's Modbus RTU against pymodbus and minimalmodbus over a socat pty pair."""

import minimalmodbus
import pytest
import si_serial

PYMODBUS_SERVER = r"""
import sys
from pymodbus.server import StartSerialServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusDeviceContext
dev = ModbusDeviceContext(hr=ModbusSequentialDataBlock(1, list(range(100))),
                          co=ModbusSequentialDataBlock(1, [False] * 100))
ctx = ModbusServerContext(devices={1: dev}, single=False)
print("ready", flush=True)
StartSerialServer(context=ctx, port=sys.argv[1], baudrate=19200, parity="N", stopbits=2, bytesize=8)
"""


def test_si_client_reads_and_writes_pymodbus_serial_server(pty_pair, python_peer):
    a, b = pty_pair
    python_peer(PYMODBUS_SERVER, b)
    with si_serial.RtuClient(a, baud=19200, parity="none", stop_bits=2, response_timeout=1.0, rx_latency=0) as client:
        assert client.read_holding_registers(0, 10, unit=1) == list(range(10))
        client.write_multiple_registers(20, [0xBEEF, 0x1234], unit=1)
        assert client.read_holding_registers(20, 2, unit=1) == [0xBEEF, 0x1234]
        client.write_single_register(5, 777)
        assert client.read_holding_registers(5, 1) == [777]
        client.write_multiple_coils(3, [True, False, True])
        assert client.read_coils(3, 3) == [True, False, True]
        client.write_float(40, -2.5, byteorder=si_serial.BYTEORDER_LITTLE_SWAP)
        assert client.read_float(40, byteorder=si_serial.BYTEORDER_LITTLE_SWAP) == -2.5
        client.write_long(44, -5, signed=True)
        assert client.read_long(44, signed=True) == -5
        assert client.read_long(44) == 0xFFFFFFFB


def test_pymodbus_serial_client_against_si_slave(pty_pair):
    from pymodbus.client import ModbusSerialClient

    a, b = pty_pair
    store = si_serial.ModbusStore(holding_registers=100, coils=64)
    store.set_registers("holding_registers", 0, [11, 22, 33])
    with si_serial.ModbusSlave(b, address=17, store=store, baud=19200, parity="none", stop_bits=2, rx_latency=0) as slave:
        client = ModbusSerialClient(a, baudrate=19200, parity="N", stopbits=2, bytesize=8, timeout=1, retries=0)
        assert client.connect()
        try:
            r = client.read_holding_registers(0, count=3, device_id=17)
            assert not r.isError(), r
            assert r.registers == [11, 22, 33]
            r = client.write_registers(50, [5, 6, 7], device_id=17)
            assert not r.isError(), r
            assert store.get_registers("holding_registers", 50, 3) == [5, 6, 7]
            r = client.read_holding_registers(99, count=2, device_id=17)
            assert r.isError() and r.exception_code == 2
        finally:
            client.close()
        event = slave.next_event(timeout=1.0)
        assert event == {"kind": "served", "function": 3, "address": 0, "quantity": 3}


def test_minimalmodbus_instrument_against_si_slave(pty_pair):
    a, b = pty_pair
    store = si_serial.ModbusStore()
    with si_serial.ModbusSlave(b, address=5, store=store, baud=19200, parity="none", stop_bits=2, rx_latency=0):
        instrument = minimalmodbus.Instrument(a, 5)
        instrument.serial.baudrate = 19200
        instrument.serial.parity = "N"
        instrument.serial.stopbits = 2
        instrument.serial.timeout = 1.0
        try:
            instrument.write_register(10, 1234, functioncode=16)
            assert store.get_registers("holding_registers", 10, 1) == [1234]
            instrument.write_float(20, 3.25)
            assert instrument.read_float(20) == 3.25
            store.set_registers("holding_registers", 30, [0x0001, 0x0002])
            assert instrument.read_long(30) == 0x00010002
            instrument.write_bit(7, 1)
            assert store.get_bits("coils", 7, 1) == [True]
        finally:
            instrument.serial.close()


def test_si_client_against_si_slave_with_simatic_memory(pty_pair):
    """The slave serves S_MODB's example conversion DB: holding register 0 is DB6.DBW0
    ([Modbus/USS] §3.5.4, Table 3-20)."""
    a, b = pty_pair
    store = si_serial.ModbusStore.simatic()
    with si_serial.ModbusSlave(b, address=1, store=store, baud=19200, rx_latency=0):
        with si_serial.RtuClient(a, baud=19200, response_timeout=1.0, rx_latency=0) as client:
            client.write_multiple_registers(0, [0x1234, 0x5678])
            assert store.read_memory("DB6", 0, 4) == bytes([0x12, 0x34, 0x56, 0x78])
            store.write_memory("DB6", 4, b"\xab\xcd")
            assert client.read_holding_registers(2, 1) == [0xABCD]
