//! Codec and engine speed, ours beside the peers on identical inputs in the same run
//! (BENCHMARKS.md). Groups are named `<operation>/<implementation>`:
//!
//! - Modbus: CRC of a 256-byte frame, FC03 request decode, 125-register FC03 response decode
//!   (to the register values), 100-register FC16 request encode, each against rmodbus; a whole
//!   FC03 round trip over `tokio::io::duplex`, our masters (driver-backed and inline) against
//!   tokio-modbus's client, all talking to the same slave (ours: tokio-modbus's RTU server only
//!   runs on a serial port), on a current-thread and on a multi-threaded runtime.
//! - 3964(R) block encode/decode of 256 bytes, USS telegram decode, the DP window send of a
//!   224-byte frame, the decoders of complete records (RK 512 telegram, slave diagnosis, I&M0;
//!   hand-written beside nom versions), and for every engine its receive path fed the whole frame
//!   at once and one byte at a time (`*_bytewise`).
//!
//! Run: `cargo bench --bench codecs` (add `-- <group>` to pick one).

use bytes::Bytes;
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use si_core::{Engine, Instant, Output, SerialSettings};
use std::hint::black_box;

/// Deterministic bytes (xorshift), so every run and every implementation sees the same input.
fn pseudo_random(n: usize, seed: u64) -> Vec<u8> {
    let mut x = seed | 1;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x as u8
        })
        .collect()
}

/// rmodbus 0.13's CRC, copied verbatim from its `src/lib.rs` (`calc_crc16` is private there);
/// it is what rmodbus runs when it checks or appends a frame's CRC.
fn rmodbus_calc_crc16(frame: &[u8], data_length: u8) -> u16 {
    let mut crc: u16 = 0xffff;
    for i in frame.iter().take(data_length as usize) {
        crc ^= u16::from(*i);
        for _ in (0..8).rev() {
            if (crc & 0x0001) == 0 {
                crc >>= 1;
            } else {
                crc >>= 1;
                crc ^= 0xA001;
            }
        }
    }
    crc
}

fn drain<E: Engine>(engine: &mut E, mut on_transmit: impl FnMut(&[u8])) -> Option<Instant> {
    loop {
        match engine.poll_output() {
            Output::Transmit(bytes) => on_transmit(&bytes),
            Output::Wait(deadline) => return deadline,
            _ => {}
        }
    }
}

/// Hand `bytes` to the engine at `now` in one `handle_rx`, or one byte per call when
/// `bytewise`, draining its outputs after each call as a driver does (the `*_bytewise` groups).
fn feed<E: Engine>(engine: &mut E, now: Instant, bytes: &[u8], bytewise: bool) {
    feed_counting(engine, now, bytes, bytewise, |_| {});
}

/// [`feed`], handing what the engine transmits meanwhile to `on_transmit` (a slave that has
/// seen whole requests arrive in one read knows its port packetises and answers as soon as the
/// request has its predicted length, without waiting for the gap: `si_core::delivery`).
fn feed_counting<E: Engine>(
    engine: &mut E,
    now: Instant,
    bytes: &[u8],
    bytewise: bool,
    mut on_transmit: impl FnMut(&[u8]),
) {
    let chunk = if bytewise { 1 } else { bytes.len().max(1) };
    for piece in bytes.chunks(chunk) {
        engine.handle_rx(now, piece);
        drain(engine, &mut on_transmit);
    }
}

