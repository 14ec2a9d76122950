//! The simulated module in Modbus master mode: si-modbus's [`Master`] on the line, its jobs and
//! responses through the window.
//!
//! The Modbus/USS module's manual has no window chapter of its own; it uses the same S_SEND and
//! S_RCV over the same window ([ET200S SI 2005] §2.12, a derived reading), so the
//! window carries exactly what those FBs move ([Modbus/USS] §3.4.2, §3.4.5–§3.4.16):
//!
//! | Window | Content | Source |
//! |---|---|---|
//! | send job (10H …) | the S_SEND source area: slave address, function code, start / address, quantity / value, FC15/16 data (the module adds byte count and CRC) | [Modbus/USS] §3.4.5–§3.4.16 |
//! | 7xH + STATUS after the send | 0000H once the slave's response has arrived (or a broadcast's turnaround has passed); the job's failure otherwise | [Modbus/USS] §3.4.2, Fig. 3-7 `[derived]` |
//! | receive job (20H …) | the response in the S_RCV destination layout: read data only (FC01/02 first byte → low byte of the word), the echo for writes | [Modbus/USS] §3.4.5–§3.4.16 |
//! | receive job answered 20H + STATUS | the failure of the job: 0830H no response, 0E61H–0E67H exception, 0E50H–0E57H, 0831H response errors | [Modbus/USS] §3.4.5–§3.4.16, §3.3.6, Table 3-12, §3.6 |
//!
//! Readings:
//! * **A failed job is reported twice**: with the end-of-job acknowledgement of the send job and
//!   with the next receive job, as si-modbus's S_SEND and S_RCV both report it (Figure 3-7 labels
//!   both ERROR lines; [Modbus/USS] §3.4.2 `[derived]`). The send job's 7xH therefore comes only
//!   when the master's job has ended, after the response or the response time (default 2 s); the
//!   window's own rule that 7xH follows the transmission ([ET200S SI 2005] §2.12.1–§2.12.7
//!   `[derived]`) is kept in the sense that the job's "transmission" is the whole request–response
//!   exchange ([Modbus/USS] §3.4.2: S_SEND DONE with S_RCV NDR).
//! * **Refused jobs** (a source area breaking [Modbus/USS] §3.4.5–§3.4.16: 0E40H–0E4AH, 1E41H) end
//!   the send job at once with 7xH + that STATUS and reach neither the line nor the receive buffer.
//! * **Frame limit 200 bytes** both ways ([Modbus/USS] §3.4.2 LEN 1…200, 050EH; `[derived]`): a
//!   longer send job is refused with 050EH by the window module itself, and a response whose S_RCV
//!   layout is longer than 200 bytes (FC03/04 above 100 registers, FC01/02 above 1600 bits,
//!   [Modbus/USS] §3.4.5–§3.4.16) is never cut: si-modbus's job check may refuse such a read before
//!   the line (050EH, its reading of [Modbus/USS] §3.4.5–§3.4.16); a longer response that still
//!   arrives is refused by the window module, and the receive job gets 20H + 0850H.
//! * The module's receive buffer holds the responses; the master runs one job at a time, and a
//!   send job while one runs is refused with 0502H.
//! * Parameter jobs are refused with 0550H (the Modbus module offers no flow-control block
//!   through the window, [ET200S SI 2005] §2.12 `[derived]`); write V.24 sets RTS/DTR on the line
//!   directly.
//! * Line diagnostics outside a job ([`MasterEvent::Diagnostic`], the module's SYSTAT entries)
//!   are not window content; they stay events of the station.
//!
//! USS master and Modbus slave mode through the window are **not built**: the format of what
//! the Modbus slave driver passes to S_MODB through S_RCV and back through S_SEND is not
//! documented (`[derived]`), nor is any USS job layout for the window.

use crate::config::{ConfigError, FlowControl, ModuleConfig};
use crate::frame::WindowSize;
use crate::line::{EngineSerial, LineEvent, LineHooks};
use crate::module::Module;
use crate::status::RECEIVED_FRAME_TOO_LONG;
use bytes::Bytes;
use si_core::job::{JobPort, NotStarted, Reception};
use si_core::status::common::NOT_POSSIBLE_IN_MODE;
use si_core::{FramePool, Instant, Status};
use si_modbus::master::{Master, MasterEvent};

/// The Modbus module's frame limit through the window: 200 bytes ([Modbus/USS] §3.4.2,
/// `[derived]`).
pub const MAX_FRAME_LEN: usize = si_modbus::fb::MAX_LEN;

/// Room for the longest S_RCV layout a Modbus response can have: 2040 coils are 255 bytes,
/// stored as 128 words ([Modbus/USS] §3.4.5–§3.4.16); 127 registers are 254 bytes.
const RESPONSE_AREA: usize = 256;

/// The hooks for a [`Master`].
pub const MASTER_HOOKS: LineHooks<Master> = LineHooks {
    send: master_send,
    classify: master_classify,
    take_frame: Some(master_take),
    set_signals: None,
    set_flow_control: None,
};

