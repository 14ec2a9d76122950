//! Function codes the RTU master does not know pass through to the slave, as mbusd does since
//! 0.5.3: FC 2BH/0EH (Read Device Identification) from a pymodbus TCP client through the
//! gateway to a pymodbus serial slave and back. (Exception answers to a passed-through code
//! are checked in si-modbus's scenarios: pymodbus's serial slave drops a code it does not
//! know instead of answering 01H.)

use super::harness::Rig;
use crate::common::modbus::pymodbus_client_ok;

const DEVICE_ID_CLIENT: &str = r#"
import sys
from pymodbus.client import ModbusTcpClient
host, port = sys.argv[1].rsplit(":", 1)
c = ModbusTcpClient(host, port=int(port), timeout=10, retries=0)
assert c.connect(), "connect"
r = c.read_device_information(read_code=1, object_id=0, device_id=1)   # FC 2BH / MEI 0EH
assert not r.isError(), r
# The slave's own answer (it has no identity objects set): MEI 0EH, read code 1 echoed.
assert r.function_code == 0x2B and r.read_code == 1, r
assert r.information == {}, r.information
print("OK")
"#;

#[test]
fn read_device_identification_passes_through_to_the_slave_and_back() {
    let keys = "response_timeout_ms = 500\nretries = 0\npause_ms = 0";
    let Some(rig) = Rig::start("", keys) else {
        return;
    };
    pymodbus_client_ok(DEVICE_ID_CLIENT, &rig.addr);
    let status = rig.stop();
    let meters = &status["lines"][0];
    assert_eq!(meters["requests"], 1, "{status}");
    assert_eq!(meters["answers"], 1, "{status}");
}
