//! The channel abstraction of ARCHITECTURE.md ("FB equivalents"): one user program calls S_SEND
//! and S_RCV the same way whether the frames go directly over a line engine on the host's own
//! port or through the DP window of an ET 200S SI module.
//!
//! The FB structs of the three crates differ in shape, because each follows what its transport
//! can do:
//!
//! | | S_SEND | S_RCV |
//! |---|---|---|
//! | [`si_3964r::fb`] | `call(&mut Link, now, req, r, data) -> SSendOutput` | `call(&mut Link, now, en_r, r) -> SRcvOutput` (the block as `Bytes`) |
//! | [`si_ascii::fb`] | `call(&mut Link, now, req, r, data) -> Done` | `call(&mut Link, now, en_r, r, dest) -> Received` |
//! | [`crate::fb`] (window) | `call(&mut Host, req, r, data) -> Done` | `call(&mut Host, en_r, r, dest) -> Received` |
//!
//! [`Channel`] is the common face: `send` and `receive` with the S7 parameters, the engine
//! passed in (engines live inside a simulator or a tokio driver and are reached through
//! `Simulator::with` / `Handle::call`, so a channel cannot own them), and the outputs as
//! [`Done`] and [`Received`]. A user program is written once against `C: Channel`; switching
//! from a direct engine to the window is choosing [`R3964rFbs`] / [`AsciiFbs`] or [`WindowFbs`]
//! (and running the window's host and module cycles beside it):
//!
//! ```
//! use si_dp_coord::channel::Channel;
//! use si_core::Instant;
//!
//! /// Forwards every received frame back to the partner.
//! fn echo<C: Channel>(fbs: &mut C, engine: &mut C::Engine, now: Instant, buf: &mut [u8; 256], pending: &mut Option<usize>) {
//!     let r = fbs.receive(engine, now, true, false, buf);
//!     if r.ndr {
//!         *pending = Some(r.len);
//!     }
//!     if let Some(len) = *pending {
//!         let d = fbs.send(engine, now, true, false, &buf[..len]);
//!         if d.done || d.error {
//!             *pending = None;
//!         }
//!     }
//! }
//! ```
//!
//! Readings: the 3964(R) S_RCV hands its block over as `Bytes`; through [`R3964rFbs`] it is
//! copied into `dest` like the other two, and a block longer than `dest` is reported as ERROR
//! with 1E20H (the window's and the ASCII driver's reading, et200s-si-3964r-ascii.md §8.3:
//! "destination area too short"); unlike the ASCII driver the block is gone from the 3964(R)
//! link by then, as it is from the window module.

use crate::fb::{Done, Received, SRcv, SSend};
use crate::host::Host;
use crate::status::PARAMETER_OUT_OF_RANGE;
use si_core::Instant;

/// S_SEND and S_RCV over some transport; see the [module docs](self).
pub trait Channel {
    /// What the FBs act on: a line engine, or the window's [`Host`].
    type Engine;

    /// One call of S_SEND: a rising edge on `req` sends `data`; DONE or ERROR/STATUS for one
    /// call when the job ends; `r` aborts.
    fn send(
        &mut self,
        engine: &mut Self::Engine,
        now: Instant,
        req: bool,
        r: bool,
        data: &[u8],
    ) -> Done;

    /// One call of S_RCV: with `en_r`, copies at most one received frame into `dest` (NDR,
    /// LEN) or reports one receive error (ERROR, STATUS); `r` resets.
    fn receive(
        &mut self,
        engine: &mut Self::Engine,
        now: Instant,
        en_r: bool,
        r: bool,
        dest: &mut [u8],
    ) -> Received;
}

/// S_SEND / S_RCV through the DP window ([`crate::fb`] over a [`Host`]).
#[derive(Debug, Default)]
pub struct WindowFbs {
    /// The S_SEND instance.
    pub s_send: SSend,
    /// The S_RCV instance.
    pub s_rcv: SRcv,
}

impl Channel for WindowFbs {
    type Engine = Host;

    fn send(&mut self, host: &mut Host, _now: Instant, req: bool, r: bool, data: &[u8]) -> Done {
        self.s_send.call(host, req, r, data)
    }

