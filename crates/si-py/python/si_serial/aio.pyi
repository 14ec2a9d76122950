"""si_serial for asyncio: the same names, every job a coroutine (pyo3-async-runtimes on
si_serial's one runtime)."""

from types import TracebackType
from typing import Dict, List, Optional, Tuple, Type, final

from typing_extensions import disjoint_base

from . import UssEvent
from . import (
    BYTEORDER_BIG as BYTEORDER_BIG,
    BYTEORDER_BIG_SWAP as BYTEORDER_BIG_SWAP,
    BYTEORDER_LITTLE as BYTEORDER_LITTLE,
    BYTEORDER_LITTLE_SWAP as BYTEORDER_LITTLE_SWAP,
    ConfigError as ConfigError,
    DeviceException as DeviceException,
    InvalidResponseError as InvalidResponseError,
    ModbusSlave as ModbusSlave,
    ModbusStore as ModbusStore,
    NoResponseError as NoResponseError,
    ProtocolError as ProtocolError,
    SiError as SiError,
    Simulator as Simulator,
    TcpServer as TcpServer,
    Monitor as Monitor,
    WindowHost as WindowHost,
    WindowModule as WindowModule,
    decode_3964r as decode_3964r,
    decode_modbus_request as decode_modbus_request,
    decode_modbus_response as decode_modbus_response,
    decode_rk512 as decode_rk512,
    decode_uss as decode_uss,
    encode_3964r as encode_3964r,
    encode_modbus as encode_modbus,
    encode_uss as encode_uss,
    monitor_trace as monitor_trace,
)

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

@disjoint_base
class ModbusClient:
    """A Modbus client whose jobs are coroutines; arguments as in ``si_serial.ModbusClient``.
    Several jobs may be awaited at once: they run one after the other on the line."""

    @property
    def job_bound(self) -> float: ...
    async def read_coils(self, address: int, count: int, unit: int = 1) -> List[bool]: ...
    async def read_discrete_inputs(self, address: int, count: int, unit: int = 1) -> List[bool]: ...
    async def read_holding_registers(self, address: int, count: int, unit: int = 1) -> List[int]: ...
    async def read_input_registers(self, address: int, count: int, unit: int = 1) -> List[int]: ...
    async def write_single_coil(self, address: int, value: bool, unit: int = 1) -> None: ...
    async def write_single_register(self, address: int, value: int, unit: int = 1) -> None: ...
    async def read_exception_status(self, unit: int = 1) -> int: ...
    async def diagnostics(self, data: int = 0, unit: int = 1) -> int: ...
    async def get_comm_event_counter(self, unit: int = 1) -> Tuple[int, int]: ...
    async def get_comm_event_log(self, unit: int = 1) -> Tuple[int, int, int, List[int]]: ...
    async def write_multiple_coils(self, address: int, values: List[bool], unit: int = 1) -> None: ...
    async def write_multiple_registers(self, address: int, values: List[int], unit: int = 1) -> None: ...
    async def read_float(
        self, address: int, unit: int = 1, number_of_registers: int = 2, byteorder: int = 0, function: int = 3
    ) -> float: ...
    async def read_long(
        self,
        address: int,
        unit: int = 1,
        signed: bool = False,
        byteorder: int = 0,
        number_of_registers: int = 2,
        function: int = 3,
    ) -> int: ...
    async def write_float(
        self, address: int, value: float, unit: int = 1, number_of_registers: int = 2, byteorder: int = 0
    ) -> None: ...
    async def write_long(
        self,
        address: int,
        value: int,
        unit: int = 1,
        signed: bool = False,
        byteorder: int = 0,
        number_of_registers: int = 2,
    ) -> None: ...
    async def close(self) -> None: ...
    async def __aenter__(self) -> "ModbusClient": ...
    async def __aexit__(
        self,
        exc_type: Optional[Type[BaseException]],
        exc: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

@final
class RtuClient(ModbusClient):
    """A Modbus RTU master on ``port``; the keyword arguments of ``si_serial.RtuClient``.
    The port opens at once; the jobs are awaited."""

    def __new__(
        cls,
        port: str,
        *,
        baud: int = 9600,
        data_bits: int = 8,
        parity: str = "even",
        stop_bits: int = 1,
        mode: str = "normal",
        char_delay_multiplier: int = 1,
        response_timeout: float = 2.0,
        retries: int = 0,
        broadcast_turnaround: float = 0.1,
        rx_latency: Optional[float] = None,
        frame_end: str = "gap",
    ) -> "RtuClient": ...

@final
class TcpClient(ModbusClient):
    """A Modbus TCP client: ``client = await TcpClient.connect(host, port)``."""

    @staticmethod
    async def connect(
        host: str, port: int = 502, *, response_timeout: float = 2.0, retries: int = 0
    ) -> "TcpClient": ...

class Link3964R:
    """A 3964(R) link; the arguments of ``si_serial.Link3964R``; jobs awaited."""

    def __init__(self, port: str, **kwargs: object) -> None: ...
    async def send(self, data: bytes) -> None: ...
    async def recv(self, timeout: Optional[float] = None) -> bytes: ...
    async def close(self) -> None: ...
    async def __aenter__(self) -> "Link3964R": ...
    async def __aexit__(self, *exc: object) -> bool: ...

class AsciiLink:
    """The ASCII driver; the arguments of ``si_serial.AsciiLink``; jobs awaited."""

    def __init__(self, port: str, **kwargs: object) -> None: ...
    async def send(self, data: bytes) -> None: ...
    async def recv(self, timeout: Optional[float] = None) -> bytes: ...
    async def close(self) -> None: ...
    async def __aenter__(self) -> "AsciiLink": ...
    async def __aexit__(self, *exc: object) -> bool: ...

class Rk512Station:
    """An RK 512 station; the arguments of ``si_serial.Rk512Station``; jobs awaited."""

    def __init__(self, port: str, **kwargs: object) -> None: ...
    async def send(self, area: str, start: int, data: bytes) -> None: ...
    async def fetch(self, area: str, start: int, length: int) -> bytes: ...
    def read_memory(self, area: str, start: int, count: int) -> bytes: ...
    def write_memory(self, area: str, start: int, data: bytes) -> None: ...
    async def close(self) -> None: ...
    async def __aenter__(self) -> "Rk512Station": ...
    async def __aexit__(self, *exc: object) -> bool: ...

class UssMaster:
    """The USS master; the arguments of ``si_serial.UssMaster``; parameter jobs awaited."""

    def __init__(self, port: str, nodes: List[Tuple[int, int, int]], **kwargs: object) -> None: ...
    async def read_parameter(self, node: int, number: int, index: int = 0) -> int: ...
    async def write_parameter(
        self, node: int, number: int, value: int, index: int = 0, double: bool = False
    ) -> int: ...
    def set_control(self, node: int, words: List[int]) -> None: ...
    def get_status(self, node: int) -> List[int]: ...
    async def next_event(self, timeout: float = 1.0) -> Optional[UssEvent]:
        """The next event of the cycle, waiting up to ``timeout`` seconds; None if none came."""
    async def close(self) -> None: ...
    async def __aenter__(self) -> "UssMaster": ...
    async def __aexit__(self, *exc: object) -> bool: ...
