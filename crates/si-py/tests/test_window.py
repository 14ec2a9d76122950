"""The DP window: the host driven cycle by cycle against the module's side with a loopback
line, as a rig drives it against a DP master card."""

import pytest
import si_serial


def exchange(host, module, until, cycles=2000):
    """DP cycles of 1 ms: the host's output goes to the module, its input back."""
    output, input_ = bytes(8), bytes(8)
    for k in range(cycles):
        now = k * 0.001
        output = host.cycle(now, input_)
        input_ = module.cycle(now, output)
        done = until()
        if done is not None:
            return done
    pytest.fail("the job did not end")


def test_send_then_receive_through_the_window():
    host, module = si_serial.WindowHost(window=8), si_serial.WindowModule(window=8)
    sent = host.send(b"through the window")
    assert exchange(host, module, lambda: host.result(sent)) is True
    # The loopback line hands the frame back: a receive job takes it.
    received = host.receive()
    assert exchange(host, module, lambda: host.result(received)) == b"through the window"


def test_bad_window_size_names_the_keyword():
    with pytest.raises(si_serial.ConfigError) as info:
        si_serial.WindowHost(window=16)
    assert info.value.keyword == "window"
