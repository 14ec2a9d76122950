#!/usr/bin/env python3
"""mbusd's integration tests (tests/run_itests.py of 3cky/mbusd, written for pymodbus 3.6.9),
ported to pymodbus 3.16: the same six tests and assertions, against a gateway given on the
command line, so that mbusd itself is the control.

    mbusd_itests.py si PATH_TO_SI       # si gateway --line PTY --units 1 --broadcast
    mbusd_itests.py mbusd PATH_TO_MBUSD # mbusd -p PTY -s 19200

Port to 3.16: `slave=` is `device_id=`, counts are keywords, the response classes live in
pymodbus.pdu, the slave context is ModbusDeviceContext (no zero_mode: blocks start at 1 to map
request address 0 to the first value, as zero_mode=True did), the slave runs in a thread of its
own process, and the broadcast write expects no response (a Modbus TCP gateway does not answer a
broadcast; mbusd's test ignored the result). Ports and pty links are temporary, not /tmp/pts0.
"""

import asyncio
import warnings
warnings.filterwarnings("ignore")
import os
import random
import socket
import subprocess
import sys
import tempfile
import threading
import time
import unittest

from pymodbus.client import ModbusTcpClient
from pymodbus.datastore import ModbusDeviceContext, ModbusSequentialDataBlock, ModbusServerContext
from pymodbus.pdu import ExceptionResponse
from pymodbus.pdu.bit_message import (ReadCoilsResponse, ReadDiscreteInputsResponse,
                                      WriteMultipleCoilsResponse, WriteSingleCoilResponse)
from pymodbus.pdu.register_message import (ReadHoldingRegistersResponse,
                                           ReadInputRegistersResponse,
                                           WriteMultipleRegistersResponse,
                                           WriteSingleRegisterResponse)
from pymodbus.server import StartSerialServer

GATEWAY = None  # ("si" | "mbusd", binary), from argv


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def rtu_slave(port):
    store = ModbusDeviceContext(
        di=ModbusSequentialDataBlock(1, [True] * 8),
        co=ModbusSequentialDataBlock(1, [False] * 8),
        hr=ModbusSequentialDataBlock(1, [0] * 8),
        ir=ModbusSequentialDataBlock(1, list(range(8))),
    )
    context = ModbusServerContext(devices={1: store}, single=False)
    asyncio.set_event_loop(asyncio.new_event_loop())
    StartSerialServer(context=context, port=port, baudrate=19200, broadcast_enable=True)


class TestModbusRequests(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="mbusd-itests-")
        a, b = os.path.join(cls.dir, "pts0"), os.path.join(cls.dir, "pts1")
        cls.socat = subprocess.Popen(
            ["socat", f"pty,raw,echo=0,link={a}", f"pty,raw,echo=0,link={b}"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        for _ in range(500):
            if os.path.exists(a) and os.path.exists(b):
                break
            time.sleep(0.01)
        threading.Thread(target=rtu_slave, args=(os.readlink(b),), daemon=True).start()
        port = free_port()
        kind, binary = GATEWAY
        if kind == "si":
            cmd = [binary, "--baud", "19200", "--parity", "none", "--stop-bits", "1",
                   "gateway", "--listen", f"127.0.0.1:{port}", "--line", a, "--units", "1",
                   "--broadcast"]
        else:
            cmd = [binary, "-d", "-v2", f"-p{a}", "-s19200", f"-P{port}", "-A127.0.0.1"]
        cls.gateway = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        cls.client = ModbusTcpClient("127.0.0.1", port=port, timeout=5, retries=1)
        for _ in range(100):
            if cls.client.connect():
                break
            time.sleep(0.1)
        time.sleep(0.5)  # the slave's serial port opens in its thread

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        cls.gateway.kill()
        cls.socat.kill()

    def test_coils(self):
        bits = [random.randrange(2) > 0 for i in range(8)]

        # 15 Write Multiple Coils
        result = self.client.write_coils(0, bits, device_id=1)
        self.assertIsInstance(result, WriteMultipleCoilsResponse, result)
        self.assertEqual(result.address, 0, result)
        self.assertEqual(result.count, 8, result)

        # 01 Read Coils
        result = self.client.read_coils(0, count=8, device_id=1)
        self.assertIsInstance(result, ReadCoilsResponse, result)
        self.assertEqual(result.bits, bits, result)

        # 05 Write Single Coil
        bit1 = not bits[0]
        result = self.client.write_coil(0, bit1, device_id=1)
        self.assertIsInstance(result, WriteSingleCoilResponse, result)
        self.assertEqual(result.address, 0, result)
        self.assertEqual(result.bits[0], bit1, result)
        result = self.client.read_coils(0, count=1, device_id=1)
        self.assertIsInstance(result, ReadCoilsResponse, result)
        self.assertEqual(result.bits[0], bit1, result)

    def test_discreteInputs(self):
        # 02 Read Discrete Inputs
        result = self.client.read_discrete_inputs(0, count=8, device_id=1)
        self.assertIsInstance(result, ReadDiscreteInputsResponse, result)
        self.assertEqual(result.bits, [True] * 8, result)

    def test_inputRegisters(self):
        # 04 Read Input Registers
        result = self.client.read_input_registers(0, count=8, device_id=1)
        self.assertIsInstance(result, ReadInputRegistersResponse, result)
        self.assertEqual(result.registers, list(range(8)), result)

    def test_holdingRegisters(self):
        registers = [random.randrange(8) for i in range(8)]

        # 16 Write Multiple Holding Registers
        result = self.client.write_registers(0, registers, device_id=1)
        self.assertIsInstance(result, WriteMultipleRegistersResponse, result)
        self.assertEqual(result.address, 0, result)
        self.assertEqual(result.count, 8, result)

        # 03 Read Multiple Holding Registers
        result = self.client.read_holding_registers(0, count=8, device_id=1)
        self.assertIsInstance(result, ReadHoldingRegistersResponse, result)
        self.assertEqual(result.registers, registers, result)

        # 06 Write Single Holding Register
        register1 = (registers[0] + 1) % 65535
        result = self.client.write_register(0, register1, device_id=1)
        self.assertIsInstance(result, WriteSingleRegisterResponse, result)
        self.assertEqual(result.address, 0, result)
        self.assertEqual(result.registers[0], register1, result)
        result = self.client.read_holding_registers(0, count=1, device_id=1)
        self.assertIsInstance(result, ReadHoldingRegistersResponse, result)
        self.assertEqual(result.registers[0], register1, result)

    def test_exception(self):
        result = self.client.write_coil(1000, False, device_id=1)  # invalid address 1000
        self.assertIsInstance(result, ExceptionResponse, result)
        self.assertEqual(result.function_code & 0x7F, 5, result)  # fc05 Write Single Coil
        self.assertEqual(result.exception_code, 2, result)  # Illegal Data Address

    def test_broadcast(self):
        registers = [random.randrange(8) for i in range(8)]
        # 16 Write Multiple Holding Registers
        self.client.write_registers(0, registers, device_id=0, no_response_expected=True)
        time.sleep(0.3)  # the broadcast is on the line after the gateway's turnaround

        # 03 Read Multiple Holding Registers
        result = self.client.read_holding_registers(0, count=8, device_id=1)
        self.assertIsInstance(result, ReadHoldingRegistersResponse, result)
        self.assertEqual(result.registers, registers, result)


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("si", "mbusd"):
        sys.exit("usage: mbusd_itests.py si|mbusd BINARY")
    GATEWAY = (sys.argv[1], sys.argv[2])
    unittest.main(verbosity=2, argv=[sys.argv[0]])
