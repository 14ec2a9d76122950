//! A simulated USS slave: a drive with parameters and process data, for tests, examples and
//! `si sim` / `si uss sim-slave`.
//!
//! What it does ([USS spec], [SINAMICS V20] p. 107 and [SINAMICS CU240S] p. 229 unless
//! noted):
//! - receives telegrams with the start-interval and residual-run-time rules, discards any with a
//!   character error, wrong LGE or wrong BCC and does **not** answer them ([USS spec] §5.2.2);
//! - answers a normal telegram to its address after its response delay (≥ start interval,
//!   ≤ 20 ms), with its PKW response and PZD (ZSW, HIW, then zeros);
//! - takes a broadcast's PZD (control word, setpoint) without answering; sends a mirror telegram
//!   back unchanged; ignores special telegrams (bit 7) and undefined ADR combinations;
//! - PKW: executes a request once and answers the same response while the master repeats it
//!   (the handshake); read/write word and double word, arrays; AK 7 with error numbers 0 (no such
//!   parameter), 1 (read-only), 2 (limit), 3 (sub-index), 4 (no array), 5 (type), 101 (task not
//!   supported by this simulation); response ID 8 to every task with
//!   [`DriveConfig::no_pkw_rights`];
//! - parameter change reports ([`Drive::change_locally`]): response ID 9/10 with the SPM toggle
//!   bit flipped, answered to "no task" requests until the master mirrors the toggle bit;
//! - the status word follows the control word and the actual value ramps to the setpoint
//!   ([`zsw`] bits).

use crate::config::{check, start_interval, ConfigError, RESPONSE_DELAY_MAX};
use crate::frame::{
    self, response, task, Adr, NetData, ParamAddress, Pke, Pkw, PkwWords, Pzd, MAX_ADDRESS,
    MAX_TELEGRAM,
};
use crate::rx::{Receiver, RxOutcome};
use serde::{Deserialize, Serialize};
use si_core::echo::EchoFilter;
use si_core::{Duration, Engine, FramePool, Instant, LineError, Output, SerialSettings};
use std::collections::VecDeque;

/// Control word STW bits the drive reacts to (PROFIdrive/MICROMASTER meaning).
pub mod stw {
    /// Bit 0: ON / OFF1.
    pub const ON: u16 = 1 << 0;
    /// Bit 1: no OFF2 (coast stop).
    pub const NO_OFF2: u16 = 1 << 1;
    /// Bit 2: no OFF3 (quick stop).
    pub const NO_OFF3: u16 = 1 << 2;
    /// Bit 3: enable operation.
    pub const ENABLE: u16 = 1 << 3;
    /// Bit 7: acknowledge fault (rising edge).
    pub const ACK_FAULT: u16 = 1 << 7;
    /// Bit 10: control by PLC.
    pub const PLC_CONTROL: u16 = 1 << 10;
    /// The usual "run" word: ON, no OFF2, no OFF3, enable, ramp generator bits 4–6, PLC control.
    pub const RUN: u16 = 0x047F;
    /// The usual "ready, stopped" word: as RUN without ON.
    pub const STOP: u16 = 0x047E;
}

/// Status word ZSW bits the drive sets.
pub mod zsw {
    /// Bit 0: ready to switch on.
    pub const READY_TO_SWITCH_ON: u16 = 1 << 0;
    /// Bit 1: ready to operate (STW ON).
    pub const READY: u16 = 1 << 1;
    /// Bit 2: operation enabled (STW ON and ENABLE, no OFF2/OFF3).
    pub const RUNNING: u16 = 1 << 2;
    /// Bit 3: fault (the master sets comm status bit 6 from it).
    pub const FAULT: u16 = 1 << 3;
    /// Bit 4: no OFF2 active.
    pub const NO_OFF2: u16 = 1 << 4;
    /// Bit 5: no OFF3 active.
    pub const NO_OFF3: u16 = 1 << 5;
    /// Bit 7: warning (the master sets comm status bit 7 from it).
    pub const WARNING: u16 = 1 << 7;
    /// Bit 8: actual value equals the setpoint.
    pub const AT_SETPOINT: u16 = 1 << 8;
    /// Bit 9: control by PLC requested (with STW bit 10 the master sets comm status bit 8).
    pub const PLC_REQUESTED: u16 = 1 << 9;
    /// Bit 10: running and the setpoint reached.
    pub const SETPOINT_REACHED: u16 = 1 << 10;
}

