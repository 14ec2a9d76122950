"""si_serial for asyncio: the same names, every job a coroutine (pyo3-async-runtimes on
si_serial's one runtime)."""

from types import TracebackType
from typing import List, Optional, Tuple, Type

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
)

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

class RtuClient(ModbusClient):
    """A Modbus RTU master on ``port``; the keyword arguments of ``si_serial.RtuClient``.
    The port opens at once; the jobs are awaited."""

    def __init__(
        self,
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
    ) -> None: ...

class TcpClient(ModbusClient):
    """A Modbus TCP client: ``client = await TcpClient.connect(host, port)``."""

    @staticmethod
    async def connect(
        host: str, port: int = 502, *, response_timeout: float = 2.0, retries: int = 0
    ) -> "TcpClient": ...
