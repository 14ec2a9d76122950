//! A user program on simulated modules: S_SEND on one host and S_RCV on another (or the same),
//! each called once per DP cycle as a CPU's cyclic program calls them, with the modules and the
//! line between them run by the caller's simulator. What `si sim dp-coord-e2e` and
//! `dp-coord-modbus` show: the FBs' ends as the user program sees them.

use crate::fb::{Done, Received, SRcv, SSend};
use crate::host::Host;
use si_core::{Duration, Instant};
use si_sim::Simulator;

/// The user programs of a run: S_SEND with `data` on `hosts[0]` (REQ until it has ended) and
/// S_RCV (EN_R = 1) on `hosts[receiver]`, one call each per DP cycle of 2 ms, in which
/// `dp_cycle` runs the hosts and their modules. Ends when both FBs have ended, or after 5000
/// cycles.
pub fn user_programs(
    sim: &mut Simulator,
    hosts: &mut [Host],
    receiver: usize,
    data: &[u8],
    mut dp_cycle: impl FnMut(&mut Simulator, &mut [Host]),
) -> (SendResult, ReceiveResult) {
    let (mut s_send, mut s_rcv) = (SSend::default(), SRcv::default());
    let mut dest = [0u8; 224];
    let (mut sent, mut got) = (None, None);
    for _ in 0..5_000 {
        let d = s_send.call(&mut hosts[0], sim.now(), sent.is_none(), false, data);
        if d.done || d.error {
            sent = Some((sim.now(), d));
        }
        let r = s_rcv.call(&mut hosts[receiver], sim.now(), true, false, &mut dest);
        if r.ndr || r.error {
            got = Some((sim.now(), r, dest[..r.len].to_vec()));
        }
        if sent.is_some() && got.is_some() {
            break;
        }
        dp_cycle(sim, hosts);
        sim.run_for(Duration::from_millis(2));
    }
    (sent, got)
}

/// What S_SEND ended with: when, and its outputs.
pub type SendResult = Option<(Instant, Done)>;

/// What S_RCV ended with: when, its outputs and the received bytes.
pub type ReceiveResult = Option<(Instant, Received, Vec<u8>)>;
