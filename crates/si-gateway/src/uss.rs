//! USS drives behind the gateway: each drive is a Modbus unit id, served from the
//! USS master's cyclic polling ([Modbus/USS] §3.7, [USS spec] §5.1) rather than
//! forwarded, so a Modbus request never waits for the bus except to start a parameter job.
//!
//! The register map of one drive:
//!
//! | registers | table | meaning |
//! |---|---|---|
//! | 0 … n−1 | input (FC 04) | PZD of the latest answer: ZSW, HIW, further PZD in. 0BH if the drive never answered or its last poll failed |
//! | 0 … n−1 | holding (FC 03/06/16) | PZD sent with every poll: STW, HSW, further PZD out; a write takes effect from the next poll |
//! | 100 | holding | PNU (parameter number) |
//! | 101 | holding | sub-index IND, 0 … 255 |
//! | 102, 103 | holding | value, high and low word (a word write sends 103 alone) |
//! | 104 | holding | command: writing 1 reads the parameter, 2 writes a word, 3 a double word; 06H while a job runs; reads back the last command |
//! | 105 | holding, read-only | status: 0 idle (no job yet), 1 busy, 2 done (102/103 hold the drive's value), 3 error |
//! | 106 | holding, read-only | the failed job's STATUS code: the drive's or the line's (16#1503 for response ID 7, 16#1408 "node does not answer"), the master's refusal before sending (16#1E20 a PNU above 61 999, 16#1504 no PKW area or a double word in a 3-word area: `si_uss::master::RequestError::status`), or 16#1E0D when the line's port closed under the job |
//! | 107 | holding, read-only | the drive's error number for response ID 7 (0 otherwise) |
//!
//! n is the line's `pzd_words`. A request spanning the PZD and the window, or past either, is
//! answered with exception 02H. While the line's port is closed every request to its drives is
//! answered with 0AH ([`super::reopen`]), the window's too: the line is down as a whole. A
//! reopened line has a new master, whose PZD out start as at start-up: the client writes
//! STW/HSW again, as it would after a drive's own telegram-loss fault, rather than the
//! gateway sending a run command it can no longer vouch for.

use super::counters::Outcome;
use super::line::{
    counted, lock, GATEWAY_PATH_UNAVAILABLE, GATEWAY_TARGET_FAILED, ILLEGAL_DATA_ADDRESS,
    ILLEGAL_DATA_VALUE, ILLEGAL_FUNCTION, SLAVE_DEVICE_BUSY,
};
use super::reopen::{self, Closed, LineLog, Opened};
use super::uss_config::UssLine;
use si_modbus::frame::Request;
use si_modbus::mbap::TcpAdu;
use si_modbus::serve;
use si_uss::master::{ParamRequest, Width};
use si_uss::tokio::{Error, Handle};
use std::future::Future;
use std::sync::{Arc, Mutex};

/// First register of the parameter window.
pub const WINDOW: u16 = 100;
/// Window registers, 100 … 107.
const WINDOW_LEN: usize = 8;
/// The command register's offset in the window.
const COMMAND: usize = 4;
/// The first read-only register's offset (status, STATUS, error number).
const READ_ONLY: usize = 5;

/// Window status: the job runs.
pub const BUSY: u16 = 1;
/// Window status: the job ended; the value registers hold the drive's answer.
pub const DONE: u16 = 2;
/// Window status: the job failed; register 106 holds its STATUS.
pub const FAILED: u16 = 3;

/// One drive: its unit id, bus address, PZD count and parameter window.
struct Drive {
    unit: u8,
    address: u8,
    pzd_words: usize,
    window: Arc<Mutex<[u16; WINDOW_LEN]>>,
}

/// The master of a USS line while its port is open; `None` while the line is down.
type Link = Mutex<Option<Arc<Handle>>>;

/// The drives of one USS line and the master polling them.
pub struct UssDrives {
    link: Arc<Link>,
    drives: Vec<Drive>,
}

impl UssDrives {
    /// The drives of `line`, down until [`supervise`](Self::supervise) gives them a master.
    pub fn new(line: &UssLine) -> Self {
        UssDrives {
            link: Arc::default(),
            drives: line
                .drives
                .iter()
                .map(|&(unit, address)| Drive {
                    unit,
                    address,
                    pzd_words: usize::from(line.pzd_words),
                    window: Arc::default(),
                })
                .collect(),
        }
    }

