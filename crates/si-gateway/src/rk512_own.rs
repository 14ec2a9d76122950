//! The passive RK 512 role behind the gateway: the gateway's station is a passive
//! partner ([`si_rk512::Station::serving`]): a CP 341 or PLC SENDs into its memory and FETCHes
//! from it, and Modbus TCP clients read and write that same memory through S_MODB's
//! conversion DB ([`super::rk512`] has the mapping), answered from memory without line traffic.
//!
//! Modbus requests reach the line's task through the line's queue, like an active line's, so
//! that one task owns the station: it answers them between the station's events, one at a
//! time (the station's memory is one CPU's, changed by one program at a time). The line's
//! `queue` bounds them (06H when full); `pause_ms` does not apply, there is no line traffic.
//!
//! # The memory survives a reopening
//!
//! The memory is the gateway's, not the port's: when the port closes (an adapter pulled) the
//! line is down — queued requests get 0AH ([`super::reopen`]) — and the station reopened on the
//! new port starts from the memory as last kept, not zeroed. It is kept (the whole passive
//! side, [`si_rk512::passive::Server`]) after every Modbus write and after every SEND the
//! partner completed, since the old station is gone with its port and cannot be read out once
//! it has closed. The limit of this: a SEND the station completed in the very moment its port
//! closed (between serving it and the line's task reading the event) is not kept. A partner's
//! job that was half received when the port closed is dropped.

use super::counters::{Outcome, Stats};
use super::line::{self, counted, lock, LineQueue, GATEWAY_PATH_UNAVAILABLE};
use super::reopen::{self, Closed, LineLog, Opened};
use super::rk512::answer_from;
use super::rk512_config::Rk512Line;
use super::rk512_spans::is_read;
use crate::Error;
use si_core::memory::{Memory, MemorySizes};
use si_modbus::mbap::TcpAdu;
use si_modbus::serve;
use si_modbus::simatic::{ConversionDb, SimaticStore};
use si_rk512::passive::Server;
use si_rk512::tokio::Handle;
use si_rk512::{Command, Event, Station};
use std::sync::{Arc, Mutex};

/// The passive side's memory (and DX blocks) as last kept, restored into each reopened
/// station (module docs). Kept by copying into the same buffers after each change: no
/// allocation per write once the first copy is made.
#[derive(Clone, Default)]
pub struct Kept(Arc<Mutex<Option<(Memory, Memory)>>>);

impl Kept {
    /// Keep `server`'s memory as it is now.
    fn keep(&self, server: &Server) {
        match &mut *lock(&self.0) {
            Some((memory, dx)) => {
                memory.clone_from(server.memory());
                dx.clone_from(server.dx());
            }
            empty => *empty = Some((server.memory().clone(), server.dx().clone())),
        }
    }

    /// Keep the memory of the running `station` (nothing if it has stopped).
    async fn keep_from(&self, station: &Handle) {
        let kept = self.clone();
        let _ = station.with_server(move |s| kept.keep(s)).await;
    }

    /// Give a newly built `station` the memory last kept; a job half received by the old
    /// station is dropped with the old station. Nothing before anything was kept.
    pub fn restore(&self, station: &mut Station) {
        if let Some((memory, dx)) = &*lock(&self.0) {
            station.server_mut().memory_mut().clone_from(memory);
            station.server_mut().dx_mut().clone_from(dx);
        }
    }
}

/// A passive line: the gateway's own memory, mapped by the line's conversion DB.
pub struct OwnMemory {
    conversion: ConversionDb,
    kept: Kept,
}

impl OwnMemory {
    /// The memory of `line`, nothing kept yet.
    pub fn new(line: &Rk512Line) -> Self {
        OwnMemory {
            conversion: line.conversion,
            kept: Kept::default(),
        }
    }

    /// What the line's opener restores into each station it builds.
    pub fn kept(&self) -> Kept {
        self.kept.clone()
    }

