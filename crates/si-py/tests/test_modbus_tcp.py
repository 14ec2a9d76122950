"""si-serial's Modbus TCP client and server, and pymodbus's TCP client against si's server."""

import si_serial


def test_tcp_client_and_server_every_function():
    with si_serial.TcpServer() as server:
        server.store.set_bits("discrete_inputs", 0, [True, False, True])
        server.store.set_registers("input_registers", 4, [9, 8])
        with si_serial.TcpClient("127.0.0.1", server.port, response_timeout=1.0) as c:
            c.write_single_coil(1, True)
            assert c.read_coils(0, 3) == [False, True, False]
            assert c.read_discrete_inputs(0, 3) == [True, False, True]
            assert c.read_input_registers(4, 2) == [9, 8]
            c.write_multiple_registers(0, [1, 2, 3])
            assert c.read_holding_registers(0, 3) == [1, 2, 3]
            c.write_float(10, 1.5, number_of_registers=4)
            assert c.read_float(10, number_of_registers=4) == 1.5
            assert c.diagnostics(0xA537) == 0xA537
        assert server.store.get_registers("holding_registers", 0, 3) == [1, 2, 3]


def test_pymodbus_tcp_client_against_si_server():
    from pymodbus.client import ModbusTcpClient

    with si_serial.TcpServer() as server:
        server.store.set_registers("holding_registers", 0, list(range(10)))
        client = ModbusTcpClient("127.0.0.1", port=server.port)
        assert client.connect()
        try:
            r = client.read_holding_registers(0, count=10, device_id=1)
            assert r.registers == list(range(10))
        finally:
            client.close()
