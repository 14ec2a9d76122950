//! The finished line engines as the module's serial side: a simulated ET 200S SI module that runs
//! 3964(R) ([`si_3964r::Link`]) or the ASCII driver ([`si_ascii::Link`]) on its line.
//!
//! si-dp-coord is the one protocol crate allowed to drive line engines (ARCHITECTURE.md): the
//! module firmware does exactly this, with the window on one side and a line procedure on the
//! other ([ET200S SI 2005] §2.12.1–§2.12.7 `[derived]`: "the module sends the end-of-job ack only
//! after the frame has been transmitted to the partner"). Each function wraps a configured
//! engine in an [`EngineSerial`] with the engine's [`LineHooks`]:
//!
//! | Module needs | 3964(R) | ASCII |
//! |---|---|---|
//! | send a frame | `Link::send` (refusal → its STATUS) | `Link::send` (refusal → its STATUS) |
//! | frame received | `Received { len }` → `take_block` at the next module cycle | `Received` → `read_frame_bytes` at the next module cycle |
//! | receive error | `ReceiveError(s)`, except 0807H | `ReceiveError { status }` |
//! | send ended | `Sent` / `SendFailed` | `Sent` / `SendFailed` |
//! | write V.24 | RTS/DTR set on the line directly | `Link::set_signals` (0502H on RS-422/485, under automatic V.24, RTS under RTS/CTS) |
//! | parameters | refused, 0550H (3964(R) has no flow control) | `Link::apply_param_block` (0550H / 1E20H) |
//!
//! Readings:
//! * **0807H "zero-length block received (not an error)"** ([ET200S SI] §2.13, Table 2-28) is
//!   not buffered for the host: the window's receive job has no way to say "not an error" other
//!   than 0101H, and an empty block carries nothing to fetch, so the module drops it. Every other
//!   receive error is delivered to the next receive job as 20H + STATUS ([ET200S SI 2005] §2.12.7
//!   case 2).
//! * **Frames are taken out of the engine at the module's next cycle**, not when the engine
//!   reports them: the engine's buffer (3964(R): 5 blocks, ASCII: 1024 bytes) then frees at the
//!   rate the module runs, and the window module's own buffer (`ModuleConfig::rx_buffer_*`)
//!   decides what the host sees (0B01H, 080AH).
//! * **Parameter blocks** carry times in 10 ms units (Table 2-27); the ASCII engine takes
//!   milliseconds, so each value is multiplied by 10. Its range check (20 … 655 350 ms) is the
//!   engine's; a refusal carries the engine's STATUS.
//! * **No allocation per frame** in steady state (the si-core contract): [`r3964r`] and
//!   [`ascii`] hand frames to send over as `Bytes` cut from a buffer the adapter keeps
//!   ([`EngineSerial::with_pooled_send`]); received frames come from the engines' own kept
//!   buffers (`take_block`, `read_frame_bytes`). The `send` entries of [`R3964R_HOOKS`] and
//!   [`ASCII_HOOKS`], for an [`EngineSerial::new`] without the pool, copy each frame into a
//!   new `Bytes`. `tests/no_alloc.rs` proves it for both engines.
//! * The window module must be configured for the same flow control as the ASCII engine
//!   ([`ascii_module_config`] does it): the module checks the block number first (0550H), the
//!   engine then checks the values.

use crate::config::{ConfigError, FlowControl, ModuleConfig};
use crate::frame::{ParamBlock, WindowSize};
use crate::line::{EngineSerial, LineEvent, LineHooks};
use crate::module::{Module, SerialEvent};
use bytes::Bytes;
use si_core::{FramePool, Instant, SignalUpdate, Status};

/// The hooks for a [`si_3964r::Link`].
pub const R3964R_HOOKS: LineHooks<si_3964r::Link> = LineHooks {
    send: r3964r_send,
    classify: r3964r_classify,
    take_frame: Some(r3964r_take),
    set_signals: None,
    set_flow_control: None,
};

fn r3964r_send(link: &mut si_3964r::Link, now: Instant, frame: &[u8]) -> Result<(), Status> {
    r3964r_send_bytes(link, now, Bytes::copy_from_slice(frame))
}

