//! A plain 3964(R) partner behind the gateway ("RK 512 / 3964(R) partners"): the
//! procedure carries blocks without addresses ([ET200S SI] §2.7), so the unit id is
//! the partner and its blocks are registers.
//!
//! | registers | table | meaning |
//! |---|---|---|
//! | 0 | input (FC 04) | blocks received so far (wrapping at 65 536) |
//! | 1 | input | bytes of the latest block (0 before the first) |
//! | 2 … 2 + ⌈L/2⌉ − 1 | input | the latest block, two bytes per register, high byte first, the odd last byte padded with 00H; L = the link's longest block (200 bytes by default) |
//! | 0 … | holding, FC 16 only, from 0 | register 0 the block's length n (1 … L, at most two per further register), registers 1 … its bytes, high byte first: the block is sent, and the echo comes once the partner acknowledged it (DLE) |
//!
//! Every block received is taken at once (S_RCV's job), so the partner never waits for the
//! receive buffer. A send that fails is answered as an RK 512 job's STATUS is
//! ([`super::rk512::status_exception`]: class 07H → 0BH, busy → 06H); a length out of range is
//! 03H, a write elsewhere or a read past the block 02H, any other function 01H.
//!
//! While the line's port is closed every request is answered with 0AH, reads of the latest
//! block too (the line is down as a whole, as a USS line is), and the port is reopened
//! ([`super::reopen`]). The latest block and the count survive the reopening: they are the
//! last the partner sent, and the count goes on from there.

use super::counters::Outcome;
use super::line::{
    counted, lock, GATEWAY_PATH_UNAVAILABLE, ILLEGAL_DATA_ADDRESS, ILLEGAL_DATA_VALUE,
    ILLEGAL_FUNCTION,
};
use super::reopen::{self, Closed, LineLog, Opened};
use super::rk512::status_exception;
use si_3964r::tokio::{Error, Handle, Sender};
use si_modbus::frame::{Registers, Request, Response};
use si_modbus::mbap::TcpAdu;
use si_modbus::serve;
use std::future::Future;
use std::sync::{Arc, Mutex};

/// The input registers before the block's data: count and length.
const HEADER: usize = 2;

/// The partner's latest block, as the input registers show it.
#[derive(Debug, Default)]
struct Latest {
    count: u16,
    block: Vec<u8>,
}

/// The sending half of a 3964(R) line while its port is open; `None` while it is down.
type Link = Mutex<Option<Sender>>;

/// A 3964(R) line: its sending half and the latest block the receiving task took.
pub struct BlockLine {
    sender: Arc<Link>,
    latest: Arc<Mutex<Latest>>,
    max_block_len: usize,
}

impl BlockLine {
    /// A line with blocks up to `max_block_len` bytes, down until
    /// [`supervise`](Self::supervise) gives it a link.
    pub fn new(max_block_len: usize) -> Self {
        BlockLine {
            sender: Arc::default(),
            latest: Arc::default(),
            max_block_len,
        }
    }

    /// Serve the line through `first`, and through each link reopened after the port closed,
    /// until the process ends ([`super::reopen`]): every block received is taken at once.
    pub fn supervise(
        &self,
        log: LineLog,
        first: reopen::First<Handle>,
        open: impl AsyncFnMut() -> Result<Opened<Handle>, crate::Error> + 'static,
    ) -> impl Future<Output = ()> + 'static {
        // The closure owns what its futures use (see `line::run`).
        let (sender, latest) = (Arc::clone(&self.sender), Arc::clone(&self.latest));
        reopen::supervise(
            log,
            first,
            open,
            move |link, closed| {
                serve_until_closed(Arc::clone(&sender), Arc::clone(&latest), link, closed)
            },
            std::future::pending,
        )
    }

    /// The answer to `adu` and how it is counted.
    pub async fn answer(&self, adu: &TcpAdu) -> (TcpAdu, Outcome) {
        let result = match adu.decode_request() {
            Ok((_, request)) => self.serve(adu, request).await,
            Err(e) => Err(serve::refusal(e.kind).0.code()),
        };
        counted(adu, result)
    }

    async fn serve(&self, adu: &TcpAdu, request: Request<'_>) -> Result<TcpAdu, u8> {
        let sender = lock(&self.sender).clone().ok_or(GATEWAY_PATH_UNAVAILABLE)?;
        let response = |r: &Response<'_>| {
            TcpAdu::response(adu.transaction(), adu.unit(), r).map_err(|_| ILLEGAL_DATA_VALUE)
        };
        match request {
            Request::ReadInputRegisters { address, quantity } => {
                let words = self.input_registers();
                let start = usize::from(address);
                let values = words
                    .get(start..start + usize::from(quantity))
                    .ok_or(ILLEGAL_DATA_ADDRESS)?;
                response(&Response::ReadInputRegisters(Registers::Words(values)))
            }
            Request::WriteMultipleRegisters { address: 0, values } => {
                let words: Vec<u16> = values.iter().collect();
                let block = block(&words, self.max_block_len)?;
                if let Err(e) = sender.send(block).await {
                    return Err(match e.status() {
                        Some(s) if !matches!(e, Error::Stopped(_)) => {
                            let s = si_3964r::status::lookup(s.code());
                            tracing::debug!("3964(R) send: {s}");
                            status_exception(s.code())
                        }
                        _ => GATEWAY_PATH_UNAVAILABLE,
                    });
                }
                let quantity = words.len() as u16;
                response(&Response::WriteMultipleRegisters {
                    address: 0,
                    quantity,
                })
            }
            Request::WriteMultipleRegisters { .. } => Err(ILLEGAL_DATA_ADDRESS),
            _ => Err(ILLEGAL_FUNCTION),
        }
    }

    /// Count, length and the latest block's words, padded to the longest block.
    fn input_registers(&self) -> Vec<u16> {
        let l = lock(&self.latest);
        let mut words = vec![0u16; HEADER + self.max_block_len.div_ceil(2)];
        words[0] = l.count;
        words[1] = l.block.len() as u16;
        for (w, pair) in words[HEADER..].iter_mut().zip(l.block.chunks(2)) {
            *w = u16::from_be_bytes([pair[0], pair.get(1).copied().unwrap_or(0)]);
        }
        words
    }
}