fn modbus(c: &mut Criterion) {
    use rmodbus::client::ModbusRequest;
    use rmodbus::server::ModbusFrame;
    use rmodbus::ModbusProto;
    use si_modbus::frame::{crc16, decode_request, decode_response, Registers, Request, Response};

    // CRC over a 256-byte frame. rmodbus's length is a u8, so it covers 255 bytes: the
    // largest frame it can check.
    let frame = pseudo_random(256, 1);
    let mut g = c.benchmark_group("modbus_crc");
    g.throughput(Throughput::Bytes(256));
    g.bench_function("si", |b| b.iter(|| crc16(black_box(&frame))));
    g.bench_function("rmodbus", |b| {
        b.iter(|| rmodbus_calc_crc16(black_box(&frame), 255))
    });
    g.finish();

    // FC03 request, 10 registers from 0: 01 03 00 00 00 0A C5 CD (the manual's frame).
    let mut request_wire = Vec::new();
    ModbusRequest::new(1, ModbusProto::Rtu)
        .generate_get_holdings(0, 10, &mut request_wire)
        .unwrap();
    assert_eq!(
        request_wire,
        [0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD]
    );
    let mut g = c.benchmark_group("modbus_decode_fc03_request");
    g.bench_function("si", |b| {
        b.iter(|| match decode_request(black_box(&request_wire)) {
            Ok((unit, Request::ReadHoldingRegisters { address, quantity })) => {
                (unit, address, quantity)
            }
            other => panic!("{other:?}"),
        })
    });
    let mut response = Vec::with_capacity(256);
    g.bench_function("rmodbus", |b| {
        b.iter(|| {
            let mut frame =
                ModbusFrame::new(1, black_box(&request_wire), ModbusProto::Rtu, &mut response);
            frame.parse().unwrap();
            assert!(frame.error.is_none());
            (frame.func as u8, frame.reg, frame.count)
        })
    });
    g.finish();

    // FC03 response with 125 registers, decoded to the values in both cases.
    let values: Vec<u16> = (0..125u16).map(|i| i.wrapping_mul(0x9E37)).collect();
    let mut wire = vec![0x01, 0x03, 250];
    for v in &values {
        wire.extend_from_slice(&v.to_be_bytes());
    }
    let crc = crc16(&wire);
    wire.extend_from_slice(&crc.to_le_bytes());
    let mut g = c.benchmark_group("modbus_decode_fc03_response_125");
    g.throughput(Throughput::Bytes(wire.len() as u64));
    g.bench_function("si", |b| {
        let mut out = [0u16; 125];
        b.iter(|| {
            let Ok((_, Response::ReadHoldingRegisters(regs))) = decode_response(black_box(&wire))
            else {
                panic!("not a register response")
            };
            for (slot, v) in out.iter_mut().zip(regs.iter()) {
                *slot = v;
            }
            black_box(&out);
        })
    });
    let mut mreq = ModbusRequest::new(1, ModbusProto::Rtu);
    let mut scratch = Vec::new();
    mreq.generate_get_holdings(0, 125, &mut scratch).unwrap();
    let mut out: Vec<u16> = Vec::with_capacity(125);
    mreq.parse_u16(&wire, &mut out).unwrap();
    assert_eq!(out, values);
    g.bench_function("rmodbus", |b| {
        b.iter(|| {
            out.clear();
            mreq.parse_u16(black_box(&wire), &mut out).unwrap();
            black_box(&out);
        })
    });
    g.finish();

    // FC16 request writing 100 registers.
    let words: Vec<u16> = (0..100u16).map(|i| i.wrapping_mul(0x0101)).collect();
    let mut g = c.benchmark_group("modbus_encode_fc16_request_100");
    let mut buf = [0u8; si_modbus::frame::MAX_ADU];
    let si_len = Request::WriteMultipleRegisters {
        address: 0x10,
        values: Registers::Words(&words),
    }
    .encode(1, &mut buf)
    .unwrap();
    let mut theirs = Vec::with_capacity(256);
    ModbusRequest::new(1, ModbusProto::Rtu)
        .generate_set_holdings_bulk(0x10, &words, &mut theirs)
        .unwrap();
    assert_eq!(&buf[..si_len], &theirs[..], "identical frames");
    g.throughput(Throughput::Bytes(si_len as u64));
    g.bench_function("si", |b| {
        b.iter(|| {
            Request::WriteMultipleRegisters {
                address: 0x10,
                values: Registers::Words(black_box(&words)),
            }
            .encode(1, &mut buf)
            .unwrap()
        })
    });
    let mut mreq = ModbusRequest::new(1, ModbusProto::Rtu);
    g.bench_function("rmodbus", |b| {
        b.iter(|| {
            theirs.clear();
            mreq.generate_set_holdings_bulk(0x10, black_box(&words), &mut theirs)
                .unwrap();
            theirs.len()
        })
    });
    g.finish();

    // The slave engine receiving an FC03 request: whole, and one byte per read.
    modbus_slave_rx(c);
    // FC03 of 10 registers over tokio::io::duplex.
    modbus_roundtrip(c);
}

