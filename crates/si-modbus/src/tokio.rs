//! Async Modbus over any [`Transport`](si_core::driver::Transport) (feature `tokio`): the
//! [`Client`] trait with one method per function code, implemented by the RTU [`Master`]
//! (engine in a driver task), the [`InlineMaster`] (engine in the caller's future) and the
//! Modbus TCP [`tcp::Client`]; a [`Slave`] handle serving a store; a Modbus TCP server in
//! [`tcp`]. They all fail with one [`Error`].
//!
//! The driver-backed handles run the Sans-IO engines on the si-core driver, which feeds them
//! tokio's clock and fires short deadlines precisely (see its "Timing, honestly"), so the
//! end-of-frame gap (4 ms at 9600–38 400 bit/s, 1 ms above, [Modbus/USS] §3.5, Table 3-11) is
//! detected some 0.1 ms late on an idle machine; that delays responses slightly but never merges
//! frames that the gap separates on the wire. To answer without waiting for the gap, build the
//! engines with [`FrameEnd::Length`](crate::config::FrameEnd) and start them with
//! `spawn_engine`.
//!
//! Handles have one shape across si's protocol crates: `spawn(config, transport)`,
//! `open(config, path)` (feature `serial`: the serial port opened with the config's own line
//! settings), methods on `&self`, `closed()` and `close().await` (returns once the port is
//! released; dropping a handle releases it too), `next_event()` on the slave.
//!
//! ```no_run
//! # async fn demo(port: tokio::io::DuplexStream) -> Result<(), si_modbus::tokio::Error> {
//! use si_modbus::tokio::{Client, Master};
//! use si_modbus::MasterConfig;
//! let master = Master::spawn(MasterConfig::default(), port)?;
//! let regs = master.read_holding_registers(1, 0, 10).await?;
//! master.write_single_register(1, 4, 0x1234).await?;
//! master.close().await?;
//! # Ok(()) }
//! ```

mod client;
mod error;
mod inline;
mod lifetime;
mod master;
pub mod scan;
mod slave;
pub mod tcp;

pub use client::{Client, CommEventLog, Reply};
pub use error::{Error, Job};
pub use inline::InlineMaster;
pub use master::{Master, DIAGNOSTICS_KEPT};
pub use slave::Slave;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Request;
    use crate::slave::{SlaveEvent, Tables};
    use crate::{MasterConfig, SlaveConfig};

    #[tokio::test]
    async fn master_and_slave_over_a_duplex_pipe() {
        let (a, b) = tokio::io::duplex(1024);
        let config = SlaveConfig {
            address: 7,
            ..SlaveConfig::default()
        };
        let mut server = Slave::spawn(config, Tables::new(16, 16, 16, 16), b).unwrap();
        let m = Master::spawn(MasterConfig::default(), a).unwrap();
        m.write_multiple_registers(7, 2, &[0xAAAA, 0x5555])
            .await
            .unwrap();
        assert_eq!(
            m.read_holding_registers(7, 1, 3).await.unwrap(),
            vec![0, 0xAAAA, 0x5555]
        );
        m.write_single_coil(7, 3, true).await.unwrap();
        m.write_multiple_coils(7, 8, &[true, false, true])
            .await
            .unwrap();
        let coils = m.read_coils(7, 0, 11).await.unwrap();
        assert_eq!(coils.iter().filter(|&&c| c).count(), 3);
        assert_eq!(m.diagnostics(7, 0xA537).await.unwrap(), 0xA537);
        let e = m.read_holding_registers(7, 15, 2).await.unwrap_err();
        assert_eq!(
            e.status(),
            Some(crate::status::EXCEPTION_ILLEGAL_DATA_ADDRESS)
        );
        assert!(matches!(
            server.next_event().await,
            Some(SlaveEvent::Served { function: 16, .. })
        ));
        let regs = server.with_store(|s| s.holding_registers[2]).await.unwrap();
        assert_eq!(regs, 0xAAAA);
    }

    /// `request_with_attempts`: a corrupt first answer and a good retry complete the job and
    /// still show the CRC error; a silent unit shows its timeouts.
    #[tokio::test]
    async fn a_job_reports_what_its_attempts_met() {
        use tokio::io::{AsyncReadExt, AsyncWriteExt};
        let (a, mut b) = tokio::io::duplex(1024);
        let config = MasterConfig {
            retries: 1,
            response_timeout: si_core::Duration::from_millis(50),
            ..MasterConfig::default()
        };
        let m = Master::spawn(config, a).unwrap();
        let peer = tokio::spawn(async move {
            let mut request = [0u8; 8];
            for corrupt in [true, false] {
                b.read_exact(&mut request).await.unwrap();
                let mut answer = vec![7, 3, 2, 0x12, 0x34];
                answer.extend(crate::frame::crc16(&answer).to_le_bytes());
                answer[6] ^= u8::from(corrupt);
                b.write_all(&answer).await.unwrap();
            }
            b
        });
        let read = Request::ReadHoldingRegisters {
            address: 0,
            quantity: 1,
        };
        let (result, attempts) = m.request_with_attempts(7, &read).await;
        assert!(result.is_ok(), "{result:?}");
        assert_eq!(
            (attempts.sent, attempts.crc_errors, attempts.timeouts),
            (2, 1, 0)
        );
        let _b = peer.await.unwrap();
        let (result, attempts) = m.request_with_attempts(9, &read).await;
        assert_eq!(
            result.unwrap_err().status(),
            Some(crate::status::RESPONSE_TIMEOUT)
        );
        assert_eq!(
            (attempts.sent, attempts.crc_errors, attempts.timeouts),
            (2, 0, 2)
        );
    }

    /// A `request` future dropped before its job ended (here: no answer from unit 9, which
    /// does not exist) does not leave its outcome to the next call: the next request waits
    /// for that job to time out (0830H) and then gets its own answer.
    #[tokio::test(start_paused = true)]
    async fn a_dropped_request_does_not_hand_its_outcome_to_the_next() {
        let (a, b) = tokio::io::duplex(1024);
        let config = SlaveConfig {
            address: 7,
            ..SlaveConfig::default()
        };
        let mut tables = Tables::new(0, 0, 4, 0);
        tables.holding_registers[1] = 0x1234;
        let _server = Slave::spawn(config, tables, b).unwrap();
        let master_config = MasterConfig {
            response_timeout: si_core::Duration::from_millis(100),
            ..MasterConfig::default()
        };
        let m = Master::spawn(master_config, a).unwrap();
        let dropped = tokio::time::timeout(
            std::time::Duration::from_millis(20),
            m.read_holding_registers(9, 0, 1),
        )
        .await;
        assert!(dropped.is_err(), "unit 9 never answers");
        assert_eq!(m.read_holding_registers(7, 1, 1).await.unwrap(), [0x1234]);
    }
}