/// The link keeps the frame for its repetitions ([ET200S SI] §2.7) until the job ends.
fn r3964r_send_bytes(link: &mut si_3964r::Link, now: Instant, frame: Bytes) -> Result<(), Status> {
    link.send(now, frame)
        .map(|_| ())
        .map_err(si_3964r::SendError::status)
}

fn r3964r_classify(event: &si_3964r::Event) -> Option<LineEvent> {
    use si_3964r::Event;
    Some(match event {
        Event::Sent { .. } => SerialEvent::SendDone(Ok(())).into(),
        Event::SendFailed { status, .. } => SerialEvent::SendDone(Err(*status)).into(),
        Event::Received { .. } => LineEvent::FrameWaiting,
        Event::ReceiveError(s) if s.code() == si_3964r::status::ZERO_LENGTH.code() => return None,
        Event::ReceiveError(s) => SerialEvent::ReceiveFailed(*s).into(),
    })
}

fn r3964r_take(
    link: &mut si_3964r::Link,
    now: Instant,
    _: &mut FramePool,
) -> Option<Result<Bytes, Status>> {
    link.take_block(now).map(Ok)
}

/// A 3964(R) engine as the module's serial side, sending from the adapter's frame pool.
pub fn r3964r(link: si_3964r::Link) -> EngineSerial<si_3964r::Link> {
    EngineSerial::new(link, R3964R_HOOKS).with_pooled_send(r3964r_send_bytes)
}

/// A simulated module with 3964(R) on its line: the window of `window` bytes, the module
/// defaults otherwise, flow control none (3964(R) has none, so every parameter job gets 0550H).
///
/// The module's frame limit is the link's `max_block_len`; an error names a module parameter out
/// of range (none is with the engine's own ranges).
pub fn r3964r_module(
    window: WindowSize,
    link: si_3964r::Link,
) -> Result<Module<EngineSerial<si_3964r::Link>>, ConfigError> {
    let cfg = ModuleConfig {
        flow_control: FlowControl::None,
        max_frame_len: usize::from(link.config().max_block_len),
        ..ModuleConfig::new(window)
    };
    Module::new(cfg, r3964r(link))
}

/// The hooks for a [`si_ascii::Link`].
pub const ASCII_HOOKS: LineHooks<si_ascii::Link> = LineHooks {
    send: ascii_send,
    classify: ascii_classify,
    take_frame: Some(ascii_take),
    set_signals: Some(ascii_set_signals),
    set_flow_control: Some(ascii_flow_control),
};

fn ascii_send(link: &mut si_ascii::Link, now: Instant, frame: &[u8]) -> Result<(), Status> {
    ascii_send_bytes(link, now, Bytes::copy_from_slice(frame))
}

/// The link hands the frame out in slices while it sends.
fn ascii_send_bytes(link: &mut si_ascii::Link, now: Instant, frame: Bytes) -> Result<(), Status> {
    link.send(now, frame).map(|_| ()).map_err(|e| e.status())
}

fn ascii_classify(event: &si_ascii::Event) -> Option<LineEvent> {
    use si_ascii::Event;
    Some(match event {
        Event::Sent { .. } => SerialEvent::SendDone(Ok(())).into(),
        Event::SendFailed { status, .. } => SerialEvent::SendDone(Err(*status)).into(),
        Event::Received { .. } => LineEvent::FrameWaiting,
        Event::ReceiveError { status, .. } => SerialEvent::ReceiveFailed(*status).into(),
    })
}

fn ascii_take(
    link: &mut si_ascii::Link,
    now: Instant,
    _: &mut FramePool,
) -> Option<Result<Bytes, Status>> {
    // Sized by the frame itself, so no frame can stay behind for want of room; cut from the
    // link's kept buffer, so nothing is allocated per frame.
    link.read_frame_bytes(now).map(Ok)
}

fn ascii_set_signals(
    link: &mut si_ascii::Link,
    _now: Instant,
    update: SignalUpdate,
) -> Result<(), Status> {
    link.set_signals(update).map_err(|r| r.status)
}