/// One parameter of the simulated drive.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Parameter {
    /// Full parameter number (0…61 999, [`crate::param`]).
    pub number: u16,
    /// Values by sub-index; one for a simple parameter.
    pub values: Vec<u32>,
    /// A double-word parameter (answered with response IDs 2/5).
    pub dword: bool,
    /// Writes are refused with error 1.
    pub read_only: bool,
    /// Smallest value a write may set.
    pub min: u32,
    /// Largest value a write may set.
    pub max: u32,
    /// The value is signed: `min`, `max` and writes are compared as 16-bit (word) or 32-bit
    /// (double word) two's complement numbers.
    #[serde(default)]
    pub signed: bool,
}

impl Parameter {
    /// A writable word parameter 0…65 535.
    pub fn word(number: u16, value: u16) -> Self {
        Parameter {
            number,
            values: vec![u32::from(value)],
            dword: false,
            read_only: false,
            signed: false,
            min: 0,
            max: u32::from(u16::MAX),
        }
    }
    /// A writable double-word parameter.
    pub fn dword(number: u16, value: u32) -> Self {
        Parameter {
            dword: true,
            max: u32::MAX,
            values: vec![value],
            ..Parameter::word(number, 0)
        }
    }
    /// The same, read-only.
    pub fn read_only(mut self) -> Self {
        self.read_only = true;
        self
    }
    /// The same, with write limits.
    pub fn limits(mut self, min: u32, max: u32) -> Self {
        self.min = min;
        self.max = max;
        self
    }
    /// The same, signed, with write limits `min`…`max`.
    pub fn signed(mut self, min: i32, max: i32) -> Self {
        self.signed = true;
        self.min = min as u32;
        self.max = max as u32;
        self
    }
    /// May a write set `value` (a word's or double word's bit pattern)?
    fn allows(&self, value: u32) -> bool {
        if self.signed {
            let s = |x: u32| {
                if self.dword {
                    x as i32
                } else {
                    i32::from(x as u16 as i16)
                }
            };
            (s(self.min)..=s(self.max)).contains(&s(value))
        } else {
            (self.min..=self.max).contains(&value)
        }
    }
    /// The same, as an array of `values`.
    pub fn array(mut self, values: &[u32]) -> Self {
        self.values = values.to_vec();
        self
    }
}

/// How the simulated drive behaves.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DriveConfig {
    /// Character format.
    pub settings: SerialSettings,
    /// Bus address 0…31.
    pub address: u8,
    /// PKW words (P2013).
    pub pkw: PkwWords,
    /// PZD words 0…16 (P2012).
    pub pzd_words: u8,
    /// Delay from the request's last character to the response (≥ start interval, ≤ 20 ms).
    pub response_delay: Duration,
    /// How fast the actual value follows the setpoint, in units per second.
    pub ramp_per_second: u32,
    /// The transceiver hears its own transmission (RS-485 bus): skip that many characters.
    pub local_echo: bool,
    /// Parameters.
    pub parameters: Vec<Parameter>,
    /// The master has no PKW rights here: every task other than AK 0 is answered with response
    /// ID 8, "no master control / no PKW rights" ([SINAMICS V20] p. 107), as a drive whose PKW
    /// channel belongs to another interface answers.
    #[serde(default)]
    pub no_pkw_rights: bool,
}

impl DriveConfig {
    /// A drive at `address` with PKW 4 / PZD 2, answering after the start interval, ramping
    /// 10 000 units a second, with a few parameters: P700 (command source, word, 0…6),
    /// P1082 (max frequency, word, limit 0…650), P2010 (USS baud index, array of 2), P964
    /// (firmware version, read-only), P2000 (reference frequency, double word), P1120 (a signed
    /// word, −1000…1000, for negative values) and P20001 (a word above 19 999, page index 50H).
    pub fn new(settings: SerialSettings, address: u8) -> Self {
        DriveConfig {
            settings,
            address,
            pkw: PkwWords::Four,
            pzd_words: 2,
            response_delay: start_interval(&settings),
            ramp_per_second: 10_000,
            local_echo: false,
            no_pkw_rights: false,
            parameters: vec![
                Parameter::word(700, 5).limits(0, 6),
                Parameter::word(1082, 50).limits(0, 650),
                Parameter::word(2010, 6).array(&[6, 6]),
                Parameter::word(964, 0x0102).read_only(),
                Parameter::dword(2000, 50_000),
                Parameter::word(1120, 10).signed(-1000, 1000),
                Parameter::word(20001, 0),
            ],
        }
    }
}

