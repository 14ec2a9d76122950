//! Where the bytes go: `--port PATH` or `--tcp HOST:PORT`, with the serial settings.

use crate::error::CliError;
use clap::Args;
use si_core::driver::{PortFacts, Transport, WithFacts};
use si_core::frame_log::Frames;
use si_core::linemark::Marked;
use si_core::monitor::Decoder;
use si_core::port::{self, PortOptions, Rs485Mode, Rs485ModeError};
use si_core::tap::{Tap, Watch};
use si_core::trace::TraceKind;
use si_core::tracefile::{Header, Recorder};
use si_core::{Duration, Parity, SerialSettings, SignalUpdate};
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

/// Options every command that talks to a line shares, under their own help heading
/// ([`LINE_OPTIONS`], set on each so it does not carry over to the options declared after them); `crate::help` hides them where a command opens no line.
///
/// A value comes from, in this order: the flag (or its environment variable, `SI_PORT`), the
/// `--profile` named in the settings file (`crate::profile`), the default shown here.
#[derive(Debug, Clone, Args)]
pub struct Connection {
    /// Take the line options from this profile of the settings file ($SI_CONFIG, else
    /// $XDG_CONFIG_HOME/si/config.toml or ~/.config/si/config.toml); a flag given on the
    /// command line wins over the profile.
    #[arg(long, global = true, help_heading = LINE_OPTIONS, value_name = "NAME")]
    pub profile: Option<String>,
    /// Serial port, e.g. /dev/ttyUSB0 or COM3.
    /// SI_PORT yields to a device server or Modbus TCP server given on the command line.
    #[arg(long, global = true, help_heading = LINE_OPTIONS, env = "SI_PORT")]
    pub port: Option<String>,
    /// TCP serial device server, e.g. 192.0.2.10:4001 (raw TCP mode).
    #[arg(long, global = true, help_heading = LINE_OPTIONS, value_name = "HOST:PORT")]
    pub tcp: Option<String>,
    /// Baud rate: 110, 300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 76800, 115200.
    #[arg(long, global = true, help_heading = LINE_OPTIONS, default_value_t = 9600)]
    pub baud: u32,
    /// Data bits: 7 or 8.
    #[arg(long, global = true, help_heading = LINE_OPTIONS, default_value_t = 8)]
    pub data_bits: u8,
    /// Parity: none, even, odd, mark, space (the manuals' "any" is space).
    #[arg(long, global = true, help_heading = LINE_OPTIONS, default_value = "even")]
    pub parity: String,
    /// Stop bits: 1 or 2.
    #[arg(long, global = true, help_heading = LINE_OPTIONS, default_value_t = 1)]
    pub stop_bits: u8,
    /// Set the USB adapter's latency timer to MS milliseconds (1–255) before use (Linux,
    /// /sys/bus/usb-serial/devices/TTY/latency_timer; needs write permission there). 1 makes
    /// an FTDI-type adapter deliver received bytes at once instead of every 16 ms.
    #[arg(long, global = true, help_heading = LINE_OPTIONS, value_name = "MS")]
    pub latency_timer: Option<u64>,
    /// Declare how late the port hands received bytes over, in ms (0–255), where nothing can
    /// be read from sysfs: a CH340 or CP210x adapter, a device server, a pty. 0 declares a
    /// port that delivers every byte at once (the protocols' exact timing from the first
    /// byte). Without it an FTDI adapter's latency timer is read from sysfs; any other port
    /// is taken for a 16 ms adapter until its reads show single bytes at wire pace.
    #[arg(long, global = true, help_heading = LINE_OPTIONS, value_name = "MS",
          value_parser = clap::value_parser!(u64).range(0..=255))]
    pub rx_latency: Option<u64>,
    /// RS-485 direction control: `kernel` (the UART driver's RS-485 mode, Linux TIOCSRS485);
    /// or this program switches the transmitter around each transmission with `rts` (RTS on
    /// to transmit), `rts-inverted` (RTS off to transmit), `sysfs` ('1' written to
    /// --rs485-file to transmit, '0' to receive) or `sysfs-inverted` ('0' to transmit), as
    /// mbusd's -t, -r, -y and -Y.
    #[arg(
        long,
        global = true,
        help_heading = LINE_OPTIONS,
        value_name = "HOW",
        value_parser = rs485_mode_parser()
    )]
    pub rs485: Option<Rs485Mode>,
    /// With --rs485 sysfs or sysfs-inverted: the file written, e.g. a GPIO's
    /// /sys/class/gpio/gpio17/value (exported and set to output beforehand).
    #[arg(
        long,
        global = true,
        help_heading = LINE_OPTIONS,
        value_name = "PATH",
        required_if_eq_any = [("rs485", "sysfs"), ("rs485", "sysfs-inverted")]
    )]
    pub rs485_file: Option<PathBuf>,
    /// With --rs485: the transmitter on this long before the first bit (ms).
    #[arg(long, global = true, help_heading = LINE_OPTIONS, default_value_t = 0, value_name = "MS")]
    pub rs485_delay_before: u64,
    /// With --rs485: the transmitter kept on this long after the last bit (ms).
    #[arg(long, global = true, help_heading = LINE_OPTIONS, default_value_t = 0, value_name = "MS")]
    pub rs485_delay_after: u64,
    /// The port hears its own transmission (two-wire RS-485 adapter with its receiver always
    /// on, a bus tap): drop that echo instead of taking it for the partner's answer. Not
    /// together with a Modbus/USS config's own `local_echo`, which would then discard the
    /// answer.
    #[arg(long, global = true, help_heading = LINE_OPTIONS)]
    pub local_echo: bool,
    /// Do not put the port in line-error mode (Linux PARMRK): parity, framing and BREAK are
    /// then not reported, as on other platforms.
    #[arg(long, global = true, help_heading = LINE_OPTIONS)]
    pub no_line_errors: bool,
    /// Record every byte sent and received (with its time) into this trace file, JSON lines;
    /// `si monitor --trace FILE` decodes it. With `si sim`, records the simulated line.
    #[arg(long, global = true, help_heading = LINE_OPTIONS, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// The protocol the command speaks, written into the trace header (set by `main`).
    #[arg(skip)]
    pub protocol: Option<&'static str>,
    /// With -v: makes the protocol's monitor that logs each frame as text (set by `main`;
    /// `si_core::frame_log`).
    #[arg(skip)]
    pub frame_log: Option<LineDecoder>,
    /// `--port` was typed on the command line, not taken from `SI_PORT` (set by
    /// [`Connection::settle_line`]).
    #[arg(skip)]
    pub port_on_command_line: bool,
    /// The recorder, created on the first `open` so every port of the command shares one file.
    #[arg(skip)]
    recorder: Arc<OnceLock<Recorder>>,
}

