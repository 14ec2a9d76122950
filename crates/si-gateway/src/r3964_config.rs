//! The keys of a `kind = "3964r"` line: the 3964(R) link only (`priority`, default `high`;
//! `block_check`, default `true`; `ack_delay_ms`, 10 … 655 350, default 2000 or 550 without
//! block check: [ET200S SI] §2.7, Fig. 2-16, Table 2-11), with the port keys every line has. The
//! link's own bounds (block length 200 bytes, attempts) keep the manual's defaults.

use super::config::{refuse_keys, Device, Kind, Line, LineFile};
use si_core::RangeError;

impl LineFile {
    /// Check a `3964r` line whose device and unit ids are already read.
    pub(super) fn check_3964r(
        &self,
        name: String,
        device: Device,
        units: Vec<u8>,
    ) -> Result<Line, RangeError> {
        let mut keys = self.not_on_3964r_links();
        keys.extend([
            ("response_timeout_ms", self.response_timeout_ms.is_some()),
            ("pause_ms", self.pause_ms.is_some()),
            ("queue", self.queue.is_some()),
        ]);
        refuse_keys(&keys, "not a key of 3964r lines", "given".to_string())?;
        let link = self.link(si_3964r::Priority::High)?;
        link.validate()?;
        self.check_rs485()?;
        Ok(self.port_line(name, device, units, Kind::R3964(link)))
    }
}

#[cfg(test)]
mod tests {
    use crate::config::{File, Kind};

    fn check(keys: &str) -> Result<si_3964r::Config, String> {
        let text = format!(
            "[[line]]\nname = \"b\"\nkind = \"3964r\"\ndevice = \"x\"\nunits = \"1\"\n{keys}"
        );
        let g = File::from_toml(&text)?.check().map_err(|e| e.to_string())?;
        match g.lines[0].kind.clone() {
            Kind::R3964(c) => Ok(c),
            other => Err(format!("not a 3964r line: {other:?}")),
        }
    }

    #[test]
    fn the_link_keys_are_read_and_others_refused() {
        let c = check("").unwrap();
        assert_eq!(c.priority, si_3964r::Priority::High);
        assert!(c.block_check);
        let c = check("priority = \"low\"\nblock_check = false\nack_delay_ms = 300\n").unwrap();
        assert_eq!(
            (c.priority, c.block_check, c.ack_delay.as_millis()),
            (si_3964r::Priority::Low, false, 300)
        );
        for (keys, want) in [
            ("ack_delay_ms = 1\n", "(QVZ) = 1 ms"),
            (
                "cpu = 1\n",
                "cpu = set on a 3964r line is out of range: a key of rk512 lines",
            ),
            (
                "queue = 4\n",
                "queue = given is out of range: not a key of 3964r lines",
            ),
            ("response_timeout_ms = 100\n", "response_timeout_ms = given"),
        ] {
            let e = check(keys).unwrap_err();
            assert!(e.contains(want), "{keys}: {e}");
        }
        let e = File::from_toml("[[line]]\ndevice = \"x\"\nunits = \"1\"\nack_delay_ms = 100\n")
            .unwrap()
            .check()
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(
                "ack_delay_ms = set on a modbus-rtu line is out of range: a key of rk512 and 3964r lines"
            ),
            "{e}"
        );
    }
}