    /// Serve the drives through `first`, and through each master reopened after the port
    /// closed, until the process ends ([`super::reopen`]).
    pub fn supervise(
        &self,
        log: LineLog,
        first: reopen::First<Handle>,
        open: impl AsyncFnMut() -> Result<Opened<Handle>, crate::Error> + 'static,
    ) -> impl Future<Output = ()> + 'static {
        let link = Arc::clone(&self.link);
        // The closure owns what its futures use (see `line::run`).
        reopen::supervise(
            log,
            first,
            open,
            move |master, closed| serve_until_closed(Arc::clone(&link), master, closed),
            std::future::pending,
        )
    }

    /// The line's master, or 0AH while the line is down.
    fn master(&self) -> Result<Arc<Handle>, u8> {
        lock(&self.link).clone().ok_or(GATEWAY_PATH_UNAVAILABLE)
    }

    /// The answer to `request` and how it is counted.
    pub async fn answer(&self, request: &TcpAdu) -> (TcpAdu, Outcome) {
        let result = match self.drives.iter().find(|d| d.unit == request.unit()) {
            Some(drive) => match (request.decode_request(), self.master()) {
                (_, Err(down)) => Err(down),
                (Ok((_, r)), Ok(master)) => Self::serve(&master, drive, request, r).await,
                (Err(e), _) => Err(serve::refusal(e.kind).0.code()),
            },
            None => Err(GATEWAY_PATH_UNAVAILABLE),
        };
        let answer = result.map(|pdu| {
            let mut unit_pdu = Vec::with_capacity(1 + pdu.len());
            unit_pdu.push(request.unit());
            unit_pdu.extend_from_slice(&pdu);
            TcpAdu::from_unit_pdu(request.transaction(), &unit_pdu).unwrap_or_default()
        });
        counted(request, answer)
    }

    /// The response PDU, or the exception code.
    async fn serve(
        master: &Arc<Handle>,
        drive: &Drive,
        request: &TcpAdu,
        r: Request<'_>,
    ) -> Result<Vec<u8>, u8> {
        match r {
            Request::ReadInputRegisters { address, quantity } => {
                let a = drive.address;
                let words = master
                    .call(move |m, _| {
                        m.slave(a)
                            .filter(|s| s.answered > 0 && s.last_status == si_core::Status::OK)
                            .map(|s| s.status.words().to_vec())
                    })
                    .await
                    .map_err(|_| GATEWAY_PATH_UNAVAILABLE)?
                    .ok_or(GATEWAY_TARGET_FAILED)?;
                registers(0x04, &words, address, quantity)
            }
            Request::ReadHoldingRegisters { address, quantity } if address >= WINDOW => {
                let window = *lock(&drive.window);
                registers(0x03, &window, address - WINDOW, quantity)
            }
            Request::ReadHoldingRegisters { address, quantity } => {
                let words = Self::control(master, drive).await?;
                registers(0x03, &words, address, quantity)
            }
            Request::WriteSingleRegister { address, value } => {
                Self::write(master, drive, address, &[value]).await?;
                Ok(request.unit_pdu()[1..].to_vec())
            }
            Request::WriteMultipleRegisters { address, values } => {
                let values: Vec<u16> = values.iter().collect();
                Self::write(master, drive, address, &values).await?;
                let mut pdu = vec![0x10];
                pdu.extend(address.to_be_bytes());
                pdu.extend((values.len() as u16).to_be_bytes());
                Ok(pdu)
            }
            _ => Err(ILLEGAL_FUNCTION),
        }
    }

    /// The PZD words sent to `drive` with every poll.
    async fn control(master: &Handle, drive: &Drive) -> Result<Vec<u16>, u8> {
        let a = drive.address;
        master
            .call(move |m, _| m.slave(a).map(|s| s.control.words().to_vec()))
            .await
            .map_err(|_| GATEWAY_PATH_UNAVAILABLE)?
            .ok_or(GATEWAY_PATH_UNAVAILABLE)
    }

    /// Write `values` from register `address`: into the PZD out, or into the window.
    async fn write(
        master: &Arc<Handle>,
        drive: &Drive,
        address: u16,
        values: &[u16],
    ) -> Result<(), u8> {
        let start = usize::from(address);
        let end = start + values.len();
        if address < WINDOW {
            if end > drive.pzd_words {
                return Err(ILLEGAL_DATA_ADDRESS);
            }
            let (a, words) = (drive.address, values.to_vec());
            return master
                .call(move |m, _| {
                    let mut control = m.slave(a)?.control.words().to_vec();
                    control.get_mut(start..end)?.copy_from_slice(&words);
                    m.set_control(a, &control).ok()
                })
                .await
                .map_err(|_| GATEWAY_PATH_UNAVAILABLE)?
                .ok_or(ILLEGAL_DATA_ADDRESS);
        }
        let (start, end) = (start - usize::from(WINDOW), end - usize::from(WINDOW));
        if end > READ_ONLY {
            return Err(ILLEGAL_DATA_ADDRESS);
        }
        let mut window = lock(&drive.window);
        let starts_job = (start..end).contains(&COMMAND);
        if starts_job && window[READ_ONLY] == BUSY {
            return Err(SLAVE_DEVICE_BUSY);
        }
        let mut next = *window;
        next[start..end].copy_from_slice(values);
        if !starts_job {
            *window = next;
            return Ok(());
        }
        let request = job(&next).ok_or(ILLEGAL_DATA_VALUE)?;
        next[READ_ONLY..].copy_from_slice(&[BUSY, 0, 0]);
        *window = next;
        drop(window);
        let (master, slot, a) = (Arc::clone(master), Arc::clone(&drive.window), drive.address);
        tokio::spawn(async move {
            let result = master.parameter(a, request).await;
            let mut w = lock(&slot);
            match result {
                Ok(pkw) => {
                    let v = pkw.value();
                    w[2..4].copy_from_slice(&[(v >> 16) as u16, v as u16]);
                    w[READ_ONLY..].copy_from_slice(&[DONE, 0, 0]);
                }
                Err(e) => {
                    let number = match e {
                        Error::Failed { error_number, .. } => error_number.unwrap_or(0),
                        _ => 0,
                    };
                    // A refusal has its STATUS too (`RequestError::status`); a job whose port
                    // closed under it ends as the module ends jobs at a reset (1E0DH, [Modbus/USS]
                    // §3.6).
                    let status = e
                        .status()
                        .unwrap_or(si_core::status::common::ABORTED_BY_RESET)
                        .code();
                    w[READ_ONLY..].copy_from_slice(&[FAILED, status, number]);
                }
            }
        });
        Ok(())
    }
}

