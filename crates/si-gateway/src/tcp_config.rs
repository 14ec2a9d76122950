//! The keys of a `kind = "modbus-tcp"` line: a Modbus TCP slave (a PLC, a meter, another
//! gateway) reached over one TCP connection, which the gateway's clients share, one request
//! at a time; checked into [`TcpLine`].
//!
//! | key | range | default |
//! |---|---|---|
//! | `address` | `HOST:PORT` of the slave | (required) |
//! | `units` | the TCP unit ids served (1–255), passed on unchanged | |
//! | `unit_map` | `{ 11 = 1 }`: TCP unit id → the slave's unit id (1–247) | |
//! | `response_timeout_ms` | 50 … 655 000 | 1000 |
//! | `retries` | 0 … 15 after a timeout | 0 |
//! | `pause_ms` | 0 … 10 000 between requests | 0 |
//! | `queue` | 1 … 1024 waiting requests | 32 |
//!
//! A Modbus TCP slave times its own answers, so there is no character format, framing or
//! RS-485 key; the timeout default is si-modbus's TCP client's own.

use crate::port_config::{check_exchange, check_pause, check_queue, parse_unit_map};
use si_core::RangeError;
use std::collections::BTreeMap;
use std::time::Duration;

/// One `[[line]]` of kind `modbus-tcp`, as written.
#[derive(Debug, Clone, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TcpFile {
    /// The line's `kind` as written (read by the file's reader).
    #[serde(default)]
    pub kind: Option<String>,
    /// A name for status lines and errors (default `line<N>`).
    pub name: Option<String>,
    /// The slave's `HOST:PORT`.
    pub address: Option<String>,
    /// TCP unit ids served, passed on as they are: `"1-10,12"`.
    pub units: Option<String>,
    /// TCP unit ids mapped to the slave's unit ids, e.g. `{ 11 = 1 }`.
    pub unit_map: Option<BTreeMap<String, u8>>,
    /// A listening address of its own ([`crate::faces`]).
    pub listen: Option<String>,
    /// Response timeout (ms).
    pub response_timeout_ms: Option<u32>,
    /// Retries after a timeout.
    pub retries: Option<u8>,
    /// Pause between requests (ms).
    pub pause_ms: Option<u64>,
    /// Requests waiting at most.
    pub queue: Option<usize>,
}

/// A checked Modbus TCP line's own settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TcpLine {
    /// The slave's `HOST:PORT`.
    pub address: String,
    /// The TCP client's timeout and retries.
    pub client: si_modbus::tokio::tcp::ClientConfig,
    /// Pause between requests.
    pub pause: Duration,
    /// Queue length.
    pub queue: usize,
    /// TCP unit id → the slave's unit id, for the remapped ones.
    pub unit_map: Vec<(u8, u8)>,
}

impl TcpFile {
    /// Check the line's own keys.
    pub fn check(&self) -> Result<TcpLine, RangeError> {
        let address = self
            .address
            .clone()
            .ok_or_else(|| RangeError::new("address", "HOST:PORT of the slave", "", "none"))?;
        let (retries, response_timeout) =
            check_exchange(self.retries, 0, self.response_timeout_ms, 1000)?;
        let pause = check_pause(self.pause_ms, 0)?;
        let queue = check_queue(self.queue)?;
        Ok(TcpLine {
            address,
            client: si_modbus::tokio::tcp::ClientConfig {
                response_timeout,
                retries,
            },
            pause,
            queue,
            unit_map: parse_unit_map(self.unit_map.as_ref())?,
        })
    }
}
