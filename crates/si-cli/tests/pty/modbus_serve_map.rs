//! `si modbus serve` says what it serves: the address map after the banner, and for a
//! refused request the address, count and why. Over a pseudo-terminal pair made by socat
//! (`apt-get install socat`; a skip with a message when it is missing, a failure with `CI` set).

use crate::common;

use common::modbus::{self, served};
use common::stderr;

#[test]
fn serve_prints_its_address_map_and_explains_a_refusal() {
    let Some((pair, _serve, log, line)) = modbus::serving_8n1() else {
        return;
    };
    // Table 3-20's conversion DB over the default memory: FC03 reaches DB6 only.
    let o = modbus::si_on(
        &pair.b,
        line,
        &[
            "modbus", "read", "holding", "--unit", "1", "--addr", "500", "--count", "20",
        ],
    );
    assert!(!o.status.success());
    assert!(stderr(&o).contains("exception 04"), "{}", stderr(&o));
    // Past every FC02 range of the conversion DB: exception 02.
    let o = modbus::si_on(
        &pair.b,
        line,
        &[
            "modbus", "read", "discrete", "--unit", "1", "--addr", "12300",
        ],
    );
    assert!(stderr(&o).contains("exception 02"), "{}", stderr(&o));
    let log = served(&log);
    for want in [
        "unit 1 serves coils (FC01/05/15) 0..=2039: M500.0 … M754.7, writes to MB500..=MB1200 only",
        "unit 1 serves holding registers (FC03/06/16) 0..=511: DB6.DBW0 … DB6.DBW1022, writable",
        "unit 1 serves input registers (FC04) 2048..=2559: DB6.DBW0 … DB6.DBW1022",
        "refused holding registers read address 500 count 20: exception 04 slave device failure: \
         512 is outside the holding registers served: 0..=511",
        "refused discrete inputs read address 12300 count 1: exception 02 illegal data address: \
         12300 is outside the discrete inputs served: 8160..=10199, 10200..=11087",
    ] {
        assert!(
            log.lines().any(|l| l == want),
            "missing {want:?} in:\n{log}"
        );
    }
}