/// Hand `master` to the drives until its port closes: why it closed. The master is dropped
/// (once the jobs still holding it end), and the drives are down until the next.
async fn serve_until_closed(link: Arc<Link>, master: Handle, closed: Closed) -> String {
    *lock(&link) = Some(Arc::new(master));
    let why = closed.await;
    *lock(&link) = None;
    why
}

/// The parameter job the window's command asks for; `None` for an unknown command or a
/// sub-index past 255.
fn job(window: &[u16; WINDOW_LEN]) -> Option<ParamRequest> {
    let [pnu, index, high, low, command, ..] = *window;
    let index = u8::try_from(index).ok()?;
    match command {
        1 => Some(ParamRequest::read(pnu, index)),
        2 => Some(ParamRequest::write(pnu, index, u32::from(low), Width::Word)),
        3 => Some(ParamRequest::write(
            pnu,
            index,
            u32::from(high) << 16 | u32::from(low),
            Width::DoubleWord,
        )),
        _ => None,
    }
}

/// The read response `function` over `words[address..address + quantity]`, or 02H.
fn registers(function: u8, words: &[u16], address: u16, quantity: u16) -> Result<Vec<u8>, u8> {
    let start = usize::from(address);
    let values = words
        .get(start..start + usize::from(quantity))
        .ok_or(ILLEGAL_DATA_ADDRESS)?;
    let mut pdu = Vec::with_capacity(2 + 2 * values.len());
    pdu.extend([function, (2 * values.len()) as u8]);
    pdu.extend(values.iter().flat_map(|v| v.to_be_bytes()));
    Ok(pdu)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_window_command_picks_the_parameter_task() {
        let read = job(&[700, 0, 0, 0, 1, 0, 0, 0]).unwrap();
        assert_eq!(read, ParamRequest::read(700, 0));
        let word = job(&[1082, 2, 9, 120, 2, 0, 0, 0]).unwrap();
        assert_eq!(word, ParamRequest::write(1082, 2, 120, Width::Word));
        let dword = job(&[1082, 0, 1, 2, 3, 0, 0, 0]).unwrap();
        assert_eq!(
            dword,
            ParamRequest::write(1082, 0, 0x0001_0002, Width::DoubleWord)
        );
        assert_eq!(job(&[700, 0, 0, 0, 4, 0, 0, 0]), None);
        assert_eq!(job(&[700, 256, 0, 0, 1, 0, 0, 0]), None);
    }

    #[test]
    fn reads_outside_the_image_are_refused() {
        assert_eq!(
            registers(0x04, &[1, 2], 0, 2),
            Ok(vec![0x04, 4, 0, 1, 0, 2])
        );
        assert_eq!(registers(0x04, &[1, 2], 1, 2), Err(ILLEGAL_DATA_ADDRESS));
        assert_eq!(registers(0x03, &[1, 2], 9, 1), Err(ILLEGAL_DATA_ADDRESS));
    }
}
