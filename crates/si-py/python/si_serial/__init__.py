"""si for Python: the SIMATIC ET 200S serial interface protocols for test rigs.

Blocking clients that release the GIL while they wait, on one shared runtime. Times are float
seconds. Every failure is an :class:`SiError` carrying the manual's STATUS word, every bad
parameter a :class:`ConfigError` (a :class:`ValueError`) naming the parameter, its range and
the value.
"""

from ._si_serial import (
    BYTEORDER_BIG,
    BYTEORDER_BIG_SWAP,
    BYTEORDER_LITTLE,
    BYTEORDER_LITTLE_SWAP,
    ConfigError,
    DeviceException,
    InvalidResponseError,
    ModbusClient,
    ModbusSlave,
    ModbusStore,
    NoResponseError,
    ProtocolError,
    RtuClient,
    SiError,
    TcpClient,
    TcpServer,
)

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
    "TcpClient",
    "TcpServer",
]