/// What the drive reports.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DriveEvent {
    /// A telegram for this drive was taken (and answered unless broadcast).
    Polled {
        /// Control word received.
        stw: u16,
        /// Main setpoint received.
        setpoint: u16,
        /// Status word answered.
        zsw: u16,
        /// Actual value answered.
        actual: u16,
    },
    /// A parameter was changed by a PKW write.
    Written {
        /// Which.
        param: ParamAddress,
        /// The new value.
        value: u32,
    },
    /// A broadcast was taken.
    Broadcast,
    /// A mirror telegram was sent back.
    Mirrored,
    /// A telegram was discarded without an answer.
    Discarded {
        /// Why.
        reason: &'static str,
    },
}

/// The simulated drive engine.
pub struct Drive {
    config: DriveConfig,
    rx: Receiver,
    out: VecDeque<Output<DriveEvent>>,
    tx: [u8; MAX_TELEGRAM],
    tx_len: usize,
    reply_at: Option<Instant>,
    /// A line that echoes our replies: as many received characters (or line errors) as we
    /// sent are dropped (si-core's one echo filter, count mode).
    echo: EchoFilter,
    stw: u16,
    setpoint: u16,
    actual: u16,
    ramp_remainder: u64,
    last_update: Option<Instant>,
    last_request: Option<Pkw>,
    last_response: Option<Pkw>,
    fault: bool,
    warning: bool,
    /// A parameter changed locally, reported until the master acknowledges the toggle bit.
    pending_report: Option<(ParamAddress, u32, bool)>,
    report_toggle: bool,
    /// Transmit frames are cut from this pool: a steady state allocates nothing per frame (the
    /// si-core contract).
    tx_pool: FramePool,
}

impl Drive {
    /// A drive; the address must be 0…31, PZD 0…16 words, the response delay at most 20 ms.
    pub fn new(config: DriveConfig) -> Result<Self, ConfigError> {
        check(
            config.address <= MAX_ADDRESS,
            "address",
            config.address,
            "0…31",
        )?;
        check(
            config.pzd_words <= 16,
            "PZD words",
            config.pzd_words,
            "0…16",
        )?;
        check(
            config.response_delay <= RESPONSE_DELAY_MAX,
            "response delay",
            config.response_delay,
            "start interval … 20 ms",
        )?;
        Ok(Drive {
            rx: Receiver::new(config.settings),
            out: VecDeque::with_capacity(8),
            tx: [0; MAX_TELEGRAM],
            tx_len: 0,
            tx_pool: FramePool::preallocated(4 * MAX_TELEGRAM),
            reply_at: None,
            echo: EchoFilter::counting(),
            stw: 0,
            setpoint: 0,
            actual: 0,
            ramp_remainder: 0,
            last_update: None,
            last_request: None,
            last_response: None,
            fault: false,
            warning: false,
            pending_report: None,
            report_toggle: false,
            config,
        })
    }

    /// The configuration (parameters as last written).
    pub fn config(&self) -> &DriveConfig {
        &self.config
    }

    /// The value of parameter `number`, sub-index `index`.
    pub fn parameter(&self, number: u16, index: u8) -> Option<u32> {
        self.config
            .parameters
            .iter()
            .find(|p| p.number == number)
            .and_then(|p| p.values.get(usize::from(index)).copied())
    }

    /// Raise or clear the fault bit (ZSW bit 3); an STW bit 7 edge also clears it.
    pub fn set_fault(&mut self, fault: bool) {
        self.fault = fault;
    }