fn master_send(master: &mut Master, now: Instant, job: &[u8]) -> Result<(), Status> {
    master_send_bytes(master, now, Bytes::copy_from_slice(job))
}

/// Starts the job the S_SEND source area describes ([Modbus/USS] §3.4.5–§3.4.16), as si-modbus's
/// S_SEND does.
fn master_send_bytes(master: &mut Master, now: Instant, job: Bytes) -> Result<(), Status> {
    match master.start_job(now, job) {
        Ok(_) => Ok(()),
        Err(NotStarted::Refused(status)) => Err(status),
        Err(NotStarted::Busy) => Err(NOT_POSSIBLE_IN_MODE),
    }
}

fn master_classify(event: &MasterEvent) -> Option<LineEvent> {
    match event {
        MasterEvent::Completed(_) => Some(LineEvent::Answered(Ok(()))),
        MasterEvent::Failed { status, .. } => Some(LineEvent::Answered(Err(*status))),
        MasterEvent::Diagnostic(_) => None,
    }
}

/// The response of the job that just ended in the S_RCV layout ([Modbus/USS] §3.4.5–§3.4.16), or
/// its failure.
fn master_take(
    master: &mut Master,
    now: Instant,
    pool: &mut FramePool,
) -> Option<Result<Bytes, Status>> {
    let mut area = [0u8; RESPONSE_AREA];
    Some(match master.take_received(now, &mut area)? {
        Reception::Frame { len, .. } => match area.get(..len) {
            Some(frame) => Ok(pool.cut(frame)),
            None => Err(RECEIVED_FRAME_TOO_LONG),
        },
        Reception::Error(status) => Err(status),
    })
}

/// A Modbus master as the module's serial side, taking jobs from the adapter's frame pool.
pub fn master(master: Master) -> EngineSerial<Master> {
    EngineSerial::new(master, MASTER_HOOKS).with_pooled_send(master_send_bytes)
}

/// The window module configuration of the Modbus master mode: 200-byte frames, no flow-control
/// block.
pub fn master_module_config(window: WindowSize) -> ModuleConfig {
    ModuleConfig {
        flow_control: FlowControl::None,
        max_frame_len: MAX_FRAME_LEN,
        ..ModuleConfig::new(window)
    }
}

/// A simulated module in Modbus master mode (see [`master_module_config`]).
pub fn master_module(
    window: WindowSize,
    m: Master,
) -> Result<Module<EngineSerial<Master>>, ConfigError> {
    Module::new(master_module_config(window), master(m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::module::{SerialEvent, SerialSide};
    use si_core::{Engine, Output};
    use si_modbus::MasterConfig;

    #[test]
    fn a_refused_source_area_ends_the_send_at_once() {
        let mut side = master(Master::new(MasterConfig::default()).unwrap());
        // FC09 is not a function of the module: 0E42H ([Modbus/USS] §3.4.5–§3.4.16).
        let err = side
            .send(Instant::ZERO, &[0x05, 0x09, 0, 0, 0, 1])
            .unwrap_err();
        assert_eq!(err.code(), 0x0E42);
        assert_eq!(side.poll(Instant::ZERO), None);
    }

    #[test]
    fn a_second_job_while_one_runs_is_0502h() {
        let mut side = master(Master::new(MasterConfig::default()).unwrap());
        let job = [0x01, 0x03, 0, 0, 0, 1];
        side.send(Instant::ZERO, &job).unwrap();
        assert_eq!(side.send(Instant::ZERO, &job), Err(NOT_POSSIBLE_IN_MODE));
    }

    #[test]
    fn a_timed_out_job_is_reported_to_the_send_and_the_receive_job() {
        let mut engine = Master::new(MasterConfig::default()).unwrap();
        engine.set_rx_latency(si_core::Duration::ZERO); // a byte-by-byte port: manual timing
        let mut side = master(engine);
        side.send(Instant::ZERO, &[0x01, 0x03, 0, 0, 0, 1]).unwrap();
        // Through the adapter's Engine face: the request leaves, no one answers.
        let mut module = Module::new(master_module_config(WindowSize::Eight), side).unwrap();
        module.handle_tx_done(Instant::from_micros(10_000));
        while !matches!(module.poll_output(), Output::Wait(_)) {}
        module.handle_timeout(Instant::from_micros(2_020_000));
        while !matches!(module.poll_output(), Output::Wait(_)) {}
        let side = module.serial_mut();
        let timeout = si_modbus::status::RESPONSE_TIMEOUT;
        assert_eq!(
            side.poll(Instant::ZERO),
            Some(SerialEvent::ReceiveFailed(timeout))
        );
        assert_eq!(
            side.poll(Instant::ZERO),
            Some(SerialEvent::SendDone(Err(timeout)))
        );
        assert_eq!(side.poll(Instant::ZERO), None);
    }
}