    fn receive(
        &mut self,
        host: &mut Host,
        _now: Instant,
        en_r: bool,
        r: bool,
        dest: &mut [u8],
    ) -> Received {
        self.s_rcv.call(host, en_r, r, dest)
    }
}

/// S_SEND / S_RCV directly on a 3964(R) link ([`si_3964r::fb`]).
#[derive(Debug, Default)]
pub struct R3964rFbs {
    /// The S_SEND instance.
    pub s_send: si_3964r::fb::SSend,
    /// The S_RCV instance.
    pub s_rcv: si_3964r::fb::SRcv,
}

impl Channel for R3964rFbs {
    type Engine = si_3964r::Link;

    fn send(
        &mut self,
        link: &mut si_3964r::Link,
        now: Instant,
        req: bool,
        r: bool,
        data: &[u8],
    ) -> Done {
        let o = self.s_send.call(link, now, req, r, data);
        Done {
            done: o.done,
            error: o.error,
            status: o.status,
        }
    }

    fn receive(
        &mut self,
        link: &mut si_3964r::Link,
        now: Instant,
        en_r: bool,
        r: bool,
        dest: &mut [u8],
    ) -> Received {
        let o = self.s_rcv.call(link, now, en_r, r);
        let out = Received {
            ndr: o.ndr,
            error: o.error,
            len: o.len,
            status: o.status,
        };
        match o.data {
            Some(block) if block.len() <= dest.len() => {
                dest[..block.len()].copy_from_slice(&block);
                out
            }
            Some(_) => Received {
                ndr: false,
                error: true,
                len: 0,
                status: PARAMETER_OUT_OF_RANGE,
            },
            None => out,
        }
    }
}

/// S_SEND / S_RCV directly on an ASCII link ([`si_ascii::fb`]).
#[derive(Debug, Default)]
pub struct AsciiFbs {
    /// The S_SEND instance.
    pub s_send: si_ascii::fb::SSend,
    /// The S_RCV instance.
    pub s_rcv: si_ascii::fb::SRcv,
}

impl Channel for AsciiFbs {
    type Engine = si_ascii::Link;

    fn send(
        &mut self,
        link: &mut si_ascii::Link,
        now: Instant,
        req: bool,
        r: bool,
        data: &[u8],
    ) -> Done {
        let o = self.s_send.call(link, now, req, r, data);
        Done {
            done: o.done,
            error: o.error,
            status: o.status,
        }
    }

    fn receive(
        &mut self,
        link: &mut si_ascii::Link,
        now: Instant,
        en_r: bool,
        r: bool,
        dest: &mut [u8],
    ) -> Received {
        let o = self.s_rcv.call(link, now, en_r, r, dest);
        Received {
            ndr: o.ndr,
            error: o.error,
            len: o.len,
            status: o.status,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use si_core::sim::Simulator;
    use si_core::{Duration, SerialSettings};

    #[test]
    fn r3964r_block_longer_than_dest_is_1e20h() {
        let line = SerialSettings::default();
        let high = si_3964r::Config {
            priority: si_3964r::config::Priority::High,
            ..si_3964r::Config::default()
        };
        let mut sim = Simulator::new(1);
        let a = sim.add_station("A", line, si_3964r::Link::new(high, line).unwrap());
        let b = sim.add_station(
            "B",
            line,
            si_3964r::Link::new(si_3964r::Config::default(), line).unwrap(),
        );
        sim.connect(a, b);
        let (mut fa, mut fb) = (R3964rFbs::default(), R3964rFbs::default());
        let mut dest = [0u8; 4];
        let mut got = Vec::new();
        for _ in 0..200 {
            sim.with(a, |l, now| fa.send(l, now, true, false, b"too long"));
            let r = sim.with(b, |l, now| fb.receive(l, now, true, false, &mut dest));
            if r.ndr || r.error {
                got.push(r);
            }
            sim.run_for(Duration::from_millis(5));
        }
        assert_eq!(got.len(), 1, "{got:?}");
        assert!(got[0].error && !got[0].ndr);
        assert_eq!(got[0].status.code(), 0x1E20);
    }
}
