//! The module's three LEDs, SF (red), TX and RX (green), as a pure function of the module's
//! state and the time.
//!
//! [ET200S SI 2005] §2.1, §2.9.5–§2.11, Table 2-12, [ET200S SI] §2.1, §2.13,
//! [Modbus/USS] §3.1 (Table 3-2):
//!
//! * **SF** (group fault) lights for a hardware fault, a firmware error, a parameter error, a
//!   wire break or loose cable, a communication error (parity, framing, buffer overflow), and
//!   during re-parameterization.
//! * **TX** lights while the module sends, **RX** while it receives.
//! * During a **firmware update** the LEDs follow Table 2-12 instead:
//!
//! | State | SF | TX | RX |
//! |---|---|---|---|
//! | update in progress | on | on | on |
//! | update finished | on | off | off |
//! | no module firmware | flashing 2 Hz | off | off |
//! | hardware fault during the update | flashing 2 Hz | flashing 2 Hz | flashing 2 Hz |
//!
//! [`leds`] gives each LED's pattern; [`Light::is_lit`] says whether it is lit at an instant.
//! [`ModuleState::with_line`] fills in TX and RX from a line simulator's trace, so a simulated
//! module's LEDs follow what its line really did, in virtual time.
//!
//! # Readings
//!
//! - **How long SF stays lit after a communication error.** The manuals name the causes, not a
//!   duration. We light SF while a communication error is *pending*: from the error until the CPU
//!   has fetched it (the module keeps a receive error in its buffer until a receive job reports
//!   it, [ET200S SI 2005] §2.12.7 case 2). The caller says so with
//!   [`ModuleState::communication_error`].
//! - **Wire break** lights SF only where the module can see it: RS-422 with the receive-line
//!   initial state R(A) 5 V / R(B) 0 V ([ET200S SI 2005] §2.1). The caller reports what the line
//!   shows.
//! - **2 Hz flashing** is 250 ms on, 250 ms off, in phase from time zero, so the three LEDs of a
//!   hardware fault flash together.
//! - **STOP** by itself does not light SF; its causes (wire break, invalid parameters) do.

use serde::{Deserialize, Serialize};
use si_core::trace::{Trace, TraceKind};
use si_core::{Instant, SerialSettings};

/// Half a period of the 2 Hz flashing.
pub const FLASH_HALF_PERIOD_US: u64 = 250_000;

/// What one LED does.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Light {
    /// Dark.
    #[default]
    Off,
    /// Lit.
    On,
    /// Flashing at 2 Hz (firmware states of Table 2-12).
    Flashing,
}

impl Light {
    /// Whether the LED is lit at `now`.
    pub const fn is_lit(self, now: Instant) -> bool {
        match self {
            Light::Off => false,
            Light::On => true,
            Light::Flashing => (now.as_micros() / FLASH_HALF_PERIOD_US).is_multiple_of(2),
        }
    }

    const fn from(on: bool) -> Light {
        if on {
            Light::On
        } else {
            Light::Off
        }
    }
}

/// The three LEDs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Leds {
    /// SF, red, group fault.
    pub sf: Light,
    /// TX, green, sending.
    pub tx: Light,
    /// RX, green, receiving.
    pub rx: Light,
}

impl Leds {
    /// Which LEDs are lit at `now`, as (SF, TX, RX).
    pub const fn lit(&self, now: Instant) -> (bool, bool, bool) {
        (
            self.sf.is_lit(now),
            self.tx.is_lit(now),
            self.rx.is_lit(now),
        )
    }
}

/// The module's operating mode ([ET200S SI 2005] §2.11, §3.9).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OperatingMode {
    /// No driver active; every job is refused.
    Stop,
    /// The driver is being initialized with new parameters: SF is lit.
    Parameterizing,
    /// Normal operation.
    #[default]
    Run,
}

/// The firmware's state ([ET200S SI 2005] §2.9.5, Table 2-12).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Firmware {
    /// Firmware present, no update running: the LEDs show the operating state.
    #[default]
    Running,
    /// An update is being written.
    Updating,
    /// The update has finished (the new firmware is active after the restart).
    UpdateFinished,
    /// No firmware (deleted, or an update was aborted); an update is still possible.
    Missing,
    /// Erasing or writing failed during the update.
    HardwareFault,
}

