//! The Modbus slave engine ([Modbus/USS] §3.3.2, §3.3.3, Table 3-10, §3.3.6, Table 3-12, §3.5.1,
//! §3.5.2, §3.5.6–§3.5.14).
//!
//! The module's slave driver checks every request and S_MODB executes it against the CPU; here
//! the engine does the driver's part and a [`Store`] does S_MODB's. The engine:
//!
//! - answers only its own address (1–255, [Modbus/USS] §3.3.2); frames for other addresses are
//!   neither interpreted nor answered; a broadcast (address 0) is executed for FC05/06/15/16 and
//!   never answered, any other broadcast is logged as 0830H;
//! - checks the CRC (0836H, no answer), the function code (0831H, exception 01), quantities
//!   (0832H), FC15/16 byte counts (0833H), the FC05 value (0834H), the FC08 sub-function
//!   (0835H), all answered with exception 03 (Table 3-12);
//! - answers FC08 (sub-function 0000) itself, without touching the store ([Modbus/USS]
//!   §3.5.6–§3.5.14);
//! - reports a request that arrives while its previous response is still on the line as
//!   0837H (sequence error) and drops it.
//!
//! With [`FrameEnd::Length`] (a host extension, see there) a request also ends as soon as it
//! has the length its function code predicts and its CRC checks ([`crate::rx::request_len`]),
//! and the slave answers at once instead of after the gap. That is safe on a shared line: the
//! master that sent the request is silent, waiting for the answer.

use crate::config::{FrameEnd, SlaveConfig};
use crate::frame::{self, fc, Adu, DecodeErrorKind, ExceptionCode, Response, BROADCAST, MAX_ADU};
use crate::rx::{Counters, Expect, Fault, Received, Receiver};
use crate::serve::{self, Outcome, ResponseData};
use crate::status::{self, slave as codes};
use crate::transmitter::{Gate, Transmitter};
use si_core::{Duration, Engine, Instant, LineError, ModemSignals, Output, Status};
use std::collections::VecDeque;

pub use crate::store::{Store, StoreError, Tables};

/// What the slave reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlaveEvent {
    /// A request was executed and answered.
    Served {
        /// Function code.
        function: u8,
        /// Start address (0 for FC08).
        address: u16,
        /// Number of bits or registers (1 for FC05/06/08).
        quantity: u16,
    },
    /// A broadcast write was executed (no answer, [Modbus/USS] §3.3.2).
    Broadcast {
        /// Function code.
        function: u8,
        /// Start address.
        address: u16,
        /// Number of bits or registers.
        quantity: u16,
    },
    /// A request was answered with an exception (a refused broadcast is reported the same way
    /// but not answered).
    Exception {
        /// Function code of the request.
        function: u8,
        /// The exception sent.
        code: ExceptionCode,
        /// The driver event (0831H–0835H), if the driver rejected it. `None` with no `error`
        /// when the request is too short or too long for its function code: [Modbus/USS]
        /// §3.5.6–§3.5.14 lists no event for that, the answer is exception 03.
        status: Option<Status>,
        /// The store's refusal, if the store rejected it.
        error: Option<StoreError>,
    },
    /// A frame that got no answer: CRC (0836H), broadcast not allowed (0830H), sequence error
    /// (0837H), a line error in Normal mode (0810H, 0811H, 080CH, 080DH, 080AH).
    Error(Status),
}

/// The Sans-IO Modbus slave, served by a [`Store`].
#[derive(Debug)]
pub struct Slave<S> {
    config: SlaveConfig,
    rx: Receiver,
    store: S,
    out: VecDeque<Output<SlaveEvent>>,
    /// Frames out, with automatic V.24 operation ([Modbus/USS] §3.2.2) around each if configured.
    tx: Transmitter,
    /// Our response is on the line until then.
    busy_until: Option<Instant>,
    /// A request started while we were still transmitting.
    overlapped: bool,
}

impl<S: Store> Slave<S> {
    /// A slave with checked parameters.
    pub fn new(config: SlaveConfig, store: S) -> Result<Self, crate::config::ConfigError> {
        config.validate()?;
        let mut out = VecDeque::new();
        Ok(Slave {
            rx: Receiver::new(&config.line),
            tx: Transmitter::new(config.line.auto_v24, &mut out),
            config,
            store,
            out,
            busy_until: None,
            overlapped: false,
        })
    }

