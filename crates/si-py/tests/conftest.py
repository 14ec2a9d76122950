"""Fixtures of the si-serial tests: socat pseudo-terminal pairs and peer processes.

Outside CI a missing socat skips the pty tests; in CI (CI set) it fails them.
"""

import os
import shutil
import subprocess
import sys
import tempfile
import time

import pytest
from peers import read_line, wait_for_port


def _need(tool):
    if shutil.which(tool) is None:
        if os.environ.get("CI"):
            pytest.fail(f"{tool} is missing (CI installs it)")
        pytest.skip(f"{tool} is not installed")


@pytest.fixture
def pty_pair():
    """Two connected pseudo-terminals `(a, b)`: bytes written to one are read from the other."""
    _need("socat")
    d = tempfile.mkdtemp(prefix="si-py-")
    a, b = os.path.join(d, "a"), os.path.join(d, "b")
    proc = subprocess.Popen(
        ["socat", f"pty,raw,echo=0,link={a}", f"pty,raw,echo=0,link={b}"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 5
    while not (os.path.exists(a) and os.path.exists(b)):
        if time.monotonic() > deadline:
            proc.kill()
            pytest.fail("socat did not create the pty pair")
        time.sleep(0.01)
    yield a, b
    proc.terminate()
    proc.wait()
    shutil.rmtree(d, ignore_errors=True)


@pytest.fixture
def python_peer():
    """Starts `script` (Python source) with `port` and further arguments in a child process
    that prints "ready" and then opens `port` to serve; returns once it holds the port open,
    and stops it at the end of the test."""
    procs = []

    def start(script, port, *args):
        proc = subprocess.Popen(
            [sys.executable, "-c", script, port, *map(str, args)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        procs.append(proc)
        line = read_line(proc, timeout=10.0)
        if "ready" not in line:
            proc.kill()
            pytest.fail(f"peer did not start: {line}{proc.stderr.read()}")
        wait_for_port(proc, port)
        return proc

    yield start
    for proc in procs:
        proc.kill()
        proc.wait()


@pytest.fixture
def si_cli():
    """The `si` command line (its path in SI_BIN: `cargo build -p si-cli`)."""
    path = os.environ.get("SI_BIN")
    if not path or not os.path.exists(path):
        if os.environ.get("CI"):
            pytest.fail("SI_BIN does not name the si binary (CI builds it)")
        pytest.skip("SI_BIN is not set: build si with `cargo build -p si-cli`")
    return path