    /// Change a parameter "at the operator panel": the value is set and a parameter change
    /// report (response ID 9, or 10 for a double word, with the SPM toggle bit flipped) answers
    /// the master's "no task" requests until the master sends the toggle bit back. False if
    /// there is no such parameter or sub-index.
    pub fn change_locally(&mut self, number: u16, index: u8, value: u32) -> bool {
        let Some(p) = self
            .config
            .parameters
            .iter_mut()
            .find(|p| p.number == number)
        else {
            return false;
        };
        let Some(slot) = p.values.get_mut(usize::from(index)) else {
            return false;
        };
        *slot = value;
        self.report_toggle = !self.report_toggle;
        self.pending_report = Some((ParamAddress { number, index }, value, p.dword));
        true
    }

    /// Raise or clear the warning bit (ZSW bit 7).
    pub fn set_warning(&mut self, warning: bool) {
        self.warning = warning;
    }

    /// The actual value now.
    pub fn actual(&self) -> u16 {
        self.actual
    }

    /// The status word from the last control word and the actual value.
    pub fn status_word(&self) -> u16 {
        let s = self.stw;
        let mut z = zsw::PLC_REQUESTED;
        if !self.fault {
            z |= zsw::READY_TO_SWITCH_ON;
        } else {
            z |= zsw::FAULT;
        }
        let on = s & stw::ON != 0 && !self.fault;
        if on {
            z |= zsw::READY;
        }
        if s & stw::NO_OFF2 != 0 {
            z |= zsw::NO_OFF2;
        }
        if s & stw::NO_OFF3 != 0 {
            z |= zsw::NO_OFF3;
        }
        let running = self.running();
        if running {
            z |= zsw::RUNNING;
        }
        if self.warning {
            z |= zsw::WARNING;
        }
        if self.actual == self.target() {
            z |= zsw::AT_SETPOINT;
            if running {
                z |= zsw::SETPOINT_REACHED;
            }
        }
        z
    }

    fn running(&self) -> bool {
        let need = stw::ON | stw::NO_OFF2 | stw::NO_OFF3 | stw::ENABLE;
        self.stw & need == need && !self.fault
    }

    fn target(&self) -> u16 {
        if self.running() {
            self.setpoint
        } else {
            0
        }
    }

    /// Move the actual value towards the target for the time since the last update.
    fn ramp(&mut self, now: Instant) {
        let elapsed = self
            .last_update
            .map_or(0, |t| now.saturating_since(t).as_micros());
        self.last_update = Some(now);
        let units = u64::from(self.config.ramp_per_second)
            .saturating_mul(elapsed)
            .saturating_add(self.ramp_remainder);
        let step = units / 1_000_000;
        self.ramp_remainder = units % 1_000_000;
        let target = self.target();
        let step = step.min(u64::from(u16::MAX)) as u16;
        self.actual = if self.actual < target {
            self.actual.saturating_add(step).min(target)
        } else {
            self.actual.saturating_sub(step).max(target)
        };
        if self.actual == target {
            self.ramp_remainder = 0;
        }
    }

    fn take_control(&mut self, now: Instant, pzd: &Pzd) {
        self.ramp(now);
        if let Some(w) = pzd.first() {
            if w & stw::ACK_FAULT != 0 && self.stw & stw::ACK_FAULT == 0 {
                self.fault = false;
            }
            self.stw = w;
        }
        if let Some(w) = pzd.second() {
            self.setpoint = w;
        }
    }

    fn queue_reply(&mut self, now: Instant, adr: Adr, net: &[u8]) {
        self.tx_len = frame::encode(adr, net, &mut self.tx).unwrap_or(0);
        let delay = self
            .config
            .response_delay
            .max(start_interval(&self.config.settings));
        self.reply_at = Some(now + delay);
    }

    fn on_telegram(&mut self, now: Instant) {
        let mut bytes = [0u8; MAX_TELEGRAM];
        let t = self.rx.telegram();
        let len = t.len();
        bytes[..len].copy_from_slice(t);
        let telegram = match frame::decode(&bytes[..len]) {
            Ok(t) => t,
            Err(_) => {
                self.discard("BCC, LGE or STX error");
                return;
            }
        };
        let adr = telegram.adr;
        let mine = adr.address() == self.config.address;
        match adr.0 & 0xE0 {
            0x00 if mine => self.data_exchange(now, telegram.net),
            0x40 if mine => {
                self.queue_reply(now, adr, telegram.net);
                self.out.push_back(Output::Event(DriveEvent::Mirrored));
            }
            0x20 => {
                match NetData::parse(
                    telegram.net,
                    self.config.pkw,
                    usize::from(self.config.pzd_words),
                ) {
                    Ok(net) => {
                        self.take_control(now, &net.pzd);
                        self.out.push_back(Output::Event(DriveEvent::Broadcast));
                    }
                    Err(_) => self.discard("broadcast with another net-data structure"),
                }
            }
            0x00 | 0x40 => {} // another slave's telegram
            _ => self.discard("special or undefined telegram type"),
        }
    }