impl Connection {
    /// Decide between `--port` and `--tcp` once the command line is parsed: both typed is a
    /// usage error (exit 2); a port from `SI_PORT` yields to a typed `--tcp`, so an
    /// environment set up for one adapter does not forbid reaching a device server. (Clap's own
    /// `conflicts_with` cannot tell the two sources apart: it counts the environment as given.)
    pub fn settle_line(&mut self, matches: &clap::ArgMatches) -> Result<(), CliError> {
        self.port_on_command_line =
            value_source(matches, "port") == Some(clap::parser::ValueSource::CommandLine);
        if self.tcp.is_some() {
            if self.port_on_command_line {
                return Err(CliError::usage(
                    "the argument '--port <PORT>' cannot be used with '--tcp <HOST:PORT>'",
                ));
            }
            self.port = None;
        }
        Ok(())
    }

    /// The validated character format, with one of the manuals' twelve baud rates.
    pub fn settings(&self) -> Result<SerialSettings, CliError> {
        self.settings_for(&si_core::BAUD_RATES)
    }

    /// The validated character format, with a baud rate from a protocol's own list (USS adds
    /// 187 500 bit/s); a value outside the lists is a usage error (exit 2).
    pub fn settings_for(&self, rates: &'static [u32]) -> Result<SerialSettings, CliError> {
        let parity: Parity = self.parity.parse().map_err(CliError::bad_argument)?;
        SerialSettings::with_rates(self.baud, self.data_bits, parity, self.stop_bits, rates)
            .map_err(CliError::bad_argument)
    }

