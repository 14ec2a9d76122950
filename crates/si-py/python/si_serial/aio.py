"""si_serial for asyncio: the same names, every job a coroutine.

``RtuClient(...)``, ``Link3964R(...)``, ``AsciiLink(...)``, ``Rk512Station(...)`` and
``UssMaster(...)`` open their port at once and their line jobs are awaited;
``await TcpClient.connect(host, port)`` connects. Both are async context managers. The
exceptions are si_serial's. What never waits on a line (``ModbusStore``, ``ModbusSlave``,
``TcpServer``, ``Simulator``, ``Monitor``, ``monitor_trace``, ``WindowHost``,
``WindowModule``, the frame functions) is si_serial's own, re-exported.
"""

from . import _si_serial
from ._si_serial import (  # noqa: F401 (re-exported)
    BYTEORDER_BIG,
    BYTEORDER_BIG_SWAP,
    BYTEORDER_LITTLE,
    BYTEORDER_LITTLE_SWAP,
    ConfigError,
    DeviceException,
    InvalidResponseError,
    Monitor,
    ModbusSlave,
    ModbusStore,
    NoResponseError,
    ProtocolError,
    SiError,
    Simulator,
    TcpServer,
    WindowHost,
    WindowModule,
    decode_3964r,
    decode_modbus_request,
    decode_modbus_response,
    decode_rk512,
    decode_uss,
    encode_3964r,
    encode_modbus,
    encode_uss,
    monitor_trace,
)

ModbusClient = _si_serial._aio.ModbusClient
RtuClient = _si_serial._aio.RtuClient
TcpClient = _si_serial._aio.TcpClient



class _Link:
    """Wraps a blocking class: the port opens in the constructor, the line jobs are awaited
    (each runs on the shared runtime, the event loop keeps running)."""

    _blocking = None

    def __init__(self, *args, **kwargs):
        self._link = self._blocking(*args, **kwargs)

    async def close(self):
        """Stops and releases the port. Idempotent."""
        await self._link._aio_close()

    async def __aenter__(self):
        return self

    async def __aexit__(self, *exc):
        await self.close()
        return False


class Link3964R(_Link):
    """A 3964(R) link; the arguments of ``si_serial.Link3964R``."""

    _blocking = _si_serial.Link3964R

    async def send(self, data):
        """Sends one block; returns once the partner acknowledged it."""
        await self._link._aio_send(data)

    async def recv(self, timeout=None):
        """The next block, within ``timeout`` seconds (None: for ever)."""
        return await self._link._aio_recv(timeout)


class AsciiLink(_Link):
    """The ASCII driver; the arguments of ``si_serial.AsciiLink``."""

    _blocking = _si_serial.AsciiLink

    async def send(self, data):
        """Sends one frame."""
        await self._link._aio_send(data)

    async def recv(self, timeout=None):
        """The next frame, within ``timeout`` seconds (None: for ever)."""
        return await self._link._aio_recv(timeout)


class Rk512Station(_Link):
    """An RK 512 station; the arguments of ``si_serial.Rk512Station``."""

    _blocking = _si_serial.Rk512Station

    async def send(self, area, start, data):
        """SEND ``data`` into the partner's ``area`` from ``start``."""
        await self._link._aio_send(area, start, data)

    async def fetch(self, area, start, length):
        """FETCH ``length`` bytes from the partner's ``area`` from ``start``."""
        return await self._link._aio_fetch(area, start, length)

    def read_memory(self, area, start, count):
        """Bytes of this station's own memory (not a line job: no await)."""
        return self._link.read_memory(area, start, count)

    def write_memory(self, area, start, data):
        """Writes this station's own memory (not a line job: no await)."""
        self._link.write_memory(area, start, data)


class UssMaster(_Link):
    """The USS master; the arguments of ``si_serial.UssMaster``."""

    _blocking = _si_serial.UssMaster

    async def read_parameter(self, node, number, index=0):
        """Reads parameter ``number`` of ``node``."""
        return await self._link._aio_read_parameter(node, number, index)

    async def write_parameter(self, node, number, value, index=0, double=False):
        """Writes parameter ``number`` of ``node``; returns the value answered."""
        return await self._link._aio_write_parameter(node, number, value, index, double)

    def set_control(self, node, words):
        """The PZD sent to ``node`` from the next poll on (no await)."""
        self._link.set_control(node, words)

    def get_status(self, node):
        """The PZD ``node`` answered last (no await)."""
        return self._link.get_status(node)

    async def next_event(self, timeout=1.0):
        """The next event of the cycle (a dict with ``kind``), waiting up to ``timeout``
        seconds; None if none came."""
        return await self._link._aio_next_event(timeout)


__all__ = [
    "AsciiLink",
    "Link3964R",
    "Rk512Station",
    "UssMaster",
    "BYTEORDER_BIG",
    "BYTEORDER_BIG_SWAP",
    "BYTEORDER_LITTLE",
    "BYTEORDER_LITTLE_SWAP",
    "ConfigError",
    "DeviceException",
    "InvalidResponseError",
    "ModbusClient",
    "Monitor",
    "WindowHost",
    "WindowModule",
    "decode_3964r",
    "decode_modbus_request",
    "decode_modbus_response",
    "decode_rk512",
    "decode_uss",
    "encode_3964r",
    "encode_modbus",
    "encode_uss",
    "monitor_trace",
    "ModbusSlave",
    "ModbusStore",
    "NoResponseError",
    "ProtocolError",
    "RtuClient",
    "SiError",
    "Simulator",
    "TcpClient",
    "TcpServer",
]
