#!/usr/bin/env python3
"""Many lines in one `si gateway` process: threads, memory, idle CPU (BENCHMARKS.md).

For each line count N: N pseudo-terminals from os.openpty (this process holds both ends, so no
line sees an end of file), a gateway configuration with one Modbus RTU line per pty (19200 8N1,
pause 1 ms), PER_FACE lines per listening address (unit ids 1..PER_FACE on each: the top-level
`listen`, then a `listen` of their own for each further group), and `si --json gateway`. A
forked child simulates an RTU slave (FC03, holding register n holds n) on the first and the
last line, so the table shows that those lines are live. After start-up and SETTLE seconds:
threads (/proc/PID/status), their names (/proc/PID/task/*/comm), RSS, open descriptors and the
soft open-file limit, then CPU (utime + stime) over IDLE seconds with no traffic, then one FC03
on the first and on the last line. Memory per line is (RSS(N) - RSS(1)) / (N - 1).

With --parallel K (K > 1): K lines, each on its own address with unit 1 and a slave, and
client.py's closed-loop FC03 client: first 1 client on one line, then one client on each of the
K lines at once, to show that lines run side by side in the one thread.

usage: lines.py SI N[,N...] [--per-face P (250)] [--idle S (10)] [--settle S (2)]
                [--parallel K] [--seconds T (10)]
Prints a markdown table (and the raw numbers as JSON lines on stderr).
"""
import argparse
import json
import os
import resource
import select
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from client import cpu_seconds, load, proc_status, recv_exact  # noqa: E402


def crc16(data):
    """Modbus RTU CRC (polynomial 0xA001, initial 0xFFFF), low byte first on the wire."""
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return struct.pack("<H", crc)


def slaves(masters):
    """Serve FC03 on each pty master in `masters` ({fd: unit}) until killed: one select loop."""
    bufs = {fd: b"" for fd in masters}
    poll = select.poll()  # not select(): descriptors above 1,024 with 1,000 lines
    for fd in masters:
        poll.register(fd, select.POLLIN)
    while True:
        for fd, _ in poll.poll():
            bufs[fd] += os.read(fd, 256)
            buf = bufs[fd]
            while len(buf) >= 8:
                frame = buf[:8]
                if frame[0] != masters[fd] or frame[1] != 3 or crc16(frame[:6]) != frame[6:]:
                    buf = buf[1:]  # not a request for us: resynchronise byte by byte
                    continue
                start, count = struct.unpack(">HH", frame[2:6])
                body = bytes([frame[0], 3, 2 * count]) + b"".join(
                    struct.pack(">H", (start + i) & 0xFFFF) for i in range(count)
                )
                os.write(fd, body + crc16(body))
                buf = buf[8:]
            bufs[fd] = buf


def free_ports(n):
    """n free loopback ports (bound at once so that they differ, then released)."""
    socks = [socket.socket() for _ in range(n)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


def ask(addr, unit, tid=1):
    """One FC03 of 10 registers from address 0: the answer's latency in ms, or the error."""
    host, port = addr.rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=5) as s:
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        t0 = time.perf_counter()
        s.sendall(struct.pack(">HHHBBHH", tid, 0, 6, unit, 0x03, 0, 10))
        rtid, _, length, runit = struct.unpack(">HHHB", recv_exact(s, 7))
        pdu = recv_exact(s, length - 1)
        ms = (time.perf_counter() - t0) * 1e3
    want = b"\x03\x14" + b"".join(struct.pack(">H", i) for i in range(10))
    if (rtid, runit, pdu) != (tid, unit, want):
        return None, pdu.hex()
    return ms, None


