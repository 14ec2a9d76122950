//! RK 512 partners behind the gateway: a Modbus unit id is an S7 CPU reached over
//! RK 512, whose memory a Modbus client sees through S_MODB's conversion DB exactly as it
//! would see that CPU's through S_MODB (registers → DB words, bits → M/Q/I/T/C; the mapping
//! and its readings in [`si_modbus::simatic`], what RK 512 can address in
//! [`super::rk512_spans`], the keys in [`super::rk512_config`]).
//!
//! # Active role: the partner's memory
//!
//! One job at a time, from the line's fair queue ([`LineQueue`]), as the RK 512 requester has
//! one job outstanding ([CP 341] §2.2.3, Fig. 2-17):
//!
//! - **Read (FC01–04):** the request is first checked against a local mirror of the partner's
//!   memory ([`SimaticStore`]), so a request S_MODB would refuse costs no job; then each span
//!   it touches is FETCHed into the mirror (on demand), and the answer is served from the
//!   mirror by si-modbus's serve code, the one the RTU slave uses. With `refresh_ms` > 0 the
//!   `refresh` areas are FETCHed every `refresh_ms` instead and reads are served from that
//!   image at once: 0BH while an area was never fetched or its last refresh failed, 02H for
//!   an address outside every refresh area.
//! - **Write (FC06/16):** the mirror's store checks the conversion DB's write limits (02H, as
//!   S_MODB answers), then the touched bytes are SENT; the normal echo once the partner's
//!   reaction accepted them. FC05/15: 01H (SEND writes only data blocks, Table 2-1).
//!
//! RK 512 STATUS → exception (our choice; the STATUS text is logged at debug level):
//!
//! | STATUS | meaning | exception |
//! |---|---|---|
//! | 09xxH | the partner refused the job (no such DB 0903, area 0902, length 090C …) | 04H, what S_MODB answers for a missing or short DB (Table 3-12) |
//! | 0Axx, 051A, 07xx, 08xx | no or a faulty reaction, or the 3964(R) link failed | 0BH, the target did not respond |
//! | 0502 | the station is busy | 06H |
//! | other (1E41, 0515, 0516) | the station refused the job before sending | 04H |
//! | the port closed | | 0AH |
//!
//! While the port is closed, the queued jobs are answered with 0AH and the port is reopened
//! ([`super::reopen`]), as for a Modbus RTU line. The mirror keeps what it last knew of the
//! partner across the reopening, but the refresh image is stale (0BH) until the first refresh
//! through the new station, which runs at once: the partner may have changed meanwhile.
//!
//! The passive role (the gateway's own memory) is in [`super::rk512_own`].

use super::counters::{Outcome, Stats};
use super::line::{
    self, counted, LineQueue, GATEWAY_PATH_UNAVAILABLE, GATEWAY_TARGET_FAILED,
    ILLEGAL_DATA_ADDRESS, SLAVE_DEVICE_BUSY, SLAVE_DEVICE_FAILURE,
};
use super::reopen::{self, Closed, LineLog, Opened};
use super::rk512_config::Rk512Line;
use super::rk512_spans::{self, add_dbs, is_read, Span};
use si_core::memory::Memory;
use si_modbus::frame::Request;
use si_modbus::mbap::TcpAdu;
use si_modbus::serve::{self, ResponseData};
use si_modbus::simatic::SimaticStore;
use si_rk512::config::DwUnit;
use si_rk512::frame::Coordination;
use si_rk512::status;
use si_rk512::tokio::{Error, Handle};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::time::Interval;

/// An active line's mirror of the partner's memory, and the station reaching the partner.
pub struct Partner {
    /// The station while the line's port is open; `None` while the line is down (0AH).
    station: Option<Handle>,
    mirror: SimaticStore,
    dw_unit: DwUnit,
    coordination: Coordination,
    /// The refresh image's areas, each with whether its last FETCH succeeded.
    image: Vec<(Span, bool)>,
    every: Option<Duration>,
}

impl Partner {
    /// The partner of `line`, reached once a station is attached (when its line opens).
    pub fn new(line: &Rk512Line) -> Self {
        let sizes = rk512_spans::mirror_sizes(&line.conversion);
        let mut mirror = SimaticStore::new(Memory::new(&sizes), line.conversion);
        add_dbs(&mut mirror.memory, &line.refresh);
        Partner {
            station: None,
            mirror,
            dw_unit: line.config.dw_unit,
            coordination: line.coordination,
            image: line.refresh.iter().map(|&s| (s, false)).collect(),
            every: line.refresh_every,
        }
    }

