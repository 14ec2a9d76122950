"""The bounded waits of peers.py: a silent or dead peer fails the test instead of hanging it."""

import subprocess
import sys

import pytest
from peers import read_line, wait_for_port


def child(source):
    return subprocess.Popen(
        [sys.executable, "-c", source], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def test_read_line_returns_lines_one_by_one():
    proc = child("print('one'); print('two', flush=True)")
    assert read_line(proc) == "one"
    assert read_line(proc) == "two"
    proc.wait()


def test_read_line_fails_on_a_silent_peer_and_stops_it():
    proc = child("import time; time.sleep(60)")
    with pytest.raises(pytest.fail.Exception, match="no line within 0.2 s"):
        read_line(proc, timeout=0.2)
    assert proc.poll() is not None


def test_read_line_fails_on_a_peer_that_ends_with_its_stderr():
    proc = child("import sys; sys.stderr.write('cannot open the port'); print('half', end='')")
    with pytest.raises(pytest.fail.Exception, match="(?s)ended.*'half'.*cannot open the port"):
        read_line(proc)


def test_wait_for_port_sees_the_port_open_and_fails_when_it_is_not(pty_pair):
    a, b = pty_pair
    holder = child(f"f = open({b!r}, 'rb'); print('open', flush=True); import time; time.sleep(60)")
    try:
        assert read_line(holder) == "open"
        wait_for_port(holder, b)
        with pytest.raises(pytest.fail.Exception, match="did not open"):
            wait_for_port(holder, a, timeout=0.2)
    finally:
        holder.kill()
        holder.wait()