    /// Serve line `log.index` until the process ends: the queue's requests from the station's
    /// memory; while its port is closed they are answered with 0AH and the port is reopened
    /// with `open`, which restores [`kept`](Self::kept) ([`super::reopen`]).
    pub async fn run(
        self,
        log: LineLog,
        queue: Arc<LineQueue>,
        first: reopen::First<Handle>,
        open: impl AsyncFnMut() -> Result<Opened<Handle>, Error>,
    ) {
        // The closures own what their futures use (see `line::run`).
        let (index, stats) = (log.index, Arc::clone(&log.stats));
        let (q, s) = (Arc::clone(&queue), Arc::clone(&stats));
        let (conversion, kept) = (self.conversion, self.kept);
        reopen::supervise(
            log,
            first,
            open,
            move |station, closed| {
                let (q, s) = (Arc::clone(&q), Arc::clone(&s));
                serve(index, q, conversion, kept.clone(), station, closed, s)
            },
            move || line::refuse(index, Arc::clone(&queue), Arc::clone(&stats)),
        )
        .await;
    }
}

/// Answer the queue from `station`'s memory, and keep the memory after each SEND the partner
/// completed, until the port closes: why it closed.
async fn serve(
    index: usize,
    queue: Arc<LineQueue>,
    conversion: ConversionDb,
    kept: Kept,
    mut station: Handle,
    mut closed: Closed,
    stats: Arc<Mutex<Stats>>,
) -> String {
    loop {
        let (client, job, depth) = tokio::select! {
            biased;
            why = &mut closed => return why,
            event = station.next_event() => {
                match event {
                    Some(Event::Served {
                        command: Command::Send | Command::SendDx,
                        ..
                    }) => kept.keep_from(&station).await,
                    Some(other) => tracing::debug!("rk512 passive side: {other:?}"),
                    // The station stopped: its port is closing.
                    None => return closed.await,
                }
                continue;
            }
            popped = queue.pop() => popped,
        };
        line::taken(index, &stats, client, depth);
        let (answer, outcome) = from_memory(&station, conversion, &kept, &job.request).await;
        line::answered(index, &stats, client, job, Some(answer), outcome, 0);
    }
}

/// The answer to `adu` from `station`'s memory, at once, and how it is counted; the memory is
/// kept after a write.
async fn from_memory(
    station: &Handle,
    conversion: ConversionDb,
    kept: &Kept,
    adu: &TcpAdu,
) -> (TcpAdu, Outcome) {
    let (adu, kept) = (*adu, kept.clone());
    let result = station
        .with_server(move |server| {
            // The store owns its memory: lend it the station's for this one request.
            let memory = std::mem::replace(server.memory_mut(), Memory::new(&NO_MEMORY));
            let mut store = SimaticStore::new(memory, conversion);
            let answer = match adu.decode_request() {
                Ok((_, request)) => answer_from(&mut store, &adu, &request),
                Err(e) => Err(serve::refusal(e.kind).0.code()),
            };
            *server.memory_mut() = store.memory;
            if answer.is_ok() && !is_read(adu.function()) {
                kept.keep(server);
            }
            answer
        })
        .await
        .unwrap_or(Err(GATEWAY_PATH_UNAVAILABLE));
    counted(&adu, result)
}