/// The window's parameter block, applied by the link (which converts its counts of 10 ms with
/// si-core's one conversion).
fn ascii_flow_control(
    link: &mut si_ascii::Link,
    _now: Instant,
    block: ParamBlock,
) -> Result<(), Status> {
    link.apply_param_block(block).map_err(|r| r.status)
}

/// An ASCII engine as the module's serial side, sending from the adapter's frame pool.
pub fn ascii(link: si_ascii::Link) -> EngineSerial<si_ascii::Link> {
    EngineSerial::new(link, ASCII_HOOKS).with_pooled_send(ascii_send_bytes)
}

/// The window module configuration matching an ASCII configuration: its flow control (so the
/// module accepts the right parameter block) and its frame limit
/// ([`si_ascii::Config::max_frame_len`], 200 bytes by default).
pub fn ascii_module_config(window: WindowSize, config: &si_ascii::Config) -> ModuleConfig {
    ModuleConfig {
        flow_control: match config.flow_control {
            si_ascii::FlowControl::None => FlowControl::None,
            si_ascii::FlowControl::XonXoff => FlowControl::XonXoff,
            si_ascii::FlowControl::RtsCts => FlowControl::RtsCts,
            si_ascii::FlowControl::AutoV24 => FlowControl::AutoV24,
        },
        max_frame_len: config.max_frame(),
        rx_buffer_bytes: si_ascii::RECEIVE_BUFFER_SIZE,
        ..ModuleConfig::new(window)
    }
}

/// A simulated module with the ASCII driver on its line (see [`ascii_module_config`]).
pub fn ascii_module(
    window: WindowSize,
    link: si_ascii::Link,
) -> Result<Module<EngineSerial<si_ascii::Link>>, ConfigError> {
    let cfg = ascii_module_config(window, link.config());
    Module::new(cfg, ascii(link))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::module::SerialSide;
    use crate::status::FLOW_CONTROL_MISMATCH;

    #[test]
    fn parameter_times_are_converted_from_10_ms_units() {
        let config = si_ascii::Config {
            flow_control: si_ascii::FlowControl::XonXoff,
            ..si_ascii::Config::default()
        };
        let mut side = ascii(si_ascii::Link::new(config).unwrap());
        side.set_flow_control(
            Instant::ZERO,
            ParamBlock::XonXoff {
                xon: 0x11,
                xoff: 0x13,
                xon_wait: 300,
            },
        )
        .unwrap();
        assert_eq!(
            side.engine().config().xon_xoff.wait_for_xon,
            si_core::Duration::from_millis(3_000)
        );
        // 1 unit = 10 ms is below the engine's 20 ms minimum: 1E20H from the engine.
        let err = side
            .set_flow_control(
                Instant::ZERO,
                ParamBlock::XonXoff {
                    xon: 0x11,
                    xoff: 0x13,
                    xon_wait: 1,
                },
            )
            .unwrap_err();
        assert_eq!(err.code(), 0x1E20);
        // A block of another flow control: 0550H.
        let err = side
            .set_flow_control(Instant::ZERO, ParamBlock::RTS_CTS_DEFAULT)
            .unwrap_err();
        assert_eq!(err.code(), 0x0550);
    }

    #[test]
    fn r3964r_refuses_parameters_and_drops_zero_length_blocks() {
        let mut side = r3964r(
            si_3964r::Link::new(si_3964r::Config::default().with_settings(Default::default()))
                .unwrap(),
        );
        let err = side
            .set_flow_control(Instant::ZERO, ParamBlock::XON_XOFF_DEFAULT)
            .unwrap_err();
        assert_eq!(err, FLOW_CONTROL_MISMATCH);
        assert_eq!(
            r3964r_classify(&si_3964r::Event::ReceiveError(
                si_3964r::status::ZERO_LENGTH
            )),
            None
        );
        assert_eq!(
            r3964r_classify(&si_3964r::Event::ReceiveError(
                si_3964r::status::TRANSMISSION_ERROR
            )),
            Some(LineEvent::Serial(SerialEvent::ReceiveFailed(
                si_3964r::status::TRANSMISSION_ERROR
            )))
        );
    }
}