    fn discard(&mut self, reason: &'static str) {
        self.out
            .push_back(Output::Event(DriveEvent::Discarded { reason }));
    }

    fn data_exchange(&mut self, now: Instant, net: &[u8]) {
        let request = match NetData::parse(net, self.config.pkw, usize::from(self.config.pzd_words))
        {
            Ok(r) => r,
            Err(_) => {
                self.discard("net data do not match PKW/PZD");
                return;
            }
        };
        self.take_control(now, &request.pzd);
        if let Some(p) = request.pkw {
            if self.pending_report.is_some() && p.pke.spm() == self.report_toggle {
                self.pending_report = None; // the master acknowledged the report
            }
        }
        let pkw = request.pkw.map(|p| {
            if let Some((param, value, dword)) = self.pending_report {
                if p.pke.ak() == task::NONE {
                    return self.change_report(&p, param, value, dword);
                }
            }
            if self.last_request == Some(p) {
                if let Some(r) = self.last_response {
                    return r;
                }
            }
            let r = self.execute(&p);
            self.last_request = Some(p);
            self.last_response = Some(r);
            r
        });
        let zsw = self.status_word();
        let mut words = [0u16; 16];
        let n = usize::from(self.config.pzd_words);
        if n > 0 {
            words[0] = zsw;
        }
        if n > 1 {
            words[1] = self.actual;
        }
        let reply = NetData {
            pkw,
            pzd: Pzd::new(&words[..n]),
        };
        let mut buf = [0u8; frame::MAX_NET];
        let len = reply.write(&mut buf).unwrap_or(0);
        let adr = Adr(self.config.address);
        self.queue_reply(now, adr, &buf[..len]);
        self.out.push_back(Output::Event(DriveEvent::Polled {
            stw: self.stw,
            setpoint: self.setpoint,
            zsw,
            actual: self.actual,
        }));
    }

    /// The change report in a PKW area the size of the request's.
    fn change_report(&self, req: &Pkw, param: ParamAddress, value: u32, dword: bool) -> Pkw {
        let (pnu, ind) = param.split().unwrap_or((0, 0));
        let dword = dword && req.pwe().len() >= 2;
        let id = if dword {
            response::CHANGE_REPORT_WORD + 1
        } else {
            response::CHANGE_REPORT_WORD
        };
        let pke = Pke::new(id, self.report_toggle, pnu);
        match req.pwe().len() {
            0 => Pkw::new(pke, ind, &[]),
            1 => Pkw::new(pke, ind, &[value as u16]),
            n => {
                let mut pwe = [0u16; frame::MAX_PWE_WORDS];
                if dword {
                    pwe[0] = (value >> 16) as u16;
                }
                pwe[1] = value as u16;
                Pkw::new(pke, ind, &pwe[..n])
            }
        }
    }

