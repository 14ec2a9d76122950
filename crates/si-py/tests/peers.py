"""Bounded waits on the peer processes of the tests: a line of their output, and the moment
they hold their port open. A peer that hangs fails the test with what it said, instead of
hanging the run.

Linux only, as the pty tests are: `wait_for_port` reads the peer's open files in /proc.
"""

import os
import select
import time

import pytest


def read_line(proc, timeout=5.0):
    """The next line `proc` writes to its stdout (a pipe), without the newline; fails the test
    when none comes within `timeout` seconds or the process ends first.

    Reads the pipe's file descriptor directly, so `select` sees every byte: do not mix with
    `proc.stdout.readline()` on the same process.
    """
    pending = proc.__dict__.setdefault("_pending_output", bytearray())
    fd = proc.stdout.fileno()
    deadline = time.monotonic() + timeout
    while b"\n" not in pending:
        left = deadline - time.monotonic()
        if left <= 0:
            _fail(proc, f"no line within {timeout} s; so far: {bytes(pending)!r}")
        readable, _, _ = select.select([fd], [], [], left)
        if not readable:
            continue
        chunk = os.read(fd, 4096)
        if not chunk:
            _fail(proc, f"it ended (exit {proc.poll()}) before a line; so far: {bytes(pending)!r}")
        pending.extend(chunk)
    line, _, rest = bytes(pending).partition(b"\n")
    pending[:] = rest
    return line.decode()


def wait_for_port(proc, port, timeout=5.0):
    """Returns once `proc` holds `port` (a path, or a symlink to one such as socat's) open;
    fails the test when it does not within `timeout` seconds or ends first. Bytes written to
    the other end of a pty pair from then on wait in the port for the peer to read them."""
    device = os.path.realpath(port)
    fds = f"/proc/{proc.pid}/fd"
    deadline = time.monotonic() + timeout
    while True:
        if proc.poll() is not None:
            _fail(proc, f"it ended (exit {proc.returncode}) before opening {port}")
        try:
            names = os.listdir(fds)
        except FileNotFoundError:
            names = []
        for name in names:
            try:
                if os.readlink(os.path.join(fds, name)) == device:
                    return
            except OSError:
                pass  # closed meanwhile
        if time.monotonic() > deadline:
            _fail(proc, f"it did not open {port} ({device}) within {timeout} s")
        time.sleep(0.005)


def _fail(proc, why):
    proc.kill()
    proc.wait()
    stderr = proc.stderr.read() if proc.stderr else ""
    if isinstance(stderr, bytes):
        stderr = stderr.decode(errors="replace")
    pytest.fail(f"peer {proc.args!r}: {why}\nstderr: {stderr}")
