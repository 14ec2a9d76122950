"""si_serial for asyncio: the same names, every job a coroutine.

``RtuClient(...)`` opens its port at once and its jobs are awaited;
``await TcpClient.connect(host, port)`` connects. Both are async context managers. The
exceptions are si_serial's. Classes that never wait on the line (``ModbusStore``,
``ModbusSlave``, ``TcpServer``, ``Simulator``) are si_serial's own, re-exported.
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
    ModbusSlave,
    ModbusStore,
    NoResponseError,
    ProtocolError,
    SiError,
    Simulator,
    TcpServer,
)

ModbusClient = _si_serial._aio.ModbusClient
RtuClient = _si_serial._aio.RtuClient
TcpClient = _si_serial._aio.TcpClient

__all__ = [
    "BYTEORDER_BIG",
    "BYTEORDER_BIG_SWAP",
    "BYTEORDER_LITTLE",
    "BYTEORDER_LITTLE_SWAP",
    "ConfigError",
    "DeviceException",
    "InvalidResponseError",
    "ModbusClient",
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
