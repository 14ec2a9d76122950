#!/usr/bin/env python3
"""Load and resource probe for one Modbus TCP gateway (BENCHMARKS.md).

Raw sockets, not pymodbus's TCP client, so that the client costs little per transaction and
the same bytes go to every gateway. Each client owns one connection and sends FC03 (10
holding registers from address 0, unit 1) in a closed loop: the next request goes out when
the answer to the last one is in. Every answer is checked (transaction id, unit, function,
byte count); a wrong one counts as an error, never as a transaction.

usage: client.py HOST PORT GATEWAY_PID SECONDS CLIENTS[,CLIENTS...]
Prints one JSON object per client count, then one for the idle probe.
"""
import json
import os
import socket
import statistics
import struct
import sys
import threading
import time

TICKS = os.sysconf("SC_CLK_TCK")


def proc_status(pid):
    """VmRSS, VmHWM (kB) and Threads from /proc/PID/status."""
    out = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM", "Threads"):
                out[key] = int(value.split()[0])
    return out


def cpu_seconds(pid):
    """utime + stime of PID (all its threads), from /proc/PID/stat, in seconds."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    # fields[0] is field 3 (state); utime and stime are fields 14 and 15.
    return (int(fields[11]) + int(fields[12])) / TICKS


def recv_exact(sock, n):
    buf = b""
    while len(buf) < n:
        chunk = sock.recv(n - len(buf))
        if not chunk:
            raise ConnectionError("gateway closed the connection")
        buf += chunk
    return buf


def client(host, port, until, lat, errors):
    sock = socket.create_connection((host, port))
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    sock.settimeout(5)
    tid = 0
    while time.perf_counter() < until:
        tid = (tid + 1) & 0xFFFF
        req = struct.pack(">HHHBBHH", tid, 0, 6, 1, 0x03, 0, 10)
        t0 = time.perf_counter()
        try:
            sock.sendall(req)
            head = recv_exact(sock, 7)
            rtid, _, length, unit = struct.unpack(">HHHB", head)
            pdu = recv_exact(sock, length - 1)
        except (OSError, ConnectionError):
            errors.append("io")
            sock.close()
            sock = socket.create_connection((host, port))
            sock.settimeout(5)
            continue
        t1 = time.perf_counter()
        if rtid != tid or unit != 1 or pdu[:2] != b"\x03\x14" or len(pdu) != 22:
            errors.append(pdu[:2].hex())
            continue
        lat.append(t1 - t0)
    sock.close()


def load(host, port, pid, seconds, clients):
    lat, errors = [], []
    cpu0 = cpu_seconds(pid)
    start = time.perf_counter()
    until = start + seconds
    threads = [
        threading.Thread(target=client, args=(host, port, until, lat, errors))
        for _ in range(clients)
    ]
    for t in threads:
        t.start()
    status = None
    for t in threads:
        t.join()
        if status is None:
            status = proc_status(pid)  # while the others may still be connected
    elapsed = time.perf_counter() - start
    cpu = cpu_seconds(pid) - cpu0
    lat.sort()
    n = len(lat)
    return {
        "clients": clients,
        "seconds": round(elapsed, 2),
        "transactions": n,
        "errors": len(errors),
        "tps": round(n / elapsed, 1),
        "mean_ms": round(statistics.fmean(lat) * 1e3, 2) if n else None,
        "p50_ms": round(lat[n // 2] * 1e3, 2) if n else None,
        "p99_ms": round(lat[min(n - 1, int(n * 0.99))] * 1e3, 2) if n else None,
        "gateway_cpu_s": round(cpu, 2),
        "gateway_cpu_ms_per_tx": round(cpu * 1e3 / n, 3) if n else None,
        "rss_kb": status["VmRSS"],
        "hwm_kb": status["VmHWM"],
        "threads": status["Threads"],
    }


def idle(pid, seconds=5):
    cpu0 = cpu_seconds(pid)
    time.sleep(seconds)
    cpu = cpu_seconds(pid) - cpu0
    status = proc_status(pid)
    return {
        "idle_s": seconds,
        "idle_cpu_ms": round(cpu * 1e3, 1),
        "rss_kb": status["VmRSS"],
        "hwm_kb": status["VmHWM"],
        "threads": status["Threads"],
    }


def main():
    host, port, pid, seconds = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4])
    print(json.dumps({"phase": "idle-before", **idle(pid)}), flush=True)
    for clients in map(int, sys.argv[5].split(",")):
        print(json.dumps({"phase": "load", **load(host, port, pid, seconds, clients)}), flush=True)
    print(json.dumps({"phase": "idle-after", **idle(pid)}), flush=True)


if __name__ == "__main__":
    main()