/// Everything the LEDs depend on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ModuleState {
    /// Operating mode.
    pub mode: OperatingMode,
    /// Firmware state.
    pub firmware: Firmware,
    /// A hardware or firmware fault.
    pub hardware_fault: bool,
    /// The parameters are missing or invalid.
    pub parameter_error: bool,
    /// Wire break or loose cable seen on the line.
    pub wire_break: bool,
    /// A communication error (parity, framing, buffer overflow) not yet fetched by the CPU.
    pub communication_error: bool,
    /// Bytes are leaving the transmitter.
    pub transmitting: bool,
    /// A frame is being received.
    pub receiving: bool,
}

impl ModuleState {
    /// This state with `transmitting` and `receiving` taken from a simulator trace: the
    /// station's transmitter is busy at `now`, or a character is arriving at its receiver
    /// (see [`line_activity`]).
    pub fn with_line(
        self,
        trace: &Trace,
        station: &str,
        settings: &SerialSettings,
        now: Instant,
    ) -> ModuleState {
        let (transmitting, receiving) = line_activity(trace, station, settings, now);
        ModuleState {
            transmitting,
            receiving,
            ..self
        }
    }
}

/// Whether `station` is sending and whether it is receiving at `now`, from a simulator trace.
///
/// Sending: from the moment a transmission starts (its trace time, or when the previous one has
/// left the transmitter) for the characters' time on the line. Receiving: during each
/// character's time on the line before it arrived (and the character time before a UART error).
pub fn line_activity(
    trace: &Trace,
    station: &str,
    settings: &SerialSettings,
    now: Instant,
) -> (bool, bool) {
    let char_time = settings.char_time();
    let mut tx_free = Instant::ZERO;
    let (mut tx, mut rx) = (false, false);
    for e in trace.of(station) {
        match &e.kind {
            TraceKind::Tx { bytes } => {
                let start = if e.at > tx_free { e.at } else { tx_free };
                tx_free = start + settings.chars_time(bytes.len() as u64);
                tx |= start <= now && now < tx_free;
            }
            TraceKind::Rx { .. } | TraceKind::RxError { .. } => {
                rx |= before(e.at, char_time.as_micros()) <= now && now < e.at;
            }
            TraceKind::RxChunk { bytes } => {
                let span = settings.chars_time(bytes.len() as u64);
                rx |= before(e.at, span.as_micros()) <= now && now < e.at;
            }
            _ => {}
        }
    }
    (tx, rx)
}

fn before(at: Instant, micros: u64) -> Instant {
    Instant::from_micros(at.as_micros().saturating_sub(micros))
}

/// The LED patterns for a module state.
///
/// ```
/// use si_module::led::{leds, Firmware, Light, ModuleState};
/// use si_core::Instant;
/// let sending = ModuleState { transmitting: true, ..ModuleState::default() };
/// assert_eq!(leds(&sending).tx, Light::On);
/// let broken = ModuleState { firmware: Firmware::HardwareFault, ..ModuleState::default() };
/// let l = leds(&broken);
/// assert_eq!(l.lit(Instant::from_micros(0)), (true, true, true));
/// assert_eq!(l.lit(Instant::from_micros(300_000)), (false, false, false));
/// ```
pub const fn leds(state: &ModuleState) -> Leds {
    match state.firmware {
        Firmware::Updating => Leds {
            sf: Light::On,
            tx: Light::On,
            rx: Light::On,
        },
        Firmware::UpdateFinished => Leds {
            sf: Light::On,
            tx: Light::Off,
            rx: Light::Off,
        },
        Firmware::Missing => Leds {
            sf: Light::Flashing,
            tx: Light::Off,
            rx: Light::Off,
        },
        Firmware::HardwareFault => Leds {
            sf: Light::Flashing,
            tx: Light::Flashing,
            rx: Light::Flashing,
        },
        Firmware::Running => {
            let sf = state.hardware_fault
                || state.parameter_error
                || state.wire_break
                || state.communication_error
                || matches!(state.mode, OperatingMode::Parameterizing);
            // Nothing is sent or received outside RUN ([ET200S SI 2005] §2.11, §3.9).
            let run = matches!(state.mode, OperatingMode::Run);
            Leds {
                sf: Light::from(sf),
                tx: Light::from(run && state.transmitting),
                rx: Light::from(run && state.receiving),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flashing_is_2_hz() {
        let at = |ms: u64| Light::Flashing.is_lit(Instant::from_micros(ms * 1000));
        assert!(at(0) && at(249) && at(500) && at(1_000));
        assert!(!at(250) && !at(499) && !at(750) && !at(999));
    }
}