    /// Reach the partner through `station` (newly opened, running). The mirror keeps what it
    /// knew; the refresh image is stale until the next refresh (module docs).
    fn attach(&mut self, station: Handle) {
        self.station = Some(station);
        for (_, fresh) in &mut self.image {
            *fresh = false;
        }
    }

    /// The answer to `adu` and how it is counted.
    pub async fn answer(&mut self, adu: &TcpAdu) -> (TcpAdu, Outcome) {
        counted(adu, self.serve(adu).await)
    }

    async fn serve(&mut self, adu: &TcpAdu) -> Result<TcpAdu, u8> {
        let (_, request) = adu
            .decode_request()
            .map_err(|e| serve::refusal(e.kind).0.code())?;
        let spans = rk512_spans::spans(&self.mirror.conversion, self.dw_unit, &request)?;
        add_dbs(&mut self.mirror.memory, &spans);
        if is_read(request.function()) {
            // The conversion's own checks first: a request S_MODB refuses costs no job.
            answer_from(&mut self.mirror, adu, &request)?;
            if self.every.is_some() {
                self.check_image(&spans)?;
            } else {
                for s in &spans {
                    let data = self.fetch(s).await?;
                    s.store(&mut self.mirror.memory, &data)
                        .map_err(|_| SLAVE_DEVICE_FAILURE)?;
                }
            }
            return answer_from(&mut self.mirror, adu, &request);
        }
        let memory_failed = |_| SLAVE_DEVICE_FAILURE;
        let before = spans
            .iter()
            .map(|s| s.load(&self.mirror.memory))
            .collect::<Result<Vec<_>, _>>()
            .map_err(memory_failed)?;
        // The store checks the write limits and writes the mirror; then the partner's turn.
        let answer = answer_from(&mut self.mirror, adu, &request)?;
        for s in &spans {
            let data = s.load(&self.mirror.memory).map_err(memory_failed)?;
            let sent = self
                .station()?
                .send(s.address, self.coordination, data)
                .await
                .map_err(|e| failed("SEND", s, &e));
            if let Err(code) = sent {
                // The mirror keeps the partner's data as last known, not what failed to go.
                for (s, old) in spans.iter().zip(&before) {
                    let _ = s.store(&mut self.mirror.memory, old);
                }
                return Err(code);
            }
        }
        Ok(answer)
    }

    /// The station, or 0AH while the line is down.
    fn station(&self) -> Result<&Handle, u8> {
        self.station.as_ref().ok_or(GATEWAY_PATH_UNAVAILABLE)
    }

    /// FETCH one span's bytes.
    async fn fetch(&self, s: &Span) -> Result<Vec<u8>, u8> {
        let data = self
            .station()?
            .fetch(s.address, self.coordination, s.len)
            .await
            .map_err(|e| failed("FETCH", s, &e))?;
        if data.len() != s.len {
            return Err(SLAVE_DEVICE_FAILURE);
        }
        Ok(data.to_vec())
    }

    /// Every span lies in a refresh area whose last FETCH succeeded: 02H outside the image,
    /// 0BH for an area not (or no longer) fetched.
    fn check_image(&self, spans: &[Span]) -> Result<(), u8> {
        for s in spans {
            let (_, fresh) = self
                .image
                .iter()
                .find(|(area, _)| area.covers(s))
                .ok_or(ILLEGAL_DATA_ADDRESS)?;
            if !fresh {
                return Err(GATEWAY_TARGET_FAILED);
            }
        }
        Ok(())
    }

    /// FETCH every refresh area into the mirror, marking each as it went. Once the partner
    /// does not respond (0BH, 0AH), the areas left are marked stale without trying them, so a
    /// silent partner holds the line for one job bound per refresh, not one per area.
    async fn refresh(&mut self) {
        let mut silent = false;
        for i in 0..self.image.len() {
            let span = self.image[i].0;
            let fresh = !silent
                && match self.fetch(&span).await {
                    Ok(data) => span.store(&mut self.mirror.memory, &data).is_ok(),
                    Err(code) => {
                        silent = matches!(code, GATEWAY_TARGET_FAILED | GATEWAY_PATH_UNAVAILABLE);
                        false
                    }
                };
            self.image[i].1 = fresh;
        }
    }
}