    /// End received frames this way (host extension [`FrameEnd::Length`]; the default is
    /// the module's [`FrameEnd::Gap`]).
    ///
    /// An engine option rather than a [`LineConfig`](crate::config::LineConfig) field:
    /// `LineConfig` is the module's own parameter set ([Modbus/USS] §3.3.5–§3.9, Table 3-11, what
    /// si-dp-coord reads from a parameter record), and this is not one of the module's parameters.
    pub fn with_frame_end(mut self, frame_end: FrameEnd) -> Self {
        self.rx.set_frame_end(frame_end);
        self
    }

    /// The physical interface ([Modbus/USS] §3.4.1, §3.4.3; RS-232C by default). On RS-485 a
    /// request starts at a correctly received slave address (this slave's or broadcast) in
    /// Normal mode too: a turnaround glitch or noise before it is skipped, as on the master
    /// ([`Master::with_interface`](crate::master::Master::with_interface)).
    pub fn with_interface(mut self, interface: si_core::Interface) -> Self {
        self.rx.set_interface(interface);
        self
    }

    /// How received frames end.
    pub fn frame_end(&self) -> FrameEnd {
        self.rx.frame_end()
    }

    /// The parameters.
    pub fn config(&self) -> &SlaveConfig {
        &self.config
    }

    /// The store, to inspect.
    pub fn store(&self) -> &S {
        &self.store
    }

    /// The store, to change (a simulated process).
    pub fn store_mut(&mut self) -> &mut S {
        &mut self.store
    }

    /// Receive statistics.
    pub fn counters(&self) -> Counters {
        self.rx.counters()
    }

    fn event(&mut self, e: SlaveEvent) {
        self.out.push_back(Output::Event(e));
    }

    fn transmit(&mut self, now: Instant, adu: &Adu) {
        let gate = self.tx.transmit(now, adu.as_bytes(), &mut self.out);
        self.on_gate(now, gate);
    }

    /// What became of the response at the automatic V.24 gate ([Modbus/USS] §3.2.2; without it,
    /// always sent).
    fn on_gate(&mut self, now: Instant, gate: Gate) {
        match gate {
            Gate::Sent(len) => {
                self.busy_until = Some(Transmitter::on_air(
                    &self.config.line,
                    &mut self.rx,
                    now,
                    len,
                ));
            }
            Gate::Aborted => self.event(SlaveEvent::Error(status::DSR_CTS_OFF)),
            Gate::Held | Gate::Nothing => {}
        }
    }

    fn exception(
        &mut self,
        now: Instant,
        function: u8,
        code: ExceptionCode,
        status: Option<Status>,
        error: Option<StoreError>,
    ) {
        if let Ok(adu) = Adu::response(self.config.address, &Response::Exception { function, code })
        {
            self.transmit(now, &adu);
        }
        self.event(SlaveEvent::Exception {
            function,
            code,
            status,
            error,
        });
    }

    fn on_frame(&mut self, now: Instant, frame: Received) {
        let overlapped = core::mem::take(&mut self.overlapped);
        if let Some(fault) = frame.fault {
            self.event(SlaveEvent::Error(fault_status(fault)));
            return;
        }
        let bytes = frame.adu.as_bytes();
        let unit = bytes[0];
        if unit != self.config.address && unit != BROADCAST {
            // [Modbus/USS] §3.3.2: not interpreted, not answered; counted as garbage unless it is a
            // good frame for another slave.
            if !frame::crc_ok(bytes) {
                self.rx.count_discarded();
            }
            return;
        }
        if overlapped {
            self.rx.count_discarded();
            self.event(SlaveEvent::Error(codes::SEQUENCE));
            return;
        }
        let function = bytes[1];
        let broadcast = unit == BROADCAST;
        let request = match frame::decode_request(bytes) {
            Ok((_, r)) => r,
            Err(e) => {
                self.rx.count_discarded();
                if e.kind == DecodeErrorKind::Crc {
                    // A request cut in two by a late packet fails its CRC: name the adapter.
                    let status = self.rx.delivery().annotate(codes::CRC);
                    self.event(SlaveEvent::Error(status));
                    return;
                }
                let (code, status) = serve::refusal(e.kind);
                if broadcast {
                    let s = if fc::broadcast_allowed(function) {
                        status
                    } else {
                        Some(codes::BROADCAST_NOT_ALLOWED)
                    };
                    if let Some(s) = s {
                        self.event(SlaveEvent::Error(s));
                    }
                } else {
                    self.exception(now, function, code, status, None);
                }
                return;
            }
        };
        if broadcast && !fc::broadcast_allowed(function) {
            self.event(SlaveEvent::Error(codes::BROADCAST_NOT_ALLOWED));
            return;
        }
        let mut data: ResponseData = [0; 256];
        match serve::execute(&mut self.store, &request, &mut data) {
            Outcome::Answer {
                response,
                address,
                quantity,
            } => {
                if broadcast {
                    self.event(SlaveEvent::Broadcast {
                        function,
                        address,
                        quantity,
                    });
                } else {
                    let adu = Adu::response(self.config.address, &response);
                    if let Ok(adu) = adu {
                        self.transmit(now, &adu);
                    }
                    self.event(SlaveEvent::Served {
                        function,
                        address,
                        quantity,
                    });
                }
            }
            Outcome::Refused {
                code,
                status,
                error,
            } => {
                if broadcast {
                    // Refused like a unicast request, but a broadcast is never answered.
                    self.event(SlaveEvent::Exception {
                        function,
                        code,
                        status,
                        error,
                    });
                } else {
                    self.exception(now, function, code, status, error);
                }
            }
        }
    }