/// Sizes of a memory that allocates nothing: the placeholder while a request has the real one.
const NO_MEMORY: MemorySizes = MemorySizes {
    inputs: 0,
    outputs: 0,
    flags: 0,
    timers: 0,
    counters: 0,
    dbs: std::collections::BTreeMap::new(),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rk512::tests::line;
    use si_modbus::frame::Request;
    use si_rk512::frame::{Address, Coordination};

    fn adu(request: &Request<'_>) -> TcpAdu {
        TcpAdu::request(1, 1, request).unwrap()
    }

    /// A passive station of low priority with a DB6 of 64 bytes on `port`, from `kept`.
    fn own_station(port: Box<dyn si_core::driver::Transport>, kept: Option<&Kept>) -> Handle {
        let mut memory = si_rk512::passive::ServerConfig::default();
        memory.memory.dbs.insert(6, 64);
        let settings = si_core::SerialSettings::default();
        let mut station = Station::serving(si_rk512::Config::default(), settings, &memory).unwrap();
        if let Some(kept) = kept {
            kept.restore(&mut station);
        }
        Handle::spawn_engine(station, port)
    }

    /// The CP's station, of high priority, on `end`.
    fn cp(end: tokio::io::DuplexStream) -> Handle {
        let mut high = si_rk512::Config::default();
        high.link.priority = si_3964r::Priority::High;
        Handle::spawn(high, end).unwrap()
    }

    /// `request` through the line's queue: the answer's PDU.
    async fn ask(queue: &LineQueue, request: &Request<'_>) -> Vec<u8> {
        let (reply, answer) = tokio::sync::oneshot::channel();
        let job = line::Job {
            request: adu(request),
            reply: Some(reply),
        };
        queue.push(1, job).expect("room in the queue");
        answer.await.expect("an answer").unit_pdu()[1..].to_vec()
    }

    /// In virtual time: the CP SENDs and a Modbus client writes; the port closes (0AH); once
    /// reopened, the memory holds both, for Modbus and for the CP.
    #[tokio::test(start_paused = true)]
    async fn the_memory_survives_a_reopening() {
        let own = OwnMemory::new(&line(vec![], None));
        let (kept, watch) = (own.kept(), own.kept());
        let (a, b) = tokio::io::duplex(4096);
        let (port, closed) = reopen::watch(Box::new(a));
        let first = Opened {
            link: own_station(port, None),
            closed,
        };
        let (ends, mut cp_ends) = tokio::sync::mpsc::unbounded_channel();
        let open = async move || {
            let (a, b) = tokio::io::duplex(4096);
            let (port, closed) = reopen::watch(Box::new(a));
            let _ = ends.send(b);
            let link = own_station(port, Some(&kept));
            Ok(Opened { link, closed })
        };
        let log = LineLog::test(1);
        let stats = Arc::clone(&log.stats);
        let queue = Arc::new(LineQueue::new(4));
        tokio::spawn(own.run(log, Arc::clone(&queue), Ok(first), open));

        let plc = cp(b);
        let at = Address::Db { db: 6, dw: 1 };
        plc.send(at, Coordination::NONE, vec![0xAB, 0xCD])
            .await
            .unwrap();
        let write = Request::WriteSingleRegister {
            address: 2,
            value: 0x4242,
        };
        assert_eq!(ask(&queue, &write).await, [0x06, 0, 2, 0x42, 0x42]);
        let kept_word = |k: &Kept| {
            let (memory, _dx) = lock(&k.0).clone().expect("kept after a write");
            memory.word(si_core::memory::Area::Db(6), 4)
        };
        assert_eq!(kept_word(&watch), Ok(0x4242));

        drop(plc);
        let read = Request::ReadHoldingRegisters {
            address: 1,
            quantity: 2,
        };
        // Down once the line task saw the port close; until then the old station answers.
        let mut answer = ask(&queue, &read).await;
        while answer != [0x83, 0x0A] {
            tokio::task::yield_now().await;
            answer = ask(&queue, &read).await;
        }

        let plc = cp(cp_ends.recv().await.expect("reopened"));
        let both = [0x03, 4, 0xAB, 0xCD, 0x42, 0x42];
        while answer != both {
            assert_eq!(answer, [0x83, 0x0A], "down, then the kept memory");
            tokio::task::yield_now().await;
            answer = ask(&queue, &read).await;
        }
        let fetched = plc.fetch(at, Coordination::NONE, 4).await.unwrap();
        assert_eq!(&fetched[..], [0xAB, 0xCD, 0x42, 0x42]);
        assert_eq!(lock(&stats).lines[0].reconnects, 1);
    }
}