    /// Open the port or connect to the device server, with [`settings`](Self::settings).
    pub async fn open(&self) -> Result<Box<dyn Transport>, CliError> {
        self.open_with(&self.settings()?).await
    }

    /// Open the port or connect to the device server with these (already validated) settings.
    pub async fn open_with(
        &self,
        settings: &SerialSettings,
    ) -> Result<Box<dyn Transport>, CliError> {
        let transport: Box<dyn Transport> = match (&self.port, &self.tcp) {
            (Some(path), _) => Box::new(port::open(path, settings, &self.port_options()?)?),
            (None, Some(addr)) => {
                if self.rs485.is_some() || self.latency_timer.is_some() {
                    return Err(CliError::new(
                        "--rs485 and --latency-timer need a serial port (--port); the device server switches its own line",
                    ));
                }
                let stream = port::device_server(addr).await?;
                Box::new(WithFacts {
                    inner: stream,
                    facts: PortFacts {
                        local_echo: self.local_echo,
                        rx_latency: self.rx_latency.map(Duration::from_millis),
                        ..PortFacts::default()
                    },
                })
            }
            (None, None) => {
                return Err(CliError::new(
                    "no line given: use --port PATH or --tcp HOST:PORT",
                ))
            }
        };
        self.tap(transport, settings)
    }

    /// `transport` with what the global flags ask to see of it: recorded into `--record`'s
    /// trace, and with -v each frame logged as text (`si_core::frame_log`).
    pub fn tap(
        &self,
        transport: Box<dyn Transport>,
        settings: &SerialSettings,
    ) -> Result<Box<dyn Transport>, CliError> {
        let transport: Box<dyn Transport> = match self.recorder(settings)? {
            Some(recorder) => Box::new(Tap::new(
                transport,
                Recording(recorder.for_station(STATION)),
            )),
            None => transport,
        };
        let decoder = self
            .frame_log
            .zip(self.protocol)
            .and_then(|(make, protocol)| make(protocol, *settings));
        Ok(match decoder {
            Some(decoder) => Box::new(Tap::new(transport, Frames::new(decoder, *settings))),
            None => transport,
        })
    }

    /// The error of a command whose line closed under it: one line naming the port that hung
    /// up or the TCP peer that closed the connection, exit 1 (a lost line is an
    /// error, never a success).
    pub fn closed(&self) -> CliError {
        CliError::new(match (&self.port, &self.tcp) {
            (Some(path), _) => format!("the line closed: {path} hung up"),
            (None, Some(addr)) => {
                format!("the line closed: TCP peer {addr} closed the connection")
            }
            (None, None) => "the line closed".to_owned(),
        })
    }

    /// The port options the global flags ask for; a usage error if a sysfs mode has no file
    /// (a profile or gateway line can ask for one without `--rs485-file`) or a file is given
    /// for another mode.
    pub fn port_options(&self) -> Result<PortOptions, CliError> {
        let (before, after) = (
            Duration::from_millis(self.rs485_delay_before),
            Duration::from_millis(self.rs485_delay_after),
        );
        if self.rs485_file.is_some() && !self.rs485.is_some_and(Rs485Mode::needs_file) {
            return Err(CliError::usage(
                "--rs485-file is for --rs485 sysfs or sysfs-inverted",
            ));
        }
        let rs485 = match self.rs485 {
            None => None,
            Some(mode) => Some(
                mode.control(self.rs485_file.clone(), before, after)
                    .map_err(|e| match e {
                        Rs485ModeError::MissingFile(mode) => CliError::usage(format!(
                            "--rs485 {mode} needs --rs485-file PATH (the file to write '1'/'0' to)"
                        )),
                        other => CliError::usage(other.to_string()),
                    })?,
            ),
        };
        Ok(PortOptions {
            latency_timer: self.latency_timer.map(Duration::from_millis),
            rx_latency: self.rx_latency.map(Duration::from_millis),
            rs485,
            local_echo: self.local_echo,
            no_line_errors: self.no_line_errors,
        })
    }

