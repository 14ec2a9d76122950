//! Which output enables an RS-485 transmitter, and at which level: the four ways of mbusd
//! (`tty.c` `tty_set_tx`/`tty_set_rx`: `-t` RTS on, `-r` RTS off, `-y FILE` '1', `-Y FILE`
//! '0' while transmitting).
//!
//! The driver's direction control ([`RtsToggle`](crate::driver::RtsToggle)) stays one piece
//! and speaks one language: "RTS on" means *transmit*, "RTS off" *receive*. The port maps
//! that to the real output here, because only the port knows how its transceiver is wired;
//! the driver's timing (the `before` wait, RTS off `after` past tx-done) then holds for every
//! wiring without a second code path, and a `--record` trace shows the direction the same
//! way whatever the wiring (`signals` with `rts: true` = transmitting).
//!
//! Auto V.24 (Modbus `--auto-v24`, the ASCII driver's flow control) also sets RTS, but RS-485
//! has no V.24 signals: the two must not combine, so every RTS update that reaches a port
//! with a [`TxEnableOutput`] is taken for the direction. `si modbus` refuses `--auto-v24` with
//! `--rs485`; a program that runs a V.24 engine over a port opened with
//! [`Rs485::Driver`](super::Rs485::Driver) must refuse it too.

use crate::driver::Transport;
use crate::sansio::SignalUpdate;
use std::fs::File;
use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// The output that switches the transceiver to transmit.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum TxEnable {
    /// RTS on while transmitting (mbusd `-t`): the usual wiring of RTS to DE/RE̅.
    #[default]
    Rts,
    /// RTS off while transmitting (mbusd `-r`): an inverting driver stage between RTS and DE.
    /// The port is left receiving (RTS on) when it is dropped, but the kernel drops RTS when
    /// the tty is closed (termios `HUPCL`), which on this wiring enables the transmitter
    /// again: as with mbusd, keep the bus safe with a pull-up on the inverter's input or clear
    /// `HUPCL` (`stty -F PORT -hupcl`).
    RtsInverted,
    /// `1` written to this file to transmit and `0` to receive (mbusd `-y`), e.g. a GPIO's
    /// `/sys/class/gpio/gpio17/value`.
    File(PathBuf),
    /// `0` written to this file to transmit and `1` to receive (mbusd `-Y`).
    FileInverted(PathBuf),
}

impl TxEnable {
    /// The file written, for the file kinds.
    pub fn file(&self) -> Option<&Path> {
        match self {
            TxEnable::File(path) | TxEnable::FileInverted(path) => Some(path),
            TxEnable::Rts | TxEnable::RtsInverted => None,
        }
    }

    /// The output is active low: `0`/RTS off means transmit.
    fn inverted(&self) -> bool {
        matches!(self, TxEnable::RtsInverted | TxEnable::FileInverted(_))
    }
}

/// A [`TxEnable`] put to work: the file kept open (so a missing or read-only GPIO is
/// reported when the port is opened, not at the first transmission) and the driver's RTS
/// updates mapped to the real output.
#[derive(Debug)]
pub struct TxEnableOutput {
    how: TxEnable,
    file: Option<LevelFile>,
    /// The transmitter was last switched on (and not off since).
    transmitting: bool,
}

/// The open level file. A regular file (a sysfs attribute is one) is rewritten at offset 0,
/// so it always holds the current level, as mbusd's open-write-close leaves it; a FIFO or a
/// character device cannot seek and gets the levels as a stream, in order.
#[derive(Debug)]
struct LevelFile {
    file: File,
    seekable: bool,
}

impl TxEnableOutput {
    /// Open the output `how`. For the file kinds, the file must exist and be writable (it is
    /// not created: a GPIO's `value` is made by exporting the pin). Opening a FIFO waits until
    /// a reader has it open. Errors name the file.
    pub fn open(how: TxEnable) -> io::Result<Self> {
        let file = match how.file() {
            Some(path) => {
                let file = std::fs::OpenOptions::new()
                    .write(true)
                    .open(path)
                    .map_err(|e| named(path, "cannot open", e))?;
                let seekable = file
                    .metadata()
                    .map_err(|e| named(path, "cannot open", e))?
                    .is_file();
                Some(LevelFile { file, seekable })
            }
            None => None,
        };
        Ok(TxEnableOutput {
            how,
            file,
            transmitting: false,
        })
    }

    /// The output this drives.
    pub fn how(&self) -> &TxEnable {
        &self.how
    }

    /// Apply the driver's `update` to `port`: its RTS is the direction (on = transmit),
    /// mapped to the real output; DTR passes through unchanged.
    pub fn set_signals<T: Transport + ?Sized>(
        &mut self,
        port: &mut T,
        update: SignalUpdate,
    ) -> io::Result<()> {
        let Some(transmit) = update.rts else {
            return port.set_signals(update);
        };
        let level = transmit != self.how.inverted();
        // Until the switch succeeds, count the transmitter as on: `release` then tries again.
        self.transmitting = true;
        match &mut self.file {
            None => port.set_signals(SignalUpdate {
                rts: Some(level),
                ..update
            }),
            Some(file) => {
                file.write_level(level).map_err(|e| {
                    let path = self.how.file().unwrap_or(Path::new("?"));
                    named(path, "cannot write the RS-485 direction to", e)
                })?;
                match update.dtr {
                    Some(_) => port.set_signals(SignalUpdate {
                        rts: None,
                        ..update
                    }),
                    None => Ok(()),
                }
            }
        }?;
        self.transmitting = transmit;
        Ok(())
    }

    /// Switch to receive if the transmitter is (or may be) on: for a port going away.
    pub fn release<T: Transport + ?Sized>(&mut self, port: &mut T) -> io::Result<()> {
        match self.transmitting {
            true => self.receive(port),
            false => Ok(()),
        }
    }

    /// Switch to receive, the state between transmissions (used when the port is opened).
    pub fn receive<T: Transport + ?Sized>(&mut self, port: &mut T) -> io::Result<()> {
        self.set_signals(
            port,
            SignalUpdate {
                rts: Some(false),
                ..SignalUpdate::default()
            },
        )
    }
}

impl LevelFile {
    /// Write `1` (high) or `0` (low), one byte as mbusd does.
    fn write_level(&mut self, high: bool) -> io::Result<()> {
        if self.seekable {
            self.file.seek(SeekFrom::Start(0))?;
        }
        self.file.write_all(if high { b"1" } else { b"0" })?;
        self.file.flush()
    }
}

/// `what PATH: error`, keeping the error's kind.
fn named(path: &Path, what: &str, e: io::Error) -> io::Error {
    io::Error::new(e.kind(), format!("{what} {}: {e}", path.display()))
}