/// The exception for a failed job (module docs), with its STATUS text logged.
fn failed(what: &str, span: &Span, e: &Error) -> u8 {
    let Some(s) = e.status() else {
        tracing::debug!("rk512 {what} {}: {e}", span.address);
        return GATEWAY_PATH_UNAVAILABLE;
    };
    let s = status::lookup(s.code());
    tracing::debug!("rk512 {what} {}: {s}", span.address);
    status_exception(s.code())
}

/// The exception for a failed job's STATUS (module docs; a 3964(R) send job's class 07H too).
pub fn status_exception(code: u16) -> u8 {
    match code {
        0x0502 => SLAVE_DEVICE_BUSY,
        0x051A => GATEWAY_TARGET_FAILED,
        c if matches!(c >> 8, 0x07 | 0x08 | 0x0A) => GATEWAY_TARGET_FAILED,
        _ => SLAVE_DEVICE_FAILURE,
    }
}

/// `request` executed on `store` by si-modbus's serve code: the answer, or the exception.
pub fn answer_from(
    store: &mut SimaticStore,
    adu: &TcpAdu,
    request: &Request<'_>,
) -> Result<TcpAdu, u8> {
    let mut data: ResponseData = [0; 256];
    match serve::execute(store, request, &mut data) {
        serve::Outcome::Answer { response, .. } => {
            TcpAdu::response(adu.transaction(), adu.unit(), &response)
                .map_err(|_| SLAVE_DEVICE_FAILURE)
        }
        serve::Outcome::Refused { code, .. } => Err(code.code()),
    }
}

/// Serve active line `log.index` until the process ends: one request at a time, then the
/// pause; with a refresh period, the refresh areas are FETCHed between requests. While its
/// port is closed the queued jobs are answered with 0AH and the port is reopened with `open`
/// ([`super::reopen`]); `partner` (its mirror) is kept across.
pub async fn run(
    log: LineLog,
    queue: Arc<LineQueue>,
    partner: Partner,
    first: reopen::First<Handle>,
    open: impl AsyncFnMut() -> Result<Opened<Handle>, crate::Error>,
    pause: Duration,
) {
    // The closures own what their futures use (see `line::run`); the partner is lent to one
    // station at a time.
    let (index, stats) = (log.index, Arc::clone(&log.stats));
    let (q, s) = (Arc::clone(&queue), Arc::clone(&stats));
    let partner = Arc::new(tokio::sync::Mutex::new(partner));
    reopen::supervise(
        log,
        first,
        open,
        move |station, closed| {
            let partner = Arc::clone(&partner);
            serve(
                index,
                Arc::clone(&q),
                partner,
                station,
                closed,
                pause,
                Arc::clone(&s),
            )
        },
        move || line::refuse(index, Arc::clone(&queue), Arc::clone(&stats)),
    )
    .await;
}

/// Serve the queue through `station` until its port closes: why it closed.
async fn serve(
    index: usize,
    queue: Arc<LineQueue>,
    partner: Arc<tokio::sync::Mutex<Partner>>,
    station: Handle,
    mut closed: Closed,
    pause: Duration,
    stats: Arc<Mutex<Stats>>,
) -> String {
    let mut partner = partner.lock_owned().await;
    partner.attach(station);
    // A new interval ticks at once: the first refresh runs as soon as the line is up.
    let mut tick = partner.every.map(|every| {
        let mut t = tokio::time::interval(every);
        t.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        t
    });
    let why = loop {
        let (client, job, depth) = tokio::select! {
            biased;
            why = &mut closed => break why,
            () = next_tick(&mut tick) => {
                partner.refresh().await;
                // A full period for the queue after every refresh: a refresh as long as the
                // period (a silent partner, many areas) would otherwise be followed by the
                // next at once, and the queue never served.
                if let Some(t) = &mut tick {
                    t.reset();
                }
                continue;
            }
            popped = queue.pop() => popped,
        };
        line::taken(index, &stats, client, depth);
        let (answer, outcome) = partner.answer(&job.request).await;
        line::answered(index, &stats, client, job, Some(answer), outcome, 0);
        if !pause.is_zero() {
            tokio::time::sleep(pause).await;
        }
    };
    partner.station = None;
    why
}