    fn tick(&mut self, now: Instant) {
        // Busy until tx-done or the estimated end of our transmission, whichever comes first.
        if self.busy_until.is_some_and(|t| now >= t) {
            self.busy_until = None;
        }
        let gate = self.tx.on_timeout(now, &mut self.out);
        self.on_gate(now, gate);
        self.end_frame(now);
    }

    /// Hand up the frame that has ended, if any. A frame the receiver drops itself (too short,
    /// suppressed) also ends an overlap: the next request is judged on its own.
    fn end_frame(&mut self, now: Instant) {
        if let Some(frame) = self.rx.poll(now) {
            self.on_frame(now, frame);
        }
        if !self.rx.is_receiving() {
            self.overlapped = false;
        }
    }
}

fn fault_status(fault: Fault) -> Status {
    match fault {
        Fault::Overflow => codes::RECEIVE_BUFFER_OVERFLOW,
        Fault::Line(LineError::Parity) => status::PARITY_ERROR,
        Fault::Line(LineError::Framing) => status::FRAMING_ERROR,
        Fault::Line(LineError::Overrun) => status::TRANSMISSION_ERROR,
        Fault::Line(LineError::Break) => status::BREAK,
    }
}

impl<S: Store> Engine for Slave<S> {
    type Event = SlaveEvent;

    fn handle_rx(&mut self, now: Instant, mut bytes: &[u8]) {
        self.rx.observe_read(now, bytes.len());
        self.tick(now);
        if !self.tx.may_receive() {
            return; // [Modbus/USS] §3.2.2 item 6: nothing is received while DSR = OFF
        }
        let own = self.config.address;
        while !bytes.is_empty() {
            let was_receiving = self.rx.is_receiving();
            let taken = self
                .rx
                .push(now, bytes, |b| b == own || b == BROADCAST, Expect::Request);
            bytes = &bytes[taken..];
            if !was_receiving && self.rx.is_receiving() && self.busy_until.is_some() {
                self.overlapped = true;
            }
            // A request complete by its length (FrameEnd::Length) is answered at once; the
            // rest of the bytes start the next frame.
            self.end_frame(now);
        }
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.tick(now);
    }

    fn handle_tx_done(&mut self, now: Instant) {
        self.tick(now);
        self.busy_until = None;
        // The RTS-off time of automatic V.24 ([Modbus/USS] §3.2.2 item 5) runs from the last byte
        // actually leaving, which only the driver knows: not from the engine's estimate.
        self.tx.sent(now, &mut self.out);
    }

    fn set_rx_latency(&mut self, latency: Duration) {
        self.rx.set_rx_latency(latency);
    }

    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        self.tick(now);
        self.rx.line_error(now, error);
    }

    fn handle_signals(&mut self, now: Instant, signals: ModemSignals) {
        self.tick(now);
        let (gate, dsr_dropped) = self.tx.on_signals(signals, &mut self.out);
        self.on_gate(now, gate);
        if dsr_dropped && self.rx.is_receiving() {
            // [Modbus/USS] §3.2.2 item 7: DSR ON → OFF aborts a reception.
            self.rx.discard();
            self.event(SlaveEvent::Error(status::DSR_CTS_OFF));
        }
    }

    fn poll_output(&mut self) -> Output<SlaveEvent> {
        self.out.pop_front().unwrap_or_else(|| {
            let own = Instant::earliest(self.rx.deadline(), self.busy_until);
            Output::Wait(Instant::earliest(own, self.tx.deadline()))
        })
    }
}

const _: () = assert!(MAX_ADU >= 256);
