"""si_serial.aio: the Modbus clients as coroutines, on the same runtime."""

import asyncio
import time

import pytest
import si_serial
from si_serial import aio
from peers import wait_for_port


def test_tcp_client_coroutines_against_si_server():
    async def main():
        with si_serial.TcpServer() as server:
            server.store.set_registers("holding_registers", 0, [7, 8, 9])
            async with await aio.TcpClient.connect("127.0.0.1", server.port) as client:
                assert await client.read_holding_registers(0, 3) == [7, 8, 9]
                await client.write_float(10, 2.5)
                assert await client.read_float(10) == 2.5
                # Several jobs at once on one connection: each gets its own answer.
                got = await asyncio.gather(*(client.read_holding_registers(i, 1) for i in range(3)))
                assert got == [[7], [8], [9]]
                with pytest.raises(si_serial.DeviceException) as info:
                    await client.read_holding_registers(9999, 2)
                assert info.value.exception_code == 2

    asyncio.run(main())


def test_rtu_client_against_si_slave_and_the_loop_keeps_running(pty_pair):
    a, b = pty_pair

    async def main():
        ticks = 0

        async def tick():
            nonlocal ticks
            while True:
                ticks += 1
                await asyncio.sleep(0.001)

        ticker = asyncio.create_task(tick())
        with si_serial.ModbusSlave(b, address=1, rx_latency=0):
            async with aio.RtuClient(a, response_timeout=0.2, rx_latency=0) as client:
                await client.write_multiple_registers(0, [1, 2])
                assert await client.read_holding_registers(0, 2) == [1, 2]
                before = ticks
                start = time.monotonic()
                with pytest.raises(aio.NoResponseError):
                    await client.read_holding_registers(0, 1, unit=9)
                assert time.monotonic() - start <= client.job_bound
                # The event loop ran while the job waited.
                assert ticks - before > 20
        ticker.cancel()

    asyncio.run(main())


def test_bad_arguments_raise_before_any_await():
    with pytest.raises(si_serial.ConfigError) as info:
        aio.RtuClient("/nonexistent", response_timeout=0.01)
    assert info.value.keyword == "response_timeout"


def test_3964r_links_as_coroutines(pty_pair):
    a, b = pty_pair

    async def main():
        async with aio.Link3964R(a, priority="high", rx_latency=0) as high, aio.Link3964R(b, rx_latency=0) as low:
            # Receive and send at once on the two ends.
            received, _ = await asyncio.gather(low.recv(timeout=2.0), high.send(b"async block"))
            assert received == b"async block"
            with pytest.raises(aio.NoResponseError):
                await high.recv(timeout=0.1)

    asyncio.run(main())


def test_ascii_and_rk512_as_coroutines(pty_pair):
    a, b = pty_pair

    async def main():
        async with aio.AsciiLink(a, rx_latency=0) as tx, aio.AsciiLink(b, end="end-chars", end_chars=(0x0A, 0), rx_latency=0) as rx:
            await tx.send(b"line\n")
            assert await rx.recv(timeout=2.0) == b"line\n"

    asyncio.run(main())


def test_rk512_and_uss_as_coroutines(pty_pair, si_cli):
    import subprocess

    a, b = pty_pair

    async def main():
        async with aio.Rk512Station(b, serve=True, dbs={2: 16}, rx_latency=0) as plc:
            async with aio.Rk512Station(a, priority="high", rx_latency=0) as host:
                await host.send("DB2", 0, b"\x01\x02")
                assert plc.read_memory("DB2", 0, 2) == b"\x01\x02"
                assert await host.fetch("DB2", 0, 2) == b"\x01\x02"
        drive = subprocess.Popen([si_cli, "uss", "sim-slave", "--address", "5", "--port", b],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            await asyncio.to_thread(wait_for_port, drive, b)
            async with aio.UssMaster(a, [(5, 4, 2)], response_timeout=0.1, rx_latency=0) as master:
                assert await master.read_parameter(5, 1082) == 50
        finally:
            drive.kill()
            drive.wait()

    asyncio.run(main())


def test_uss_next_event_as_a_coroutine(pty_pair, si_cli):
    """`await UssMaster.next_event()`: the cycle's events from the CLI's simulated drive at
    node 5 and a silent node 6, while the event loop keeps running."""
    import subprocess

    a, b = pty_pair

    async def main():
        drive = subprocess.Popen([si_cli, "uss", "sim-slave", "--address", "5", "--port", b],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            await asyncio.to_thread(wait_for_port, drive, b)
            async with aio.UssMaster(a, [(5, 4, 2), (6, 4, 2)], response_timeout=0.05,
                                     rx_latency=0) as master:
                ticks = 0

                async def tick():
                    nonlocal ticks
                    while True:
                        ticks += 1
                        await asyncio.sleep(0.001)

                ticker = asyncio.create_task(tick())
                seen = set()
                deadline = time.monotonic() + 5
                while not {("response", 5), ("no_answer", 6)} <= seen:
                    assert time.monotonic() < deadline, seen
                    event = await master.next_event(timeout=1.0)
                    assert event is not None
                    seen.add((event["kind"], event.get("address")))
                ticker.cancel()
                assert ticks > 10
                with pytest.raises(si_serial.ConfigError):
                    await master.next_event(timeout=-1.0)
            # Closed: the master says so.
            with pytest.raises(si_serial.ProtocolError):
                await master.next_event(timeout=0.1)
        finally:
            drive.kill()
            drive.wait()

    asyncio.run(main())