    /// Execute one PKW request and build the response area (same size as the request's).
    fn execute(&mut self, req: &Pkw) -> Pkw {
        let ak = req.pke.ak();
        let pnu = req.pke.pnu();
        let param = ParamAddress::join(pnu, req.ind);
        let words = req.pwe().len();
        let reply = |ak: u8, value: u32, dword: bool| {
            let pke = Pke::new(ak, false, pnu);
            let mut pwe = [0u16; 2];
            match (words, dword) {
                (0, _) => {}
                (1, _) => pwe[0] = value as u16,
                (_, true) => pwe = [(value >> 16) as u16, value as u16],
                (_, false) => pwe = [0, value as u16],
            }
            let mut area = [0u16; frame::MAX_PWE_WORDS];
            area[..words.min(2)].copy_from_slice(&pwe[..words.min(2)]);
            Pkw::new(pke, req.ind, &area[..words])
        };
        let error = |n: u16| reply(response::CANNOT_EXECUTE, u32::from(n), false);
        if ak == task::NONE {
            return Pkw::new(Pke(0), 0, &[0u16; frame::MAX_PWE_WORDS][..words]);
        }
        if self.config.no_pkw_rights {
            return reply(response::NO_PERMISSION, 0, false);
        }
        let Some(p) = self
            .config
            .parameters
            .iter_mut()
            .find(|p| p.number == param.number)
        else {
            return error(0);
        };
        let index = usize::from(param.index);
        let is_array = p.values.len() > 1;
        let dword = p.dword && words >= 2;
        let (value_id, array_id) = if dword {
            (response::VALUE_DWORD, response::ARRAY_DWORD)
        } else {
            (response::VALUE_WORD, response::ARRAY_WORD)
        };
        let requested = req.value();
        match ak {
            task::READ | task::READ_ARRAY => {
                if ak == task::READ_ARRAY && !is_array {
                    return error(4);
                }
                match p.values.get(index) {
                    Some(&v) => reply(if is_array { array_id } else { value_id }, v, dword),
                    None => error(3),
                }
            }
            task::READ_ARRAY_LEN => reply(response::ARRAY_LEN, p.values.len() as u32, false),
            task::WRITE_WORD
            | task::WRITE_WORD_EEPROM
            | task::WRITE_DWORD
            | task::WRITE_DWORD_EEPROM
            | task::WRITE_ARRAY_WORD
            | task::WRITE_ARRAY_WORD_EEPROM
            | task::WRITE_ARRAY_DWORD
            | task::WRITE_ARRAY_DWORD_EEPROM => {
                let wants_dword = matches!(
                    ak,
                    task::WRITE_DWORD
                        | task::WRITE_DWORD_EEPROM
                        | task::WRITE_ARRAY_DWORD
                        | task::WRITE_ARRAY_DWORD_EEPROM
                );
                let array_task = matches!(
                    ak,
                    task::WRITE_ARRAY_WORD
                        | task::WRITE_ARRAY_WORD_EEPROM
                        | task::WRITE_ARRAY_DWORD
                        | task::WRITE_ARRAY_DWORD_EEPROM
                );
                if p.read_only {
                    return error(1);
                }
                if wants_dword != p.dword {
                    return error(5);
                }
                if array_task && !is_array {
                    return error(4);
                }
                if index >= p.values.len() {
                    return error(3);
                }
                if !p.allows(requested) {
                    return error(2);
                }
                p.values[index] = requested;
                self.out.push_back(Output::Event(DriveEvent::Written {
                    param,
                    value: requested,
                }));
                let id = if array_task { array_id } else { value_id };
                reply(id, requested, dword)
            }
            _ => error(101),
        }
    }
}

impl Engine for Drive {
    type Event = DriveEvent;

    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.rx.observe_read(now, bytes.len());
        for &b in bytes {
            if self.echo.drops(now, b) {
                continue;
            }
            match self.rx.push(now, b) {
                RxOutcome::Complete => self.on_telegram(now),
                RxOutcome::LengthError => self.discard("LGE out of range"),
                RxOutcome::Pending | RxOutcome::StartNotIdentified => {}
            }
        }
    }

    fn set_rx_latency(&mut self, latency: Duration) {
        self.rx.set_rx_latency(latency);
    }

    fn handle_timeout(&mut self, now: Instant) {
        if self.rx.timeout(now).is_some() {
            self.discard("residual run time exceeded");
        }
        if self.reply_at.is_some_and(|t| now >= t) {
            self.reply_at = None;
            let len = self.tx_len;
            let telegram = self.tx_pool.cut(&self.tx[..len]);
            self.out.push_back(Output::Transmit(telegram));
            if self.config.local_echo {
                // A new reply: an echo of the previous one not heard back is forgotten.
                self.echo.stop();
                self.echo.sent_len(len);
            }
        }
    }

    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        if self.echo.drops_line_error() {
            return;
        }
        if self.rx.is_receiving() {
            self.discard("character error");
        }
        self.rx.line_error(now, error);
    }

    fn poll_output(&mut self) -> Output<DriveEvent> {
        if let Some(o) = self.out.pop_front() {
            return o;
        }
        Output::Wait(Instant::earliest(self.reply_at, self.rx.deadline()))
    }
}