fn modbus_slave_rx(c: &mut Criterion) {
    use si_core::Duration;
    use si_modbus::{SimaticStore, Slave, SlaveConfig};
    let request = [0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD];
    let mut g = c.benchmark_group("modbus_slave_rx_fc03");
    for bytewise in [false, true] {
        let config = SlaveConfig {
            address: 1,
            ..SlaveConfig::default()
        };
        let mut slave = Slave::new(config, SimaticStore::example()).unwrap();
        let mut t = 0u64;
        let name = if bytewise { "si_bytewise" } else { "si" };
        g.bench_function(name, |b| {
            b.iter(|| {
                t += 100_000;
                let now = Instant::from_micros(t);
                let mut sent = 0;
                feed_counting(&mut slave, now, &request, bytewise, |tx| sent += tx.len());
                let later = now + Duration::from_millis(5);
                slave.handle_timeout(later);
                drain(&mut slave, |tx| sent += tx.len());
                slave.handle_tx_done(later + Duration::from_millis(30));
                drain(&mut slave, |_| {});
                assert_eq!(sent, 25);
            })
        });
    }
    g.finish();
}

/// Take the slave's events as an application would: its driver stops reading the line when
/// they pile up unread.
fn take_events(mut server: si_modbus::tokio::Slave<si_modbus::Tables>) {
    tokio::spawn(async move { while server.next_event().await.is_some() {} });
}

/// FC03 of 10 registers over `tokio::io::duplex`: our masters and tokio-modbus's RTU client,
/// each against our slave, side by side in one run, on a current-thread runtime
/// (`modbus_roundtrip_duplex`) and on a multi-threaded one (`modbus_roundtrip_duplex_mt`, two
/// workers: noisier on a loaded machine).
///
/// - `si`: the driver-backed [`handle::Master`], the engine in a driver task;
/// - `si-inline`: the [`handle::InlineMaster`], the engine in the caller's future, as
///   tokio-modbus runs its codec;
/// - `tokio-modbus`: its RTU client context.
///
/// Both clients and the slave end frames by their predicted length (our
/// `FrameEnd::Length`; tokio-modbus's RTU codec does so too), so no end-of-frame gap is waited
/// for. Our master keeps to [Modbus/USS] §3.3.5 and holds a request until the line has been silent
/// for the gap (1 ms) since the last response, which back-to-back `iter` would measure; so each
/// iteration first leaves the line idle for longer than the gap (untimed) and then times one
/// request until its response is decoded, the same loop for every implementation.
fn modbus_roundtrip(c: &mut Criterion) {
    let current = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    modbus_roundtrip_on(c, "modbus_roundtrip_duplex", &current);
    let multi = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    modbus_roundtrip_on(c, "modbus_roundtrip_duplex_mt", &multi);
    if std::env::var_os("SI_BENCH_INTERLEAVED").is_some() {
        // `SI_BENCH_RUNTIMES=current-thread`: only that runtime (both unless given), e.g. for
        // instruction counts that do not depend on how the workers' threads were scheduled.
        let runtimes = std::env::var("SI_BENCH_RUNTIMES").ok();
        let on = |name: &str| {
            runtimes
                .as_deref()
                .is_none_or(|r| r.split(',').any(|n| n == name))
        };
        if on("current-thread") {
            modbus_roundtrip_interleaved("current-thread", &current);
        }
        if on("multi-thread") {
            modbus_roundtrip_interleaved("multi-thread", &multi);
        }
    }
}