/// Lend `link`'s sending half to the requests and take every block it receives into
/// `latest`, until its port closes: why it closed. The line is down again after.
async fn serve_until_closed(
    slot: Arc<Link>,
    latest: Arc<Mutex<Latest>>,
    mut link: Handle,
    mut closed: Closed,
) -> String {
    *lock(&slot) = Some(link.sender());
    let why = loop {
        tokio::select! {
            biased;
            why = &mut closed => break why,
            received = link.recv() => match received {
                Ok(block) => {
                    let mut l = lock(&latest);
                    l.count = l.count.wrapping_add(1);
                    l.block = block.to_vec();
                }
                Err(Error::Failed { status }) => {
                    let s = si_3964r::status::lookup(status.code());
                    tracing::debug!("3964(R) reception: {s}");
                }
                // The link stopped: its port is closing.
                Err(_) => break (&mut closed).await,
            },
        }
    };
    *lock(&slot) = None;
    why
}

/// The block an FC 16 from register 0 asks to send: length word, then the bytes.
fn block(words: &[u16], max_block_len: usize) -> Result<Vec<u8>, u8> {
    let (&len, data) = words.split_first().ok_or(ILLEGAL_DATA_VALUE)?;
    let len = usize::from(len);
    if len == 0 || len > max_block_len || len > 2 * data.len() {
        return Err(ILLEGAL_DATA_VALUE);
    }
    Ok(data
        .iter()
        .flat_map(|w| w.to_be_bytes())
        .take(len)
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_length_word_cuts_the_block() {
        assert_eq!(block(&[3, 0x4142, 0x4300], 200), Ok(b"ABC".to_vec()));
        assert_eq!(block(&[4, 0x4142, 0x4344], 200), Ok(b"ABCD".to_vec()));
        assert_eq!(block(&[5, 0x4142, 0x4344], 200), Err(ILLEGAL_DATA_VALUE));
        assert_eq!(block(&[0, 0x4142], 200), Err(ILLEGAL_DATA_VALUE));
        assert_eq!(block(&[2, 0x4142], 1), Err(ILLEGAL_DATA_VALUE));
    }

    /// Yield until the line is up (`true`) or down.
    async fn until_up(line: &BlockLine, up: bool) {
        while lock(&line.sender).is_some() != up {
            tokio::task::yield_now().await;
        }
    }

    /// The link's high-priority configuration (the partner keeps the default, low).
    fn high() -> si_3964r::Config {
        si_3964r::Config {
            priority: si_3964r::Priority::High,
            ..si_3964r::Config::default()
        }
    }

    async fn ask(line: &BlockLine, unit_pdu: &[u8]) -> Vec<u8> {
        let adu = TcpAdu::from_unit_pdu(1, unit_pdu).unwrap();
        line.answer(&adu).await.0.unit_pdu()[1..].to_vec()
    }

    #[tokio::test]
    async fn blocks_are_input_registers_and_a_register_write_sends_one() {
        let (a, b) = tokio::io::duplex(4096);
        let high = high();
        let line = BlockLine::new(200);
        let (port, closed) = reopen::watch(Box::new(a));
        let first = Opened {
            link: Handle::spawn(high, port).unwrap(),
            closed,
        };
        let never = async || Err(crate::Error::new("an in-memory pipe"));
        tokio::spawn(line.supervise(LineLog::test(1), Ok(first), never));
        until_up(&line, true).await;
        let mut partner = Handle::spawn(si_3964r::Config::default(), b).unwrap();
        // Nothing yet: count and length 0.
        assert_eq!(
            ask(&line, &[1, 0x04, 0, 0, 0, 2]).await,
            [0x04, 4, 0, 0, 0, 0]
        );
        partner.send(vec![1, 2, 3]).await.unwrap();
        let mut answer = Vec::new();
        for _ in 0..1000 {
            answer = ask(&line, &[1, 0x04, 0, 0, 0, 4]).await;
            if answer[2] == 0 && answer[3] == 1 {
                break;
            }
            tokio::task::yield_now().await;
        }
        assert_eq!(answer, [0x04, 8, 0, 1, 0, 3, 1, 2, 3, 0]);
        // Past the longest block (2 + 100 registers): 02H; FC 03: 01H; a bad length: 03H.
        assert_eq!(ask(&line, &[1, 0x04, 0, 101, 0, 2]).await, [0x84, 0x02]);
        assert_eq!(ask(&line, &[1, 0x03, 0, 0, 0, 1]).await, [0x83, 0x01]);
        let bad = [1, 0x10, 0, 0, 0, 2, 4, 0, 9, 0x41, 0x42];
        assert_eq!(ask(&line, &bad).await, [0x90, 0x03]);
        let elsewhere = [1, 0x10, 0, 1, 0, 1, 2, 0, 1];
        assert_eq!(ask(&line, &elsewhere).await, [0x90, 0x02]);
        // A block sent: the echo once acknowledged, and the partner has it.
        let write = [1, 0x10, 0, 0, 0, 3, 6, 0, 3, 0x41, 0x42, 0x43, 0];
        assert_eq!(ask(&line, &write).await, [0x10, 0, 0, 0, 3]);
        assert_eq!(&partner.recv().await.unwrap()[..], b"ABC");
        // The partner gone: 0AH.
        drop(partner);
        assert_eq!(ask(&line, &write).await, [0x90, 0x0A]);
    }

    /// In virtual time: the port closes, every request gets 0AH, the line is reopened after
    /// the first second of backoff, and the latest block and its count are still there.
    #[tokio::test(start_paused = true)]
    async fn a_reopened_line_keeps_the_latest_block() {
        let (a, b) = tokio::io::duplex(4096);
        let (port, closed) = reopen::watch(Box::new(a));
        let first = Opened {
            link: Handle::spawn(high(), port).unwrap(),
            closed,
        };
        let (ends, mut partner_ends) = tokio::sync::mpsc::unbounded_channel();
        let open = async move || {
            let (a, b) = tokio::io::duplex(4096);
            let (port, closed) = reopen::watch(Box::new(a));
            let _ = ends.send(b);
            let link = Handle::spawn(high(), port).map_err(|e| crate::Error::new(e.to_string()))?;
            Ok(Opened { link, closed })
        };
        let line = BlockLine::new(200);
        let log = LineLog::test(1);
        let stats = Arc::clone(&log.stats);
        tokio::spawn(line.supervise(log, Ok(first), open));
        let partner = Handle::spawn(si_3964r::Config::default(), b).unwrap();
        until_up(&line, true).await;
        partner.send(vec![7, 8]).await.unwrap();
        let latest = [0x04, 6, 0, 1, 0, 2, 7, 8];
        let read = [1, 0x04, 0, 0, 0, 3];
        while ask(&line, &read).await != latest {
            tokio::task::yield_now().await;
        }

        drop(partner);
        until_up(&line, false).await;
        assert_eq!(ask(&line, &read).await, [0x84, 0x0A]);
        let write = [1, 0x10, 0, 0, 0, 2, 4, 0, 1, 0x41, 0];
        assert_eq!(ask(&line, &write).await, [0x90, 0x0A]);

        let b = partner_ends.recv().await.expect("reopened");
        let mut partner = Handle::spawn(si_3964r::Config::default(), b).unwrap();
        until_up(&line, true).await;
        assert_eq!(ask(&line, &read).await, latest, "kept across the reopening");
        assert_eq!(ask(&line, &write).await, [0x10, 0, 0, 0, 2]);
        assert_eq!(&partner.recv().await.unwrap()[..], b"A");
        assert_eq!(lock(&stats).lines[0].reconnects, 1);
    }
}