/// The refresh period's next tick; never without a refresh.
async fn next_tick(tick: &mut Option<Interval>) {
    match tick {
        Some(t) => {
            t.tick().await;
        }
        None => std::future::pending().await,
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::rk512_config::Role;
    use si_core::memory::{Area, MemorySizes};
    use si_core::SerialSettings;
    use si_modbus::frame::Registers;
    use si_modbus::simatic::ConversionDb;
    use si_rk512::passive::ServerConfig;
    use si_rk512::{Config, Station};

    /// An active line with the example conversion DB and these refresh areas.
    pub(crate) fn line(refresh: Vec<Span>, every: Option<Duration>) -> Rk512Line {
        Rk512Line {
            role: Role::Active,
            config: Config::default(),
            coordination: Coordination::NONE,
            conversion: ConversionDb::EXAMPLE,
            refresh_every: every,
            refresh,
            memory: MemorySizes::default(),
        }
    }

    /// Over an in-memory pipe: an active-only station of high priority, and a serving one
    /// (low priority) with a DB6 of `db6` bytes.
    fn stations(db6: u32) -> (Handle, Handle) {
        let (a, b) = tokio::io::duplex(4096);
        let settings = SerialSettings::default();
        let mut high = Config::default();
        high.link.priority = si_3964r::Priority::High;
        let mut memory = ServerConfig::default();
        memory.memory.dbs.insert(6, db6);
        let serving = Station::serving(Config::default(), settings, &memory).unwrap();
        let serving = Handle::spawn_engine(serving, b);
        (Handle::spawn(high, a).unwrap(), serving)
    }

    /// A gateway station and a partner with DB6 (64 bytes).
    fn partner(refresh: Vec<Span>, every: Option<Duration>) -> (Partner, Handle) {
        let (station, plc) = stations(64);
        let mut p = Partner::new(&line(refresh, every));
        p.attach(station);
        (p, plc)
    }

    fn adu(request: &Request<'_>) -> TcpAdu {
        TcpAdu::request(1, 1, request).unwrap()
    }

    async fn ask(p: &mut Partner, request: &Request<'_>) -> (Vec<u8>, Outcome) {
        let (answer, outcome) = p.answer(&adu(request)).await;
        (answer.unit_pdu()[1..].to_vec(), outcome)
    }

    #[tokio::test]
    async fn writes_are_sent_and_reads_fetched_from_the_partner() {
        let (mut p, plc) = partner(vec![], None);
        let w = [0x1234, 0x5678];
        let write = Request::WriteMultipleRegisters {
            address: 10,
            values: Registers::Words(&w),
        };
        assert_eq!(
            ask(&mut p, &write).await,
            (vec![0x10, 0, 10, 0, 2], Outcome::Answer)
        );
        let word = plc
            .with_server(|s| s.memory().word(Area::Db(6), 22).unwrap())
            .await
            .unwrap();
        assert_eq!(word, 0x5678, "the SEND landed in DB6.DBW22");
        plc.with_server(|s| s.memory_mut().set_word(Area::Db(6), 0, 0xBEEF))
            .await
            .unwrap()
            .unwrap();
        let read = Request::ReadHoldingRegisters {
            address: 0,
            quantity: 1,
        };
        assert_eq!(
            ask(&mut p, &read).await,
            (vec![0x03, 2, 0xBE, 0xEF], Outcome::Answer)
        );
        // DB7 (R 512…) is missing at the partner: 0903 → 04H. Writing DB7 is above DB_Max 6:
        // the store's 02H, before any job.
        let r = Request::ReadHoldingRegisters {
            address: 512,
            quantity: 1,
        };
        assert_eq!(
            ask(&mut p, &r).await,
            (vec![0x83, 0x04], Outcome::Exception)
        );
        let one = [1];
        let w7 = Request::WriteMultipleRegisters {
            address: 512,
            values: Registers::Words(&one),
        };
        assert_eq!(
            ask(&mut p, &w7).await,
            (vec![0x90, 0x02], Outcome::Exception)
        );
        // DW 300 cannot be addressed; coils cannot be sent.
        let far = Request::ReadHoldingRegisters {
            address: 300,
            quantity: 1,
        };
        assert_eq!(ask(&mut p, &far).await.0, [0x83, 0x02]);
        let coil = Request::WriteSingleCoil {
            address: 0,
            value: true,
        };
        assert_eq!(ask(&mut p, &coil).await.0, [0x85, 0x01]);
        // The partner's end closes: 0AH.
        drop(plc);
        assert_eq!(ask(&mut p, &read).await, (vec![0x83, 0x0A], Outcome::Other));
    }

    #[tokio::test]
    async fn a_refresh_image_serves_reads_once_fetched() {
        let area = rk512_spans::db_span(6, 0, 8, DwUnit::Words).unwrap();
        let missing = rk512_spans::db_span(9, 0, 2, DwUnit::Words).unwrap();
        let flags = Span {
            address: si_rk512::frame::Address::Flags(0),
            area: Area::Flags,
            start: 0,
            len: 2,
        };
        let image = vec![area, missing, flags];
        let (mut p, plc) = partner(image, Some(Duration::from_millis(100)));
        plc.with_server(|s| s.memory_mut().set_word(Area::Db(6), 2, 0x0102))
            .await
            .unwrap()
            .unwrap();
        let read = |address| Request::ReadHoldingRegisters {
            address,
            quantity: 1,
        };
        assert_eq!(
            ask(&mut p, &read(1)).await,
            (vec![0x83, 0x0B], Outcome::Timeout)
        );
        p.refresh().await;
        assert_eq!(ask(&mut p, &read(1)).await.0, [0x03, 2, 0x01, 0x02]);
        // A refused area (DB9 missing) is stale; the areas after it are still fetched.
        let fresh: Vec<bool> = p.image.iter().map(|(_, f)| *f).collect();
        assert_eq!(fresh, [true, false, true]);
        // Outside the image: 02H.
        assert_eq!(ask(&mut p, &read(4)).await.0, [0x83, 0x02]);
        // A station attached after a reopening: stale until its first refresh through it.
        let (station, plc2) = stations(64);
        p.attach(station);
        assert_eq!(ask(&mut p, &read(1)).await.0, [0x83, 0x0B]);
        p.refresh().await;
        assert_eq!(
            ask(&mut p, &read(1)).await.0,
            [0x03, 2, 0, 0],
            "the new DB6"
        );
        // A failed refresh makes the image stale again.
        drop((plc, plc2));
        p.refresh().await;
        assert_eq!(ask(&mut p, &read(1)).await.0, [0x83, 0x0B]);
        assert!(p.image.iter().all(|(_, f)| !f));
    }

    /// A refresh longer than the period (here a silent partner: the 3964(R) attempts, about
    /// 12 s, against 1 ms) still leaves the queue its turn, in virtual time.
    #[tokio::test(start_paused = true)]
    async fn requests_are_served_between_refreshes_longer_than_the_period() {
        let (a, _silent) = tokio::io::duplex(4096);
        let (port, closed) = reopen::watch(Box::new(a));
        let mut high = Config::default();
        high.link.priority = si_3964r::Priority::High;
        let station = Station::new(high, SerialSettings::default()).unwrap();
        let station = Handle::spawn_engine(station, port);
        let area = rk512_spans::db_span(6, 0, 8, DwUnit::Words).unwrap();
        let every = Some(Duration::from_millis(1));
        let partner = Arc::new(tokio::sync::Mutex::new(Partner::new(&line(
            vec![area],
            every,
        ))));
        let queue = Arc::new(LineQueue::new(4));
        let stats = Arc::new(Mutex::new(Stats::new(1)));
        let q = Arc::clone(&queue);
        tokio::spawn(serve(0, q, partner, station, closed, Duration::ZERO, stats));
        let (tx, rx) = tokio::sync::oneshot::channel();
        let read = Request::ReadHoldingRegisters {
            address: 1,
            quantity: 1,
        };
        let job = super::super::line::Job {
            request: adu(&read),
            reply: Some(tx),
        };
        assert!(queue.push(1, job).is_some());
        let answer = tokio::time::timeout(Duration::from_secs(600), rx)
            .await
            .expect("answered between two refreshes")
            .unwrap();
        // Never fetched (the partner is silent): 0BH from the image, no line traffic.
        assert_eq!(answer.unit_pdu()[1..], [0x83, 0x0B]);
    }
}