/// `SI_BENCH_INTERLEAVED=1`: the same round trips, the three clients taking turns request by
/// request (si, si-inline, tokio-modbus, si, …), each request timed from an idle line as in
/// the criterion groups; printed as each client's median per request. On a loaded machine the
/// criterion groups, which run one client after the other, see different loads; taking turns,
/// every client sees the same.
fn modbus_roundtrip_interleaved(runtime: &str, rt: &tokio::runtime::Runtime) {
    use si_modbus::tokio::{self as handle, Client as _};
    use std::time::Duration as StdDuration;
    use tokio_modbus::client::Reader;
    // `SI_BENCH_INTERLEAVED=<n>`: n requests per client (2000 unless a number is given).
    let requests: usize = std::env::var("SI_BENCH_INTERLEAVED")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(2_000);
    let (slave, master) = roundtrip_engines();
    let _guard = rt.enter();
    let (a, b) = tokio::io::duplex(1024);
    take_events(handle::Slave::spawn_engine(slave(), b));
    let driven = handle::Master::spawn_engine(master(), a);
    let (a, b) = tokio::io::duplex(1024);
    take_events(handle::Slave::spawn_engine(slave(), b));
    let inline = handle::InlineMaster::from_engine(master(), a);
    let (a, b) = tokio::io::duplex(1024);
    take_events(handle::Slave::spawn_engine(slave(), b));
    let mut ctx = tokio_modbus::client::rtu::attach_slave(a, tokio_modbus::Slave(1));
    // `SI_BENCH_CLIENTS=si-inline,tokio-modbus`: only these clients take turns (all three
    // unless given), e.g. to count one client's instructions under callgrind.
    let clients = std::env::var("SI_BENCH_CLIENTS").ok();
    let runs = |name: &str| {
        clients
            .as_deref()
            .is_none_or(|c| c.split(',').any(|n| n == name))
    };
    let active = [runs("si"), runs("si-inline"), runs("tokio-modbus")];
    let mut times = [Vec::new(), Vec::new(), Vec::new()];
    for _ in 0..requests {
        for (which, t) in times.iter_mut().enumerate() {
            if !active[which] {
                t.push(StdDuration::ZERO);
                continue;
            }
            roundtrip_idle();
            let start = std::time::Instant::now();
            let n = rt.block_on(async {
                match which {
                    0 => driven.read_holding_registers(1, 0, 10).await.unwrap().len(),
                    1 => inline.read_holding_registers(1, 0, 10).await.unwrap().len(),
                    _ => ctx
                        .read_holding_registers(0, 10)
                        .await
                        .unwrap()
                        .unwrap()
                        .len(),
                }
            });
            t.push(start.elapsed());
            assert_eq!(n, 10);
        }
    }
    let median = |t: &mut Vec<StdDuration>| {
        t.sort();
        t[t.len() / 2]
    };
    let [si, inline, theirs] = times.each_mut().map(median);
    println!(
        "modbus_roundtrip_interleaved ({runtime}): si {si:?}, si-inline {inline:?}, \
         tokio-modbus {theirs:?}: tokio-modbus / si-inline = {:.2}x",
        theirs.as_secs_f64() / inline.as_secs_f64()
    );
}

/// The slave and master engines of the round-trip groups (see [`modbus_roundtrip`]).
fn roundtrip_engines() -> (
    impl Fn() -> si_modbus::Slave<si_modbus::Tables>,
    impl Fn() -> si_modbus::Master,
) {
    use si_modbus::{FrameEnd, Master, MasterConfig, Mode, Slave, SlaveConfig, Tables};
    // A pipe moves bytes at once, a line does not: at 115200 baud the slave would still be
    // sending its 25-byte answer (2.2 ms) when a client that got it at once sends the next
    // request, and the slave rightly refuses that overlap (0837H). At a nominal 1 Gbaud the
    // answer's time on the line is below 1 µs; the end-of-frame gap stays Table 3-11's
    // shortest, 1 ms, as at 115200 baud.
    static FAST: [u32; 1] = [1_000_000_000];
    let settings =
        SerialSettings::with_rates(1_000_000_000, 8, si_core::Parity::Even, 1, &FAST).unwrap();
    let slave_config = SlaveConfig {
        address: 1,
        line: si_modbus::config::LineConfig {
            settings,
            mode: Mode::Normal,
            ..SlaveConfig::default().line
        },
    };
    let slave = move || {
        Slave::new(slave_config, Tables::new(0, 0, 100, 0))
            .unwrap()
            .with_frame_end(FrameEnd::Length)
    };
    let master = move || {
        let mut config = MasterConfig::default();
        config.line.settings = settings;
        Master::new(config)
            .unwrap()
            .with_frame_end(FrameEnd::Length)
    };
    (slave, master)
}

/// Leave the line idle for longer than the 1 ms gap, so our master's hold never delays the
/// timed request. Waited by spinning, not sleeping: a thread woken from sleep runs its first
/// microseconds on a cold, down-clocked core, which would be measured instead of the code.
fn roundtrip_idle() {
    const IDLE: std::time::Duration = std::time::Duration::from_micros(1_300);
    let start = std::time::Instant::now();
    while start.elapsed() < IDLE {
        std::hint::spin_loop();
    }
}

