"""si for Python: the SIMATIC ET 200S serial interface protocols for test rigs.

Blocking calls release the GIL while they wait. Times are float seconds. Every failure is an
:class:`SiError` carrying the manual's STATUS word; every bad parameter a :class:`ConfigError`
naming the keyword, the manual's parameter, its range and the value.
"""

from types import TracebackType
from typing import Callable, Dict, Iterable, List, Optional, Tuple, Type, TypedDict, Union, final

from typing_extensions import disjoint_base

# The extension's public names, as `__init__.py` computes them at import.
__all__ = [
    "AsciiLink",
    "BYTEORDER_BIG",
    "BYTEORDER_BIG_SWAP",
    "BYTEORDER_LITTLE",
    "BYTEORDER_LITTLE_SWAP",
    "ConfigError",
    "DeviceException",
    "InvalidResponseError",
    "Link3964R",
    "ModbusClient",
    "ModbusSlave",
    "ModbusStore",
    "Monitor",
    "NoResponseError",
    "ProtocolError",
    "Rk512Station",
    "RtuClient",
    "SiError",
    "Simulator",
    "TcpClient",
    "TcpServer",
    "UssMaster",
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
]

BYTEORDER_BIG: int
"""ABCD: registers in order, each high byte first (minimalmodbus's constant)."""
BYTEORDER_LITTLE: int
"""DCBA: the whole value little-endian."""
BYTEORDER_BIG_SWAP: int
"""BADC: registers in order, bytes swapped within each."""
BYTEORDER_LITTLE_SWAP: int
"""CDAB: low register first, each high byte first."""

class SiError(OSError):
    """A job failed."""

    status: Optional[int]
    """The manual's STATUS word (e.g. 0x0830), None where the failure has none."""
    status_text: Optional[str]
    """The manual's meaning of the STATUS."""

class NoResponseError(SiError):
    """The partner did not answer within the configured time (Modbus 0830H)."""

class InvalidResponseError(SiError):
    """An answer failed the checks: CRC, BCC, length, byte count or echo."""

class ProtocolError(SiError):
    """The protocol gave up: NAK, retries exhausted, the line stopped or the client closed."""

# RK 512's 051AH "command telegram not sent" carries ``cause``: the 3964(R) STATUS behind
# it (e.g. 0703H), which also decides the exception's class.

class DeviceException(SiError):
    """The partner answered with an error."""

    exception_code: int
    """Modbus: the exception code (1 … 255)."""
    error_number: int
    """RK 512: the partner's error number (the STATUS's event number, class 09H); USS: the
    drive's PKW error number (response ID 7)."""

class ConfigError(ValueError):
    """A parameter is out of range. The message starts with the keyword argument."""

    keyword: str
    """The Python keyword argument (``response_timeout``)."""
    parameter: str
    """The parameter as the manual names it (``response time``)."""
    range: str
    """The allowed values (``50 … 655000 ms``)."""
    value: str
    """The value given, without its unit."""
    status: Optional[int]
    """The module's parameter-assignment STATUS (e.g. 0x0E23), None where it has none."""
    status_text: Optional[str]

