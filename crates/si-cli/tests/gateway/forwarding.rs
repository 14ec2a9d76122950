//! A pymodbus TCP client through the gateway: FC 01 02 03 04 05 06 15 16 reach the RTU slave
//! and come back; its exception passes unchanged; a silent unit gives 0BH and an unrouted one
//! 0AH, and so does a broadcast on lines that do not allow them; the diagnostic unit and the status line at exit count what happened.

use super::harness::{read_holding, Mbap, Rig};
use crate::common::modbus::pymodbus_client_ok;

const TCP_CLIENT: &str = r#"
import sys
from pymodbus.client import ModbusTcpClient
host, port = sys.argv[1].rsplit(":", 1)
c = ModbusTcpClient(host, port=int(port), timeout=10, retries=0)
assert c.connect(), "connect"
def ok(r):
    assert not r.isError(), r
    return r
assert ok(c.read_holding_registers(3, count=3, device_id=1)).registers == [3, 4, 5]   # FC03
assert ok(c.read_input_registers(2, count=2, device_id=1)).registers == [1002, 1003]  # FC04
assert ok(c.read_discrete_inputs(0, count=4, device_id=1)).bits[:4] == [False, True, False, True]  # FC02
ok(c.write_register(10, 0xBEEF, device_id=1))                                          # FC06
ok(c.write_registers(11, [7, 8], device_id=1))                                         # FC16
assert ok(c.read_holding_registers(10, count=3, device_id=1)).registers == [0xBEEF, 7, 8]
ok(c.write_coil(3, True, device_id=1))                                                 # FC05
ok(c.write_coils(8, [True, False, True], device_id=1))                                 # FC15
bits = ok(c.read_coils(0, count=12, device_id=1)).bits[:12]                            # FC01
assert bits == [False]*3 + [True] + [False]*4 + [True, False, True, False], bits
r = c.read_holding_registers(99, count=5, device_id=1)       # past the slave's table
assert r.isError() and r.exception_code == 2, r
r = c.read_holding_registers(0, count=1, device_id=2)        # routed to the silent line
assert r.isError() and r.exception_code == 0x0B, r
r = c.read_holding_registers(0, count=1, device_id=9)        # no line serves 9
assert r.isError() and r.exception_code == 0x0A, r
own = ok(c.read_input_registers(0, count=16, device_id=247)).registers
assert own[1] == 13 and own[3] == 9 and own[5] == 1 and own[7] == 1 and own[13] == 1, own
line = ok(c.read_input_registers(16, count=16, device_id=247)).registers
assert line[1] == 10 and line[3] == 9 and line[5] == 1 and line[7] == 0, line
silent = ok(c.read_input_registers(32, count=16, device_id=247)).registers
assert silent[1] == 1 and silent[7] == 1, silent
r = c.read_holding_registers(0, count=1, device_id=247)      # only FC04 on the diagnostic unit
assert r.isError() and r.exception_code == 1, r
r = c.write_register(0, 1, device_id=0)                       # broadcasts are not configured
assert r.isError() and r.exception_code == 0x0A, r
print("OK")
"#;

#[test]
fn pymodbus_tcp_client_through_the_gateway_to_a_pymodbus_rtu_slave() {
    let keys = "response_timeout_ms = 300\nretries = 1\npause_ms = 5";
    let Some(rig) = Rig::start("diagnostic_unit = 247", keys) else {
        return;
    };
    pymodbus_client_ok(TCP_CLIENT, &rig.addr);
    let status = rig.stop();
    assert_eq!(status["event"], "status", "{status}");
    let (meters, silent) = (&status["lines"][0], &status["lines"][1]);
    assert_eq!(meters["name"], "meters", "{status}");
    assert_eq!(meters["requests"], 10, "{status}");
    assert_eq!(meters["answers"], 9, "{status}");
    assert_eq!(meters["exceptions"], 1, "{status}");
    assert_eq!(meters["queue_depth"], 0, "{status}");
    assert_eq!(silent["requests"], 1, "{status}");
    assert_eq!(silent["timeouts"], 1, "{status}");
}

/// With `broadcast = true` a write to unit 0 reaches the slave and gets no answer (mbusd's
/// default): the next answer on the connection is the following read's, showing the value the
/// broadcast wrote.
#[test]
fn a_configured_broadcast_is_written_and_not_answered() {
    let Some(rig) = Rig::start("", "broadcast = true\npause_ms = 0") else {
        return;
    };
    let mut m = Mbap::connect(&rig.addr);
    m.send(0x0101, 0, &[0x06, 0x00, 0x30, 0x12, 0x34]);
    m.send(0x0102, 1, &read_holding(0x30, 1));
    assert_eq!(m.recv(), (0x0102, 1, vec![0x03, 2, 0x12, 0x34]));
    let status = rig.stop();
    assert_eq!(status["lines"][0]["requests"], 2, "{status}");
    assert_eq!(status["lines"][0]["answers"], 1, "{status}");
}

/// A line with framing keys of its own (`frame_end = "length"`, a doubled gap) opens and
/// forwards: write and read back through the pymodbus slave.
#[test]
fn a_line_with_its_own_rtu_framing_forwards() {
    let keys = "frame_end = \"length\"\nchar_delay_multiplier = 2\npause_ms = 0";
    let Some(rig) = Rig::start("", keys) else {
        return;
    };
    let mut m = Mbap::connect(&rig.addr);
    m.send(7, 1, &[0x06, 0x00, 0x31, 0xAB, 0xCD]);
    assert_eq!(m.recv(), (7, 1, vec![0x06, 0x00, 0x31, 0xAB, 0xCD]));
    m.send(8, 1, &read_holding(0x31, 1));
    assert_eq!(m.recv(), (8, 1, vec![0x03, 2, 0xAB, 0xCD]));
}