    /// The shared recorder if `--record` was given, created with a header on first use.
    pub fn recorder(&self, settings: &SerialSettings) -> Result<Option<Recorder>, CliError> {
        let Some(path) = &self.record else {
            return Ok(None);
        };
        if let Some(r) = self.recorder.get() {
            return Ok(Some(r.clone()));
        }
        let mut header = Header::new("port").settings(*settings).stations(&[STATION]);
        if let Some(p) = self.protocol {
            header = header.protocol(p);
        }
        let r = Recorder::create(path, &header)
            .map_err(|e| CliError::new(format!("cannot record to {}: {e}", path.display())))?;
        Ok(Some(self.recorder.get_or_init(|| r).clone()))
    }
}

/// Makes the passive monitor for a protocol (by its trace-header name) on a line with these
/// settings; `None` if the protocol has none.
pub type LineDecoder = fn(&str, SerialSettings) -> Option<Box<dyn Decoder + Send>>;

/// The help heading of the line options.
pub const LINE_OPTIONS: &str = "Line options";

/// The station name this program's side has in a recorded trace.
pub const STATION: &str = "si";

/// Writes what passes through a tapped transport into a trace: writes as `tx`, reads as
/// `rx_chunk` and `rx_error` (decoded from a port that marks line errors), signal changes as
/// `signals` (si_core::tracefile). Timestamps come from the recorder's clock when the read or
/// write completes.
struct Recording(Recorder);

impl Recording {
    /// Record one entry; a recording error is logged, never allowed to stop the line.
    fn note(&self, kind: TraceKind) {
        if let Err(e) = self.0.record(kind) {
            tracing::warn!("trace recording failed: {e}");
        }
    }
}

impl Watch for Recording {
    fn written(&mut self, bytes: &[u8]) {
        self.note(TraceKind::Tx {
            bytes: bytes.to_vec(),
        });
    }
    fn read(&mut self, piece: Marked<'_>) {
        self.note(match piece {
            Marked::Data(run) => TraceKind::RxChunk {
                bytes: run.to_vec(),
            },
            Marked::Error(error) => TraceKind::RxError { error },
        });
    }
    fn signals(&mut self, update: SignalUpdate) {
        self.note(TraceKind::Signals { update });
    }
}

/// `--rs485`'s parser: si-core's names, listed as clap's possible values with what this
/// program does for each (help and errors name them), parsed with [`Rs485Mode`]'s `FromStr`.
fn rs485_mode_parser() -> impl clap::builder::TypedValueParser<Value = Rs485Mode> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    let help = |mode| match mode {
        Rs485Mode::Kernel => {
            "The kernel's RS-485 mode (Linux TIOCSRS485, where the port's driver has it)"
        }
        Rs485Mode::Rts => {
            "This program raises RTS before each transmission and drops it after (mbusd -t)"
        }
        Rs485Mode::RtsInverted => {
            "This program drops RTS to transmit and raises it after (mbusd -r)"
        }
        Rs485Mode::Sysfs => {
            "This program writes '1' to --rs485-file to transmit and '0' after (mbusd -y)"
        }
        Rs485Mode::SysfsInverted => {
            "This program writes '0' to --rs485-file to transmit and '1' after (mbusd -Y)"
        }
    };
    PossibleValuesParser::new(Rs485Mode::ALL.map(|m| PossibleValue::new(m.name()).help(help(m))))
        .try_map(|name| name.parse::<Rs485Mode>())
}

/// Where option `id` got its value, looked for at every level of the subcommands (a global
/// option given after a subcommand is recorded in that subcommand's matches); `None` when it
/// was not given and has no default.
pub fn value_source(matches: &clap::ArgMatches, id: &str) -> Option<clap::parser::ValueSource> {
    use clap::parser::ValueSource::{CommandLine, EnvVariable};
    let mut level = Some(matches);
    let mut found = None;
    while let Some(m) = level {
        match m.value_source(id) {
            Some(s @ (CommandLine | EnvVariable)) => return Some(s),
            Some(s) => found = found.or(Some(s)),
            None => {}
        }
        level = m.subcommand().map(|(_, sub)| sub);
    }
    found
}
