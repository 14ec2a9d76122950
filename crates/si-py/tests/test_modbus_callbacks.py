"""Values of si's Modbus slave and TCP server from Python callbacks (`on_read`, `on_write`),
with pymodbus's and minimalmodbus's clients against them.

A callback that raises is answered with exception 04, SERVER DEVICE FAILURE
([Modbus AP] §7), and the slave keeps serving."""

import threading

import minimalmodbus
import pytest
import si_serial


class Device:
    """A simulated device: holding registers computed on read, writes recorded; fails for
    holding registers 97 … 99 and for coils."""

    def __init__(self):
        self.reads = []
        self.writes = []
        self.threads = set()

    def on_read(self, table, address, count):
        self.threads.add(threading.get_ident())
        self.reads.append((table, address, count))
        if table == "coils":
            raise RuntimeError("the coils are broken")
        if table == "holding_registers" and address == 99:
            raise RuntimeError("register 99 is broken")
        if table == "holding_registers" and address == 98:
            return [1, 2, 3]  # not `count` values
        if table == "input_registers":
            return None  # served from the store
        if table == "holding_registers" and address == 97:
            return [70000] * count  # not a register value
        if table == "discrete_inputs":
            return (i % 2 for i in range(count))  # any iterable; bits by truth
        return [1000 + address + i for i in range(count)]

    def on_write(self, table, address, values):
        if address == 77:
            raise ValueError("read-only register 77")
        self.writes.append((table, address, list(values)))


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_pymodbus_serial_client_against_si_slave_with_callbacks(pty_pair):
    from pymodbus.client import ModbusSerialClient

    a, b = pty_pair
    device = Device()
    store = si_serial.ModbusStore(holding_registers=100, input_registers=10)
    store.set_registers("input_registers", 0, [7, 8])
    with si_serial.ModbusSlave(
        b, address=17, store=store, baud=19200, parity="none", stop_bits=2, rx_latency=0,
        on_read=device.on_read, on_write=device.on_write,
    ):
        client = ModbusSerialClient(a, baudrate=19200, parity="N", stopbits=2, bytesize=8, timeout=1, retries=0)
        assert client.connect()
        try:
            r = client.read_holding_registers(10, count=3, device_id=17)
            assert not r.isError(), r
            assert r.registers == [1010, 1011, 1012]
            assert device.reads[-1] == ("holding_registers", 10, 3)

            # None from on_read: the store answers.
            r = client.read_input_registers(0, count=2, device_id=17)
            assert not r.isError(), r
            assert r.registers == [7, 8]

            r = client.read_discrete_inputs(0, count=4, device_id=17)
            assert not r.isError(), r
            assert r.bits[:4] == [False, True, False, True]

            # A raising callback: exception 04, SERVER DEVICE FAILURE.
            r = client.read_holding_registers(99, count=1, device_id=17)
            assert r.isError() and r.exception_code == 4, r
            r = client.read_coils(0, count=8, device_id=17)
            assert r.isError() and r.exception_code == 4, r
            # Three values for a request of one, or a value beyond 16 bits: exception 04 too.
            r = client.read_holding_registers(98, count=1, device_id=17)
            assert r.isError() and r.exception_code == 4, r
            r = client.read_holding_registers(97, count=1, device_id=17)
            assert r.isError() and r.exception_code == 4, r

            # A write goes to on_write, then into the store.
            r = client.write_registers(50, [5, 6, 7], device_id=17)
            assert not r.isError(), r
            assert device.writes[-1] == ("holding_registers", 50, [5, 6, 7])
            assert store.get_registers("holding_registers", 50, 3) == [5, 6, 7]
            r = client.write_coil(3, True, device_id=17)
            assert not r.isError(), r
            assert device.writes[-1] == ("coils", 3, [True])

            # A refused write: exception 04, the store unchanged.
            r = client.write_register(77, 1, device_id=17)
            assert r.isError() and r.exception_code == 4, r
            assert store.get_registers("holding_registers", 77, 1) == [0]

            # The slave still serves after every failure.
            r = client.read_holding_registers(0, count=1, device_id=17)
            assert not r.isError(), r
            assert r.registers == [1000]
        finally:
            client.close()
    # Called on the runtime's threads, never on this one.
    assert threading.get_ident() not in device.threads


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_minimalmodbus_instrument_against_si_slave_with_callbacks(pty_pair):
    a, b = pty_pair
    written = {}

    def on_write(table, address, values):
        for i, v in enumerate(values):
            written[address + i] = v

    def on_read(table, address, count):
        if address == 99:
            raise LookupError("no register 99")
        return [written.get(address + i, 0xBEEF) for i in range(count)]

    with si_serial.ModbusSlave(b, address=5, baud=19200, parity="none", stop_bits=2, rx_latency=0,
                               on_read=on_read, on_write=on_write):
        instrument = minimalmodbus.Instrument(a, 5)
        instrument.serial.baudrate = 19200
        instrument.serial.parity = "N"
        instrument.serial.stopbits = 2
        instrument.serial.timeout = 1.0
        try:
            assert instrument.read_register(3) == 0xBEEF
            instrument.write_float(20, 3.25)
            assert instrument.read_float(20) == 3.25
            # Exception 04 is none of minimalmodbus's named codes: its base class.
            with pytest.raises(minimalmodbus.SlaveReportedException) as raised:
                instrument.read_register(99)
            assert not isinstance(raised.value, (minimalmodbus.IllegalRequestError,
                                                 minimalmodbus.SlaveDeviceBusyError))
            assert instrument.read_register(3) == 0xBEEF
        finally:
            instrument.serial.close()


def test_tcp_server_values_from_a_callback(monkeypatch):
    """A raising callback: exception 04 to the client, the Python exception to
    `sys.unraisablehook`."""
    import sys

    from pymodbus.client import ModbusTcpClient

    unraisable = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)

    def on_read(table, address, count):
        if address >= 10:
            raise KeyError(address)
        return list(range(address, address + count))

    with si_serial.TcpServer(on_read=on_read) as server:
        client = ModbusTcpClient("127.0.0.1", port=server.port, timeout=1, retries=0)
        assert client.connect()
        try:
            r = client.read_holding_registers(2, count=3, device_id=1)
            assert not r.isError(), r
            assert r.registers == [2, 3, 4]
            r = client.read_holding_registers(10, count=1, device_id=1)
            assert r.isError() and r.exception_code == 4, r
            assert [type(u.exc_value) for u in unraisable] == [KeyError]
            assert unraisable[0].object is on_read
            r = client.read_holding_registers(0, count=1, device_id=1)
            assert r.registers == [0]
        finally:
            client.close()


def test_a_callback_that_is_not_callable_is_refused(pty_pair):
    _, b = pty_pair
    with pytest.raises(si_serial.ConfigError, match="on_read"):
        si_serial.ModbusSlave(b, on_read=42)
    with pytest.raises(si_serial.ConfigError, match="on_write"):
        si_serial.TcpServer(on_write="not a function")