fn modbus_roundtrip_on(c: &mut Criterion, group: &str, rt: &tokio::runtime::Runtime) {
    use si_modbus::tokio::{self as handle, Client as _};
    use std::time::Duration as StdDuration;
    use tokio_modbus::client::Reader;

    let (slave, master) = roundtrip_engines();
    /// Time `one` request per iteration from an idle line, the same loop for every client.
    fn timed<F: std::future::Future<Output = usize>>(
        rt: &tokio::runtime::Runtime,
        iters: u64,
        mut one: impl FnMut() -> F,
    ) -> StdDuration {
        let mut timed = StdDuration::ZERO;
        for _ in 0..iters {
            roundtrip_idle();
            let start = std::time::Instant::now();
            let n = rt.block_on(one());
            timed += start.elapsed();
            assert_eq!(n, 10);
        }
        timed
    }
    let mut g = c.benchmark_group(group);
    g.sample_size(30);
    {
        let _guard = rt.enter();
        let (a, b) = tokio::io::duplex(1024);
        take_events(handle::Slave::spawn_engine(slave(), b));
        let master = handle::Master::spawn_engine(master(), a);
        g.bench_function("si", |bench| {
            bench.iter_custom(|iters| {
                timed(rt, iters, || async {
                    master.read_holding_registers(1, 0, 10).await.unwrap().len()
                })
            })
        });
    }
    {
        let _guard = rt.enter();
        let (a, b) = tokio::io::duplex(1024);
        take_events(handle::Slave::spawn_engine(slave(), b));
        let master = handle::InlineMaster::from_engine(master(), a);
        g.bench_function("si-inline", |bench| {
            bench.iter_custom(|iters| {
                timed(rt, iters, || async {
                    master.read_holding_registers(1, 0, 10).await.unwrap().len()
                })
            })
        });
    }
    {
        let _guard = rt.enter();
        let (a, b) = tokio::io::duplex(1024);
        take_events(handle::Slave::spawn_engine(slave(), b));
        let mut ctx = tokio_modbus::client::rtu::attach_slave(a, tokio_modbus::Slave(1));
        g.bench_function("tokio-modbus", |bench| {
            // `timed`'s loop written out: the context is borrowed mutably by each request.
            bench.iter_custom(|iters| {
                let mut timed = StdDuration::ZERO;
                for _ in 0..iters {
                    roundtrip_idle();
                    let start = std::time::Instant::now();
                    let n = rt.block_on(async {
                        ctx.read_holding_registers(0, 10)
                            .await
                            .unwrap()
                            .unwrap()
                            .len()
                    });
                    timed += start.elapsed();
                    assert_eq!(n, 10);
                }
                timed
            })
        });
    }
    g.finish();
}

fn r3964(c: &mut Criterion) {
    use si_3964r::frame::{encode_into, Decoder, Mode};
    use si_3964r::{Config, Link};

    // 256 bytes of payload with DLEs in it (about one in 256, as random data has).
    let payload = pseudo_random(256, 7);
    let mut g = c.benchmark_group("3964r_encode_256");
    g.throughput(Throughput::Bytes(256));
    let mut out = Vec::with_capacity(600);
    g.bench_function("si", |b| {
        b.iter(|| {
            out.clear();
            encode_into(black_box(&payload), Mode::BlockCheck, &mut out);
            out.len()
        })
    });
    g.finish();

    out.clear();
    encode_into(&payload, Mode::BlockCheck, &mut out);
    let block = out.clone();
    let mut g = c.benchmark_group("3964r_decode_256");
    g.throughput(Throughput::Bytes(256));
    let mut decoder = Decoder::new(Mode::BlockCheck, 1024);
    g.bench_function("si", |b| {
        b.iter(|| {
            decoder.reset();
            let (used, result) = decoder.push_slice(black_box(&block));
            assert_eq!((used, result), (block.len(), Some(Ok(()))));
            decoder.payload().len()
        })
    });
    g.finish();
    let mut g = c.benchmark_group("3964r_decode_256_bytewise");
    g.throughput(Throughput::Bytes(256));
    g.bench_function("si", |b| {
        b.iter(|| {
            decoder.reset();
            let mut end = None;
            for &byte in black_box(&block) {
                end = decoder.push(byte);
            }
            assert_eq!(end, Some(Ok(())));
            decoder.payload().len()
        })
    });
    g.finish();

    // The link engine receiving one block: STX, our DLE, the block, our DLE, take it.
    let config = Config {
        max_block_len: 1024,
        ..Config::default()
    };
    for (group, bytewise) in [
        ("3964r_link_rx_256", false),
        ("3964r_link_rx_256_bytewise", true),
    ] {
        let mut g = c.benchmark_group(group);
        g.throughput(Throughput::Bytes(256));
        let mut link = Link::new(config.with_settings(SerialSettings::default())).unwrap();
        drain(&mut link, |_| {});
        let mut t = 0u64;
        g.bench_function("si", |b| {
            b.iter(|| {
                t += 1_000_000;
                let now = Instant::from_micros(t);
                link.handle_rx(now, &[0x02]);
                drain(&mut link, |_| {});
                feed(&mut link, now, &block, bytewise);
                let got = link.take_block(now).expect("the block");
                assert_eq!(got.len(), 256);
            })
        });
        g.finish();
    }
}