class Rig:
    """N ptys, the slaves' child process and a running gateway; stop() ends them."""

    def __init__(self, si, n, per_face, live, tmp):
        ptys = [os.openpty() for _ in range(n)]
        self.ptys = ptys
        unit = [i % per_face + 1 for i in range(n)]
        self.units = unit
        ports = free_ports((n + per_face - 1) // per_face)
        toml = [f'listen = "127.0.0.1:{ports[0]}"', "max_connections = 32"]
        for i, (_, slave) in enumerate(ptys):
            face = i // per_face
            toml += [
                "[[line]]",
                f'name = "l{i}"',
                f'device = "{os.ttyname(slave)}"',
                "baud = 19200",
                'parity = "none"',
                f'units = "{unit[i]}"',
                "pause_ms = 1",
            ]
            if face:
                toml.append(f'listen = "127.0.0.1:{ports[face]}"')
        path = os.path.join(tmp, f"gw-{n}-{per_face}.toml")
        with open(path, "w") as f:
            f.write("\n".join(toml) + "\n")
        masters = {ptys[i][0]: unit[i] for i in live}
        self.slave_pid = os.fork()
        if self.slave_pid == 0:
            try:
                slaves(masters)
            finally:
                os._exit(0)
        t0 = time.perf_counter()
        self.gw = subprocess.Popen(
            [si, "--json", "gateway", "--config", path],
            stdout=subprocess.PIPE,
            stderr=open(os.path.join(tmp, f"gw-{n}.log"), "w"),
            text=True,
        )
        first = self.gw.stdout.readline()
        self.startup_s = time.perf_counter() - t0
        event = json.loads(first)
        assert event["event"] == "listening", first
        # Line i's address: the listener whose names include it.
        self.addr = {}
        for face in event["listeners"]:
            for name in face["lines"]:
                self.addr[int(name[1:])] = face["addr"]
        self.pid = self.gw.pid

    def stop(self):
        self.gw.kill()
        self.gw.wait()
        os.kill(self.slave_pid, 9)
        os.waitpid(self.slave_pid, 0)
        for m, s in self.ptys:
            os.close(m)
            os.close(s)


def soft_nofile(pid):
    with open(f"/proc/{pid}/limits") as f:
        for line in f:
            if line.startswith("Max open files"):
                return int(line.split()[3])
    return None


def thread_names(pid):
    names = []
    for t in sorted(os.listdir(f"/proc/{pid}/task")):
        with open(f"/proc/{pid}/task/{t}/comm") as f:
            names.append(f.read().strip())
    return names


def measure(si, n, per_face, idle, settle, tmp):
    live = sorted({0, n - 1})
    rig = Rig(si, n, per_face, live, tmp)
    try:
        time.sleep(settle)
        status = proc_status(rig.pid)
        fds = len(os.listdir(f"/proc/{rig.pid}/fd"))
        cpu0 = cpu_seconds(rig.pid)
        time.sleep(idle)
        idle_cpu = cpu_seconds(rig.pid) - cpu0
        answers = [ask(rig.addr[i], rig.units[i]) for i in live]
        after = proc_status(rig.pid)
        names = sorted(set(thread_names(rig.pid)))
        return {
            "lines": n,
            "per_face": per_face,
            "listeners": len(set(rig.addr.values())),
            "startup_s": round(rig.startup_s, 2),
            "threads": status["Threads"],
            "threads_after": after["Threads"],
            "thread_names": names,
            "rss_kb": status["VmRSS"],
            "rss_after_kb": after["VmRSS"],
            "hwm_kb": after["VmHWM"],
            "fds": fds,
            "soft_nofile": soft_nofile(rig.pid),
            "idle_s": idle,
            "idle_cpu_ms": round(idle_cpu * 1e3),
            "first_last_ms": [None if a[0] is None else round(a[0], 1) for a in answers],
            "errors": [a[1] for a in answers if a[1]],
        }
    finally:
        rig.stop()


def parallel(si, k, seconds, tmp):
    """One client on one line, then one client on each of k lines at once."""
    rig = Rig(si, k, 1, range(k), tmp)
    rows = []
    try:
        time.sleep(1)
        for lines in (1, k):
            results, threads = [], []
            for i in range(lines):
                host, port = rig.addr[i].rsplit(":", 1)

                def one(host=host, port=int(port)):
                    results.append(load(host, port, rig.pid, seconds, 1))

                threads.append(threading.Thread(target=one))
            cpu0 = cpu_seconds(rig.pid)
            for t in threads:
                t.start()
            for t in threads:
                t.join()
            cpu = cpu_seconds(rig.pid) - cpu0
            tps = sum(r["tps"] for r in results)
            rows.append({
                "lines_loaded": lines,
                "tps_total": round(tps, 1),
                "tps_per_line": round(tps / lines, 1),
                "mean_ms": round(sum(r["mean_ms"] for r in results) / lines, 2),
                "errors": sum(r["errors"] for r in results),
                "gateway_cpu_pct": round(cpu / seconds * 100, 1),
                "threads": results[0]["threads"],
            })
    finally:
        rig.stop()
    return rows


def main():
    p = argparse.ArgumentParser()
    p.add_argument("si")
    p.add_argument("counts")
    p.add_argument("--per-face", type=int, default=250)
    p.add_argument("--idle", type=float, default=10)
    p.add_argument("--settle", type=float, default=2)
    p.add_argument("--parallel", type=int, default=0)
    p.add_argument("--seconds", type=float, default=10)
    a = p.parse_args()
    # Two descriptors per pty here (both ends held): raise our own soft limit too.
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    tmp = tempfile.mkdtemp(prefix="si-lines.")
    print(f"# temp dir {tmp}; our RLIMIT_NOFILE was {soft}/{hard}", file=sys.stderr)
    rows = []
    for n in map(int, a.counts.split(",")):
        r = measure(a.si, n, a.per_face, a.idle, a.settle, tmp)
        print(json.dumps(r), file=sys.stderr, flush=True)
        rows.append(r)
    base = next((r for r in rows if r["lines"] == 1), None)
    print(
        "| lines | listeners | threads idle / after requests | RSS | RSS per line | open fds (soft limit) "
        f"| idle CPU ({a.idle:g} s) | FC03 first / last line | start-up |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        per = "—"
        if base and r["lines"] > 1:
            per = f"{(r['rss_kb'] - base['rss_kb']) / (r['lines'] - 1):.1f} KiB"
        live = " / ".join("no answer" if ms is None else f"{ms} ms" for ms in r["first_last_ms"])
        print(
            f"| {r['lines']} | {r['listeners']} | {r['threads']} / {r['threads_after']} "
            f"({', '.join(r['thread_names'])}) "
            f"| {r['rss_kb'] / 1024:.1f} MiB | {per} | {r['fds']} ({r['soft_nofile']}) "
            f"| {r['idle_cpu_ms']} ms | {live} | {r['startup_s']} s |"
        )
    if a.parallel > 1:
        rows = parallel(a.si, a.parallel, a.seconds, tmp)
        for r in rows:
            print(json.dumps(r), file=sys.stderr, flush=True)
        print()
        print("| lines loaded at once | transactions/s, total | per line | mean | errors "
              "| gateway CPU | threads |")
        print("|---|---|---|---|---|---|---|")
        for r in rows:
            print(
                f"| {r['lines_loaded']} | {r['tps_total']} | {r['tps_per_line']} "
                f"| {r['mean_ms']} ms | {r['errors']} | {r['gateway_cpu_pct']} % | {r['threads']} |"
            )


if __name__ == "__main__":
    main()
