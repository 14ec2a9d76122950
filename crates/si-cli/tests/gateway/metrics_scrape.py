#!/usr/bin/env python3
"""A scrape of `si gateway`'s /metrics parsed by Prometheus's own text parser
(prometheus_client.parser), with exact counts after a known sequence of requests.

usage: metrics_scrape.py GATEWAY_HOST:PORT METRICS_HOST:PORT

The gateway (metrics_scrape.rs) has line `meters` (unit 1, a pymodbus RTU slave with 100
holding registers) and line `silent` (unit 2, nobody answers), both with retries = 0 and
demote_after = 3. Exits non-zero with the failed assertion on stderr; prints OK at the end.
"""
import socket
import struct
import sys
import urllib.request

from prometheus_client.parser import text_string_to_metric_families

GATEWAY, METRICS = sys.argv[1], sys.argv[2]
TID = 0


def connect():
    host, port = GATEWAY.rsplit(":", 1)
    s = socket.create_connection((host, int(port)), timeout=10)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


def recv_exact(s, n):
    buf = b""
    while len(buf) < n:
        chunk = s.recv(n - len(buf))
        if not chunk:
            raise ConnectionError("the gateway closed the connection")
        buf += chunk
    return buf


def fc03(s, unit, address, quantity):
    """One FC03 request; the answer's PDU (function code first)."""
    global TID
    TID = (TID + 1) & 0xFFFF
    pdu = struct.pack(">BHH", 3, address, quantity)
    s.sendall(struct.pack(">HHHB", TID, 0, len(pdu) + 1, unit) + pdu)
    tid, proto, length, got_unit = struct.unpack(">HHHB", recv_exact(s, 7))
    assert (tid, proto, got_unit) == (TID, 0, unit), (tid, proto, got_unit)
    return recv_exact(s, length - 1)


def scrape():
    """Every sample as {(name, sorted labels): value}, through the real parser."""
    with urllib.request.urlopen(f"http://{METRICS}/metrics", timeout=10) as r:
        assert r.status == 200, r.status
        assert r.headers["Content-Type"].startswith("text/plain; version=0.0.4"), r.headers
        text = r.read().decode("utf-8")
    samples = {}
    families = {}
    for family in text_string_to_metric_families(text):
        families[family.name] = family.type
        for s in family.samples:
            samples[(s.name, tuple(sorted(s.labels.items())))] = s.value
    return samples, families


def value(samples, name, **labels):
    return samples.get((name, tuple(sorted(labels.items()))), 0.0)


def expect(samples, name, want, **labels):
    # The series must exist, a 0 too: a counter missing until its first event hides that
    # event from rate() and increase().
    assert (name, tuple(sorted(labels.items()))) in samples, f"{name}{labels}: no such series"
    got = value(samples, name, **labels)
    assert got == want, f"{name}{labels}: expected {want}, got {got}"


def main():
    s = connect()
    for _ in range(5):
        pdu = fc03(s, 1, 0, 2)
        assert pdu[:2] == b"\x03\x04", pdu
    for _ in range(2):
        # Past the slave's 100 registers: its exception 02, passed through.
        assert fc03(s, 1, 200, 1) == b"\x83\x02"
    # 126 registers: refused by the gateway with 03, nothing sent.
    assert fc03(s, 1, 0, 126) == b"\x83\x03"
    for _ in range(3):
        # Nobody answers: 0BH after the response timeout; the third demotes the unit.
        assert fc03(s, 2, 0, 1) == b"\x83\x0b"

    samples, families = scrape()
    # The families and their types, as the parser reads them (a counter's name loses _total).
    assert families["si_gateway_requests"] == "counter", families
    assert families["si_gateway_line_up"] == "gauge", families
    assert families["si_gateway_response_time_seconds"] == "histogram", families
    req = "si_gateway_requests_total"
    exc = "si_gateway_exceptions_total"
    expect(samples, req, 5, line="meters", unit="1", outcome="answer")
    expect(samples, req, 2, line="meters", unit="1", outcome="exception")
    expect(samples, req, 1, line="meters", unit="1", outcome="other")
    expect(samples, exc, 2, line="meters", unit="1", code="0x02")
    expect(samples, exc, 1, line="meters", unit="1", code="0x03")
    expect(samples, req, 3, line="silent", unit="2", outcome="timeout")
    expect(samples, exc, 3, line="silent", unit="2", code="0x0B")
    expect(samples, "si_gateway_retries_total", 0, line="meters", unit="1")
    expect(samples, "si_gateway_crc_errors_total", 0, line="meters", unit="1")
    expect(samples, "si_gateway_demotion_events_total", 1, line="silent", event="demoted")
    expect(samples, "si_gateway_demoted_units", 1, line="silent")
    expect(samples, "si_gateway_demoted_units", 0, line="meters")
    expect(samples, "si_gateway_line_up", 1, line="meters")
    expect(samples, "si_gateway_line_up", 1, line="silent")
    expect(samples, "si_gateway_queue_depth", 0, line="meters")
    expect(samples, "si_gateway_reconnects_total", 0, line="meters")
    # Requests put on the line: 7 to unit 1 (the 126-register one was not), 3 to unit 2.
    expect(samples, "si_gateway_response_time_seconds_count", 7, line="meters")
    expect(samples, "si_gateway_response_time_seconds_count", 3, line="silent")
    expect(samples, "si_gateway_response_time_seconds_bucket", 7, line="meters", le="+Inf")
    before = value(samples, exc, line="silent", unit="2", code="0x0B")

    # 100 requests to the dead unit, now demoted: 100 more 0BH exceptions, at once.
    for _ in range(100):
        assert fc03(s, 2, 0, 1) == b"\x83\x0b"
    samples, _ = scrape()
    after = value(samples, exc, line="silent", unit="2", code="0x0B")
    assert after - before == 100, (before, after)
    expect(samples, req, 100, line="silent", unit="2", outcome="demoted")
    expect(samples, req, 3, line="silent", unit="2", outcome="timeout")
    # Nothing more went on the line.
    expect(samples, "si_gateway_response_time_seconds_count", 3, line="silent")
    expect(samples, req, 5, line="meters", unit="1", outcome="answer")
    s.close()
    print("OK")


if __name__ == "__main__":
    main()
