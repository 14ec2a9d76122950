#!/usr/bin/env python3
"""A pacing relay between two pseudo-terminals: bytes take their wire time (BENCHMARKS.md).

A pseudo-terminal ignores the baud rate and passes a frame as fast as the kernel copies it.
This relay sits between the far ends of two socat pty pairs and gives each direction a
virtual wire: a byte is handed on when its last bit would have arrived, one character time
(start bit, data bits, parity, stop bits at BAUD bit/s) after the previous byte on that wire
or after the byte was written, whichever is later. Bytes due by the time the relay wakes are
handed on in one write, so the receiver sees the frame arrive at the wire's pace (the
deadlines are absolute: a late wake-up never stretches the wire).

usage: pace.py PTY_1 PTY_2 BAUD [BITS_PER_CHAR (10: 8N1)]
Runs until killed or until a pseudo-terminal closes.
"""
import collections
import os
import select
import sys
import threading
import time


def relay(src, dst, char_time):
    wire = collections.deque()  # (due, byte)
    wire_free = 0.0
    while True:
        now = time.perf_counter()
        due = bytearray()
        while wire and wire[0][0] <= now:
            due.append(wire.popleft()[1])
        if due:
            os.write(dst, bytes(due))
        timeout = max(0.0, wire[0][0] - now) if wire else None
        readable, _, _ = select.select([src], [], [], timeout)
        if readable:
            try:
                data = os.read(src, 4096)
            except OSError:
                return
            if not data:
                return
            now = time.perf_counter()
            for b in data:
                wire_free = max(wire_free, now) + char_time
                wire.append((wire_free, b))


def main():
    a, b, baud = sys.argv[1], sys.argv[2], int(sys.argv[3])
    bits = int(sys.argv[4]) if len(sys.argv) > 4 else 10
    char_time = bits / baud
    fa = os.open(a, os.O_RDWR | os.O_NOCTTY)
    fb = os.open(b, os.O_RDWR | os.O_NOCTTY)
    for path in (a, b):
        os.system(f"stty -F {path} raw -echo 2>/dev/null")
    threads = [
        threading.Thread(target=relay, args=(fa, fb, char_time), daemon=True),
        threading.Thread(target=relay, args=(fb, fa, char_time), daemon=True),
    ]
    for t in threads:
        t.start()
    print("ready", flush=True)
    while all(t.is_alive() for t in threads):
        time.sleep(0.5)


if __name__ == "__main__":
    main()