fn uss(c: &mut Criterion) {
    use si_core::Duration;
    use si_uss::config::{uss_settings, MasterConfig, PollEntry};
    use si_uss::drive::{Drive, DriveConfig};
    use si_uss::frame::{decode, encode, Adr, PkwWords, MAX_TELEGRAM};
    use si_uss::{Master, NetData};

    // A drive's answer with 4 PKW and 2 PZD words (the common PPO1 layout).
    let net: Vec<u8> = pseudo_random(12, 3);
    let mut telegram = [0u8; MAX_TELEGRAM];
    let n = encode(Adr::slave(5).unwrap(), &net, &mut telegram).unwrap();
    let telegram = telegram[..n].to_vec();
    let mut g = c.benchmark_group("uss_decode");
    g.throughput(Throughput::Bytes(n as u64));
    g.bench_function("si", |b| {
        b.iter(|| {
            let t = decode(black_box(&telegram)).unwrap();
            NetData::parse(t.net, PkwWords::Four, 2).unwrap()
        })
    });
    g.finish();

    // The master engine receiving a drive's answer to its poll: whole, and byte by byte.
    let settings = uss_settings(19_200).unwrap();
    for (group, bytewise) in [("uss_master_rx", false), ("uss_master_rx_bytewise", true)] {
        let mut config = MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2)]);
        config.settings = settings;
        let mut master = Master::new(config).unwrap();
        let mut drive = Drive::new(DriveConfig::new(settings, 1)).unwrap();
        let mut now = Instant::ZERO;
        master.start(now);
        let mut g = c.benchmark_group(group);
        g.bench_function("si", |b| {
            let mut wire = Vec::with_capacity(64);
            b.iter(|| {
                // Run the master to its next poll; hand it to the drive; the drive answers.
                let mut deadline = drain(&mut master, |tx| wire.extend_from_slice(tx));
                while wire.is_empty() {
                    now = deadline.unwrap_or(now + Duration::from_millis(1));
                    master.handle_timeout(now);
                    deadline = drain(&mut master, |tx| wire.extend_from_slice(tx));
                }
                master.handle_tx_done(now);
                drain(&mut master, |_| {});
                drive.handle_rx(now, &wire);
                wire.clear();
                let mut d = drain(&mut drive, |tx| wire.extend_from_slice(tx));
                while wire.is_empty() {
                    now = d.unwrap_or(now + Duration::from_millis(1));
                    drive.handle_timeout(now);
                    d = drain(&mut drive, |tx| wire.extend_from_slice(tx));
                }
                drive.handle_tx_done(now);
                drain(&mut drive, |_| {});
                feed(&mut master, now, &wire, bytewise);
                wire.clear();
            })
        });
        g.finish();
        // Every answer the master saw was good (none at all when a filter skipped the group).
        assert_eq!(master.counters().rejected, 0);
    }
}

fn ascii(c: &mut Criterion) {
    use si_ascii::{Config, EndCriterion, Link};
    let mut frame = pseudo_random(198, 9);
    for b in &mut frame {
        *b = b'0' + (*b % 64); // printable, no CR/LF
    }
    frame.extend_from_slice(b"\r\n");
    let config = Config {
        end: EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        ..Config::default()
    };
    for (group, bytewise) in [("ascii_rx_200", false), ("ascii_rx_200_bytewise", true)] {
        let mut link = Link::new(config).unwrap();
        let mut out = [0u8; 1024];
        let mut t = 0u64;
        let mut g = c.benchmark_group(group);
        g.throughput(Throughput::Bytes(200));
        g.bench_function("si", |b| {
            b.iter(|| {
                t += 1_000_000;
                let now = Instant::from_micros(t);
                feed(&mut link, now, &frame, bytewise);
                assert_eq!(link.read_frame(now, &mut out), Some(200));
            })
        });
        g.finish();
    }
}