@disjoint_base
class ModbusClient:
    """A Modbus client; build it as :class:`RtuClient` or :class:`TcpClient`.

    ``unit`` is the slave address (RTU) or unit id (TCP); 0 is a broadcast (writes only).
    Quantities follow the module's limits: 1 … 2040 bits, 1 … 127 registers (ConfigError with
    the STATUS 0E44H … 0E46H otherwise). A context manager; ``close()`` releases the port.
    """

    @property
    def job_bound(self) -> float:
        """The longest a job can take before it ends, in seconds (retries included)."""
    def read_coils(self, address: int, count: int, unit: int = 1) -> List[bool]:
        """FC01: ``count`` coils from ``address``."""
    def read_discrete_inputs(self, address: int, count: int, unit: int = 1) -> List[bool]:
        """FC02: ``count`` discrete inputs from ``address``."""
    def read_holding_registers(self, address: int, count: int, unit: int = 1) -> List[int]:
        """FC03: ``count`` holding registers from ``address``."""
    def read_input_registers(self, address: int, count: int, unit: int = 1) -> List[int]:
        """FC04: ``count`` input registers from ``address``."""
    def write_single_coil(self, address: int, value: bool, unit: int = 1) -> None:
        """FC05: one coil."""
    def write_single_register(self, address: int, value: int, unit: int = 1) -> None:
        """FC06: one register."""
    def read_exception_status(self, unit: int = 1) -> int:
        """FC07: the exception status byte."""
    def diagnostics(self, data: int = 0, unit: int = 1) -> int:
        """FC08 sub-function 0 (return query data): ``data`` echoed."""
    def get_comm_event_counter(self, unit: int = 1) -> Tuple[int, int]:
        """FC11: ``(status, event_count)``."""
    def get_comm_event_log(self, unit: int = 1) -> Tuple[int, int, int, List[int]]:
        """FC12: ``(status, event_count, message_count, events)``."""
    def write_multiple_coils(self, address: int, values: List[bool], unit: int = 1) -> None:
        """FC15: coils from ``address``."""
    def write_multiple_registers(self, address: int, values: List[int], unit: int = 1) -> None:
        """FC16: registers from ``address``."""
    def read_float(
        self,
        address: int,
        unit: int = 1,
        number_of_registers: int = 2,
        byteorder: int = 0,
        function: int = 3,
    ) -> float:
        """A float in 2 registers (a double in 4), read with FC03 (or FC04), in
        minimalmodbus's ``byteorder``."""
    def read_long(
        self,
        address: int,
        unit: int = 1,
        signed: bool = False,
        byteorder: int = 0,
        number_of_registers: int = 2,
        function: int = 3,
    ) -> int:
        """A 32-bit integer in 2 registers (64-bit in 4), in minimalmodbus's ``byteorder``."""
    def write_float(
        self,
        address: int,
        value: float,
        unit: int = 1,
        number_of_registers: int = 2,
        byteorder: int = 0,
    ) -> None:
        """Writes a float into 2 (or 4) registers with FC16."""
    def write_long(
        self,
        address: int,
        value: int,
        unit: int = 1,
        signed: bool = False,
        byteorder: int = 0,
        number_of_registers: int = 2,
    ) -> None:
        """Writes a 32-bit (or 64-bit) integer into 2 (or 4) registers with FC16."""
    def close(self) -> None:
        """Releases the port or connection; later calls raise ProtocolError. Idempotent."""
    def __enter__(self) -> "ModbusClient": ...
    def __exit__(
        self,
        exc_type: Optional[Type[BaseException]],
        exc: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

@final
class RtuClient(ModbusClient):
    """A Modbus RTU master on the serial port ``port``.

    Keyword arguments are the module's parameters ([Modbus/USS] §3.4.3, Table 3-17):
    ``baud`` (110 … 115200, one of the module's twelve rates), ``data_bits`` (8),
    ``parity`` ("none", "even", "odd", "mark", "space"), ``stop_bits`` (1 or 2), ``mode``
    ("normal" or "interference-suppression"), ``char_delay_multiplier`` (1 … 10),
    ``response_timeout`` (0.05 … 655 s), ``retries`` (0 … 255, an extension),
    ``broadcast_turnaround`` (seconds). ``rx_latency``: how late the port hands bytes over
    (0 for a pseudo-terminal or a byte-by-byte port; None: read from sysfs or assume a USB
    adapter). ``frame_end``: "gap" (the module's silence, Table 3-11) or "length" (a host
    extension: a response ends at its predicted length once its CRC checks).
    """

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
    def __enter__(self) -> "RtuClient": ...

@final
class TcpClient(ModbusClient):
    """A Modbus TCP client connected to ``host``:``port``."""

    def __new__(
        cls, host: str, port: int = 502, *, response_timeout: float = 2.0, retries: int = 0
    ) -> "TcpClient": ...
    def __enter__(self) -> "TcpClient": ...

@final
class ModbusStore:
    """The data a slave or server serves, shared with Python while it runs.

    ``ModbusStore(...)``: plain tables of the given sizes from address 0 (an access beyond
    the end is answered with exception 02). ``ModbusStore.simatic()``: S7 memory behind the
    example conversion DB of [Modbus/USS] §3.5.4, Table 3-20 (holding registers in DB6,
    input registers in DB2, coils on Q and M, inputs on I).
    """

    def __new__(
        cls,
        *,
        coils: int = 10000,
        discrete_inputs: int = 10000,
        holding_registers: int = 10000,
        input_registers: int = 10000,
    ) -> "ModbusStore": ...
    @staticmethod
    def simatic() -> "ModbusStore":
        """SIMATIC memory: DB1–DB6 (1024 bytes each), MB0–MB1255, QB0–QB127, IB0–IB127,
        T0–T255, C0–C255 behind the manual's example conversion DB."""
    def get_registers(self, table: str, address: int, count: int) -> List[int]:
        """``count`` registers of ``table`` ("holding_registers", "input_registers")."""
    def set_registers(self, table: str, address: int, values: List[int]) -> None:
        """Writes ``values`` into ``table`` from ``address``."""
    def get_bits(self, table: str, address: int, count: int) -> List[bool]:
        """``count`` bits of ``table`` ("coils", "discrete_inputs")."""
    def set_bits(self, table: str, address: int, values: List[bool]) -> None:
        """Writes ``values`` into ``table`` from ``address``."""
    def read_memory(self, area: str, start: int, count: int) -> bytes:
        """``count`` bytes of SIMATIC ``area`` ("DB1", "M", "Q", "I", "T", "C")."""
    def write_memory(self, area: str, start: int, data: bytes) -> None:
        """Writes ``data`` into SIMATIC ``area`` from byte ``start``."""

class SlaveEvent(TypedDict, total=False):
    """What a slave reports: ``kind`` is "served", "broadcast", "exception" or "error"."""

    kind: str
    function: int
    address: int
    quantity: int
    exception_code: int
    status: Optional[int]
    status_text: str

_OnRead = Callable[[str, int, int], Optional[Iterable[Union[int, bool]]]]
"""``on_read(table, address, count)``: ``count`` values of ``table`` ("coils",
"discrete_inputs", "holding_registers", "input_registers") from ``address`` (registers as
ints 0 … 65535, bits by their truth), or None to serve them from the store."""

_OnWrite = Callable[[str, int, List[Union[int, bool]]], object]
"""``on_write(table, address, values)``: sees a write ("coils" or "holding_registers")
before the store takes it; raising refuses it."""

@final
class ModbusSlave:
    """A Modbus RTU slave on the serial port ``port`` at ``address`` (1 … 255, default 222 as
    in [Modbus/USS] §3.5.4, Table 3-20), serving ``store`` (default: plain tables of 10000
    each) until ``close()``. Line keyword arguments as for :class:`RtuClient`.

    ``on_read`` / ``on_write`` put Python in front of the store (see :data:`_OnRead`,
    :data:`_OnWrite`). They run on the module's own threads, holding the GIL only while they
    run. A callback that raises, or returns other than ``count`` values, never stops the
    slave: the master gets exception 04, SERVER DEVICE FAILURE ([Modbus AP] §7), and the
    Python exception goes to ``sys.unraisablehook``.
    """

    def __new__(
        cls,
        port: str,
        *,
        address: int = 222,
        store: Optional[ModbusStore] = None,
        baud: int = 9600,
        data_bits: int = 8,
        parity: str = "even",
        stop_bits: int = 1,
        mode: str = "normal",
        char_delay_multiplier: int = 1,
        rx_latency: Optional[float] = None,
        frame_end: str = "gap",
        on_read: Optional[_OnRead] = None,
        on_write: Optional[_OnWrite] = None,
    ) -> "ModbusSlave": ...
    @property
    def store(self) -> ModbusStore: ...
    def next_event(self, timeout: float = 1.0) -> Optional[SlaveEvent]:
        """The next event, waiting up to ``timeout`` seconds (the newest 1024 are kept)."""
    def close(self) -> None:
        """Stops answering and releases the port (raises if the line failed). Idempotent."""
    def __enter__(self) -> "ModbusSlave": ...
    def __exit__(
        self,
        exc_type: Optional[Type[BaseException]],
        exc: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

@final
class TcpServer:
    """A Modbus TCP server on ``host``:``port`` (0: a free port, see ``.port``) serving
    ``store`` for every unit id, with ``on_read`` / ``on_write`` as for :class:`ModbusSlave`."""

    def __new__(
        cls,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        store: Optional[ModbusStore] = None,
        on_read: Optional[_OnRead] = None,
        on_write: Optional[_OnWrite] = None,
    ) -> "TcpServer": ...
    @property
    def store(self) -> ModbusStore: ...
    @property
    def port(self) -> int: ...
    def close(self) -> None:
        """Stops listening and closes every connection. Idempotent."""
    def __enter__(self) -> "TcpServer": ...
    def __exit__(
        self,
        exc_type: Optional[Type[BaseException]],
        exc: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

@final
class Link3964R:
    """A 3964(R) link on the serial port ``port`` ([ET200S SI] §2.9, Table 2-11).

    Keyword arguments: ``priority`` ("low" or "high"; the partners must differ),
    ``block_check`` (3964(R) with BCC, or plain 3964), ``char_delay`` ZVZ (0.02 … 655.35 s,
    default 0.22), ``ack_delay`` QVZ (0.01 … 655.35 s, default 2.0, 0.55 without block
    check), ``connection_attempts`` and ``transmission_attempts`` (1 … 255, default 6, the
    first included), ``max_block_len`` (1 … 1024 bytes, default 200),
    ``receive_buffer_blocks`` (1 … 255, default 5), the line (``baud``, ``data_bits``,
    ``parity``, ``stop_bits``) and ``rx_latency`` as for :class:`RtuClient`.
    """

    def __new__(
        cls,
        port: str,
        *,
        priority: str = "low",
        block_check: bool = True,
        char_delay: float = 0.22,
        ack_delay: Optional[float] = None,
        connection_attempts: int = 6,
        transmission_attempts: int = 6,
        max_block_len: int = 200,
        receive_buffer_blocks: int = 5,
        baud: int = 9600,
        data_bits: int = 8,
        parity: str = "even",
        stop_bits: int = 1,
        rx_latency: Optional[float] = None,
    ) -> "Link3964R": ...
    def send(self, data: bytes) -> None:
        """Sends ``data`` as one block and returns once the partner acknowledged it (DLE);
        NoResponseError for 0703H/0707H (QVZ exceeded), ProtocolError for a NAK (0702H,
        0705H, 0706H), ConfigError (1E41H) for an empty or overlong block."""
    def recv(self, timeout: Optional[float] = None) -> bytes:
        """The next block received, waiting up to ``timeout`` seconds (None: for ever);
        NoResponseError when none came, InvalidResponseError for a receive error (class 08H:
        BCC, character delay)."""
    def close(self) -> None:
        """Stops the link and releases the port. Idempotent."""
    def __enter__(self) -> "Link3964R": ...
    def __exit__(
        self,
        exc_type: Optional[Type[BaseException]],
        exc: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

@final
class AsciiLink:
    """The ASCII driver on the serial port ``port`` ([ET200S SI] §2.8, Table 2-10).

    The end of a received frame: ``end="char-delay"`` (a gap longer than ``char_delay``,
    the default), ``"end-chars"`` (``end_chars=(first, second)``, default ``(3, 0)``, second 0 =
    unused; the frame includes them) or ``"fixed-length"`` (``fixed_length`` characters). ``char_delay``
    (0.004 … 65.535 s, at least the manual's minimum for the baud rate), ``max_frame_len``
    (1 … 1024, default 200), ``flow_control`` ("none", "xon-xoff", "rts-cts", "auto-v24"),
    the line and ``rx_latency`` as for :class:`RtuClient`.
    """

    def __new__(
        cls,
        port: str,
        *,
        end: str = "char-delay",
        # (3, 0): the runtime signature cannot show a tuple default.
        end_chars: Tuple[int, int] = ...,
        fixed_length: int = 100,
        char_delay: float = 0.004,
        max_frame_len: int = 200,
        flow_control: str = "none",
        baud: int = 9600,
        data_bits: int = 8,
        parity: str = "even",
        stop_bits: int = 1,
        rx_latency: Optional[float] = None,
    ) -> "AsciiLink": ...
    def send(self, data: bytes) -> None:
        """Sends ``data`` as one frame (end characters are the caller's to include)."""
    def recv(self, timeout: Optional[float] = None) -> bytes:
        """The next frame, waiting up to ``timeout`` seconds (None: for ever);
        NoResponseError when none came, InvalidResponseError for a receive error (class 08H).
        A ``send`` from another thread waits while a ``recv`` waits."""
    def close(self) -> None:
        """Stops the link and releases the port. Idempotent."""
    def __enter__(self) -> "AsciiLink": ...
    def __exit__(
        self,
        exc_type: Optional[Type[BaseException]],
        exc: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

@final
class Rk512Station:
    """An RK 512 station on the serial port ``port`` ([CP 341] §2.2.3).

    The 3964(R) keyword arguments of :class:`Link3964R`, plus ``response_timeout`` (TRES,
    0.01 … 655.35 s, default 10) and ``max_job_len`` (2 … 65534 bytes). With ``serve=True``
    it is also the passive partner: it serves the other side's SEND and FETCH jobs from its
    own memory (``dbs`` {number: bytes}; ``inputs``, ``outputs``, ``flags`` in bytes,
    ``timers``, ``counters`` in cells). Areas: "DBn"/"DXn" (``start`` a data word), "I",
    "Q", "M" (a byte), "T", "C" (a cell).
    """

    def __new__(
        cls,
        port: str,
        *,
        serve: bool = False,
        dbs: Optional[Dict[int, int]] = None,
        inputs: Optional[int] = None,
        outputs: Optional[int] = None,
        flags: Optional[int] = None,
        timers: Optional[int] = None,
        counters: Optional[int] = None,
        response_timeout: float = 10.0,
        max_job_len: int = 1024,
        priority: str = "low",
        block_check: bool = True,
        char_delay: float = 0.22,
        ack_delay: Optional[float] = None,
        connection_attempts: int = 6,
        transmission_attempts: int = 6,
        max_block_len: int = 200,
        receive_buffer_blocks: int = 5,
        baud: int = 9600,
        data_bits: int = 8,
        parity: str = "even",
        stop_bits: int = 1,
        rx_latency: Optional[float] = None,
    ) -> "Rk512Station": ...
    def send(self, area: str, start: int, data: bytes) -> None:
        """SEND ``data`` into the partner's ``area`` from ``start``; returns on its reaction."""
    def fetch(self, area: str, start: int, length: int) -> bytes:
        """FETCH ``length`` bytes from the partner's ``area`` from ``start``."""
    def read_memory(self, area: str, start: int, count: int) -> bytes:
        """``count`` bytes of this station's own memory (``serve=True``) from byte ``start``."""
    def write_memory(self, area: str, start: int, data: bytes) -> None:
        """Writes ``data`` into this station's own memory from byte ``start``."""
    def close(self) -> None:
        """Stops the station and releases the port. Idempotent."""
    def __enter__(self) -> "Rk512Station": ...
    def __exit__(
        self,
        exc_type: Optional[Type[BaseException]],
        exc: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

class UssEvent(TypedDict, total=False):
    """A USS cycle event: ``kind`` is "response", "no_answer", "rejected", "cycle_done" or
    "other"."""

    kind: str
    cycle: int
    address: int
    pzd: List[int]
    status: int
    status_text: str
    text: str

@final
class UssMaster:
    """The USS master on the serial port ``port`` ([Modbus/USS] §3.8), polling ``nodes``
    (a list of ``(address 0 … 31, pkw_words 0/3/4/127, pzd_words 0 … 16)``) cyclically from
    the moment it is built, at 8E1.

    ``response_timeout`` (0.001 … 10 s, default 0.02), ``retries`` (PKW repetitions WDH,
    0 … 32767, default 20), ``cycle_pause`` (0 … 60 s), ``baud`` (the USS rates) and
    ``rx_latency`` as for :class:`RtuClient`.
    """

    def __new__(
        cls,
        port: str,
        nodes: List[Tuple[int, int, int]],
        *,
        response_timeout: float = 0.02,
        retries: int = 20,
        cycle_pause: float = 0.0,
        baud: int = 9600,
        rx_latency: Optional[float] = None,
    ) -> "UssMaster": ...
    def read_parameter(self, node: int, number: int, index: int = 0) -> int:
        """Reads parameter ``number`` (element ``index``) of ``node`` (PKW task 1)."""
    def write_parameter(
        self, node: int, number: int, value: int, index: int = 0, double: bool = False
    ) -> int:
        """Writes ``value`` (task 2, or 3 with ``double``); returns the value answered.
        DeviceException with ``error_number`` when the drive refuses."""
    def set_control(self, node: int, words: List[int]) -> None:
        """The PZD sent to ``node`` from the next poll on: STW, HSW, …"""
    def get_status(self, node: int) -> List[int]:
        """The PZD ``node`` answered last: ZSW, HIW, …"""
    def next_event(self, timeout: float = 1.0) -> Optional[UssEvent]:
        """The next cycle event, waiting up to ``timeout`` seconds."""
    def close(self) -> None:
        """Stops polling and releases the port. Idempotent."""
    def __enter__(self) -> "UssMaster": ...
    def __exit__(
        self,
        exc_type: Optional[Type[BaseException]],
        exc: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

class TraceRecord(TypedDict, total=False):
    """One simulator trace entry: ``at`` (virtual seconds), ``station``, ``kind`` ("tx",
    "rx", "rx_chunk", "rx_error", "other") and its fields."""

    at: float
    station: str
    kind: str
    bytes: bytes
    byte: int
    error: str
    text: str

@final
class Simulator:
    """si's deterministic line simulator, in virtual time: protocol engines as stations,
    wired with ``connect`` (point to point) or ``bus`` (half-duplex RS-485). A job call steps
    the simulation until the job's event (at most ``job_limit`` virtual seconds) and returns
    at once in real time; ``now`` is the virtual time. Station methods return the station's
    number."""

    def __new__(cls, seed: int = 1, *, trace: bool = True, job_limit: float = 60.0) -> "Simulator": ...
    @property
    def now(self) -> float:
        """Virtual time in seconds."""
    def connect(self, a: int, b: int) -> None:
        """Wires two stations point to point, full duplex."""
    def bus(self, stations: List[int]) -> None:
        """Puts stations on one half-duplex bus."""
    def run_for(self, span: float) -> None:
        """Runs ``span`` seconds of virtual time."""
    def trace(self) -> List[TraceRecord]:
        """The trace so far as a list of records."""
    def add_modbus_master(
        self, name: str, *, response_timeout: float = 2.0, retries: int = 0, baud: int = 9600
    ) -> int: ...
    def add_modbus_slave(
        self, name: str, *, address: int = 1, store: Optional[ModbusStore] = None, baud: int = 9600
    ) -> int: ...
    def add_3964r(self, name: str, *, priority: str = "low", baud: int = 9600) -> int: ...
    def add_ascii(self, name: str, *, end_char: Optional[int] = None, baud: int = 9600) -> int: ...
    def add_rk512(
        self, name: str, *, priority: str = "low", dbs: Optional[Dict[int, int]] = None, baud: int = 9600
    ) -> int: ...
    def add_uss_master(
        self, name: str, nodes: List[Tuple[int, int, int]], *, baud: int = 9600, local_echo: bool = False
    ) -> int: ...
    def add_uss_drive(
        self, name: str, *, address: int = 1, baud: int = 9600, local_echo: bool = False
    ) -> int:
        """A simulated drive (PKW 4, PZD 2; P700, P1082, P2010, P964, P2000, P1120, P20001)."""
    def read_holding_registers(self, station: int, address: int, count: int, unit: int = 1) -> List[int]: ...
    def write_multiple_registers(self, station: int, address: int, values: List[int], unit: int = 1) -> None: ...
    def send(self, station: int, data: bytes) -> None:
        """3964(R) or ASCII: sends a block or frame and runs until it is acknowledged or sent."""
    def recv(self, station: int, timeout: float = 10.0) -> bytes:
        """3964(R) or ASCII: the next block or frame, within ``timeout`` virtual seconds."""
    def rk512_send(self, station: int, area: str, start: int, data: bytes) -> None: ...
    def rk512_fetch(self, station: int, area: str, start: int, length: int) -> bytes: ...
    def read_memory(self, station: int, area_name: str, start: int, count: int) -> bytes:
        """Bytes of an RK 512 serving station's own memory."""
    def read_parameter(self, station: int, node: int, number: int, index: int = 0) -> int:
        """USS master: reads parameter ``number`` of ``node``."""
    def write_trace(self, path: str) -> None:
        """Writes the trace as a trace file (what ``monitor_trace`` and ``si monitor`` read)."""

# Frames, offline. Decoding errors raise InvalidResponseError naming what and where.

def encode_3964r(payload: bytes, block_check: bool = True) -> bytes:
    """3964(R): the block after the partner's DLE (DLE doubled, DLE ETX, BCC)."""
def decode_3964r(block: bytes, block_check: bool = True, max_len: int = 1024) -> bytes:
    """3964(R): the payload of a block; InvalidResponseError for a wrong BCC or odd DLE."""
def encode_modbus(unit: int, pdu: bytes) -> bytes:
    """Modbus RTU: ``unit`` + ``pdu`` + CRC (low byte first)."""
def decode_modbus_request(adu: bytes) -> Dict[str, object]:
    """Modbus RTU request ADU checked as the slave does: ``unit``, ``function``, ``address``,
    ``pdu``, ``text``."""
def decode_modbus_response(adu: bytes) -> Dict[str, object]:
    """Modbus RTU response ADU checked: ``unit``, ``function``, ``pdu``, ``text``."""
def encode_uss(adr: int, net: bytes) -> bytes:
    """USS: STX LGE ADR net BCC."""
def decode_uss(telegram: bytes) -> Tuple[int, bytes]:
    """USS: ``(adr, net)`` of a checked telegram."""
def decode_rk512(telegram: bytes) -> Dict[str, object]:
    """RK 512: ``kind`` ("command", "continuation", "reaction"), ``header``, ``data`` (and
    ``error_number`` of a reaction)."""

class MonitorRecord(TypedDict):
    """What a monitor reports: ``kind`` "control", "frame", "note" or "event"; ``flags``
    start with "!!" for a fault, "--" for a remark."""

    start: float
    end: float
    kind: str
    label: str
    text: str
    bytes: bytes
    flags: List[str]

def monitor_trace(
    path: str,
    protocol: str,
    *,
    baud: int = 9600,
    data_bits: int = 8,
    parity: str = "even",
    stop_bits: int = 1,
    end_char: Optional[int] = None,
) -> List[MonitorRecord]:
    """The records of a trace file decoded as ``protocol`` ("3964r", "3964", "rk512",
    "modbus", "uss", "ascii"); each record also has ``from``, the sending station's name."""

@final
class Monitor:
    """A live passive monitor: ``push`` the bytes a port read and take the records."""

    def __new__(
        cls,
        protocol: str,
        *,
        stations: List[str] = ...,
        baud: int = 9600,
        data_bits: int = 8,
        parity: str = "even",
        stop_bits: int = 1,
        end_char: Optional[int] = None,
    ) -> "Monitor": ...
    def push(self, data: bytes, at: float, station: Optional[int] = None) -> List[MonitorRecord]:
        """``data`` arrived at ``at`` seconds, sent by station number ``station``."""
    def idle(self, now: float) -> List[MonitorRecord]:
        """The line was quiet until ``now``: what is overdue."""
    def counters(self) -> Dict[str, int]: ...

@final
class WindowHost:
    """The DP master's side of the coordination-byte window ([ET200S SI 2005] §2.12): queue
    jobs, call ``cycle`` once per DP cycle with the input window read from the module and
    write the output window it returns, collect each job's ``result``."""

    def __new__(cls, *, window: int = 8) -> "WindowHost":
        """``window``: 4, 8 or 32 bytes."""
    def send(self, data: bytes) -> int:
        """Queues a send job; returns its job number."""
    def receive(self) -> int:
        """Queues a receive job; returns its job number."""
    def cycle(self, now: float, input: bytes) -> bytes:
        """One DP cycle at ``now`` seconds: the output window for ``input``."""
    def result(self, job: int) -> Optional[Union[bytes, bool]]:
        """None while ``job`` runs; True for a finished send, the bytes of a receive (empty:
        no message); ProtocolError with the STATUS when it failed."""

@final
class WindowModule:
    """The module's side of the window with a loopback serial line, to test a rig."""

    def __new__(cls, *, window: int = 8) -> "WindowModule": ...
    def cycle(self, now: float, output: bytes) -> bytes:
        """One DP cycle at ``now`` seconds: the input window for the host's ``output``."""