fn dpcoord(c: &mut Criterion) {
    use si_core::Duration;
    use si_dp_coord::{
        Host, HostConfig, HostEvent, Job, LoopbackSerial, Module, ModuleConfig, WindowSize,
    };
    let frame = Bytes::from(pseudo_random(224, 11));
    let mut g = c.benchmark_group("dpcoord_send_224");
    g.throughput(Throughput::Bytes(224));
    g.bench_function("si", |b| {
        b.iter_batched(
            || {
                let host = Host::new(HostConfig::new(WindowSize::ThirtyTwo)).unwrap();
                let module = Module::new(
                    ModuleConfig::new(WindowSize::ThirtyTwo),
                    LoopbackSerial::new(),
                )
                .unwrap();
                (host, module)
            },
            |(mut host, mut module)| {
                host.submit(Job::Send(frame.clone())).unwrap();
                let mut input = module.input().to_vec();
                let mut output = Vec::with_capacity(32);
                let mut now = Instant::ZERO;
                for _ in 0..1_000 {
                    now += Duration::from_millis(1);
                    output.clear();
                    output.extend_from_slice(host.cycle(now, &input));
                    input.clear();
                    input.extend_from_slice(module.cycle(now, &output));
                    if let Some(HostEvent::Completed { result, .. }) = host.poll_event() {
                        assert!(result.is_ok());
                        return;
                    }
                }
                panic!("the send did not complete");
            },
            BatchSize::SmallInput,
        )
    });
    g.finish();
}

/// A group timing `decode` (which must succeed) on `bytes`, in bytes per second; the decoded
/// value is returned to criterion, so none of the decoding is optimised away.
fn decode_group<'a, T, E: std::fmt::Debug>(
    c: &mut Criterion,
    name: &str,
    bytes: &'a [u8],
    decode: impl Fn(&'a [u8]) -> Result<T, E>,
) {
    let mut g = c.benchmark_group(name);
    g.throughput(Throughput::Bytes(bytes.len() as u64));
    g.bench_function("si", |b| b.iter(|| decode(black_box(bytes)).unwrap()));
    g.finish();
}

/// Decoders of complete records: an RK 512 SEND telegram with 128 data bytes, a slave
/// diagnosis with every part, an I&M0 record (nom where it helps).
fn records(c: &mut Criterion) {
    use si_module::diag::{
        ChannelDiagnosis, ErrorType, ModuleDiagnosis, ModuleStatus, SlaveDiagnosis, StationStatus,
    };
    use si_module::ident::Im0;
    use si_rk512::frame::{Address, Command, CommandHeader, Coordination, Telegram};

    let mut telegram = CommandHeader {
        command: Command::Send,
        address: Address::Db { db: 10, dw: 1 },
        length: 64,
        coordination: Coordination::cpu_only(1),
    }
    .encode()
    .to_vec();
    telegram.extend(pseudo_random(128, 5));
    decode_group(c, "rk512_decode_telegram", &telegram, Telegram::decode);

    let diag = SlaveDiagnosis {
        station: StationStatus {
            status1: 0x08,
            status2: 0x0C,
            master_address: 2,
            ident_number: 0x80E0,
            ..StationStatus::default()
        },
        module_diagnosis: Some(ModuleDiagnosis { bits: vec![0x02] }),
        module_status: Some(ModuleStatus { bits: vec![0x04] }),
        channels: vec![
            ChannelDiagnosis::si(2, ErrorType::WireBreak),
            ChannelDiagnosis::si(3, ErrorType::MessageError),
        ],
        unknown: Vec::new(),
    }
    .encode()
    .unwrap();
    decode_group(c, "module_diag_decode", &diag, SlaveDiagnosis::decode);

    let record = Im0::for_variant(si_module::diag::Variant::ModbusUss, "S C-X4U12345")
        .encode()
        .unwrap();
    decode_group(c, "module_im0_decode", &record, Im0::decode);
}

criterion_group!(benches, modbus, r3964, uss, ascii, dpcoord, records);
criterion_main!(benches);
