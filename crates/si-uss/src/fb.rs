//! The ET 200S data model and the FC equivalents S_USSI (FC19), S_USST (FC17) and S_USSR (FC18).
//!
//! Sources: [Modbus/USS] §3.7.3–§3.7.9, [ET200S SI 2005] Tables 3-80, 3-82, Table 3-84,
//! [ET200S SI 2005] §3.8–§3.8.10. A PLC program keeps each slave's data in the **net-data DB**
//! (DBND), the polling list in the **parameter DB** (DBPA) and the telegram buffers in the **CP
//! DB** (DBCP). Here the three DBs are byte images ([`Db`], S7 byte order: high byte first) and the
//! line work is done by a [`Master`] engine, so a program written against the DB layout runs
//! unchanged on a host:
//!
//! - [`s_ussi`] checks SANZ, TNU1, PKW, PZD and WDH, creates the DBs and presets DBPA (ANZ codes
//!   in [`Anz`]); [`master_config`] turns a DBPA into the master's polling list;
//! - [`s_usst`], called once per cycle, takes the current slave (SLAV) from DBPA, hands its
//!   transmit PZD to the master, starts a PKW job when KSTW bit 0 is set and acknowledges a change
//!   report when KSTW bit 1 is set;
//! - [`s_ussr`], called once per cycle after it, copies the master's comm status word, comm error
//!   word and — only when the group error bit 9 is 0 — the receive buffer into DBND, then moves
//!   SLAV to the next entry.
//!
//! **Readings chosen** ([Modbus/USS] §3.7 `[derived]`, [ET200S SI 2005] §3.8 `[derived]`
//! `[derived]`):
//! - Offsets for PKW < 4 or PZD < 16 are not printed; we use the derived general offsets of
//!   [ET200S SI 2005] §3.8.8 ([`SlaveLayout`]), which reproduce the printed table for PKW 4 / PZD
//!   16 and the word formula 2 × (PKW + PZD) + PKW + 6.
//! - S_USSI numbers the slaves TNU1, TNU1 + 1, … (ANZ 5 if that passes 31), and places their
//!   blocks one after another from DBW2.
//! - Pafe 1 is byte n+10 (written by S_USSR), Pafe 2 byte n+11 (S_USST), as the DBND table
//!   prints them; "the last two bytes" / "1 byte" of the FC texts are taken to mean these.
//! - DBCP is created with its 50 words and its length is checked (ANZ 6), but a host master needs
//!   no S_SEND/S_RCV hand-over: the [`Master`] keeps the telegram buffers itself and DBCP stays
//!   zero.
//! - SYPA and SLPA (start of the system and slave parameters in DBPA) are not inputs here: the
//!   manual prints fixed DBPA offsets ([Modbus/USS] §3.7.8), which we use, i.e. SYPA = 2 and SLPA =
//!   10.
//! - The telegram monitoring time the FCs derive from the PLC cycle time (DBCP DBW6) is replaced
//!   by the master's response timeout and residual run time ([USS spec] §5.2.1, §5.2.2).
//! - Broadcast and mirror telegrams have no place in the FCs (TNU 0…31 only, [Modbus/USS] §3.7
//!   `[derived]`); use [`Master::broadcast`] and [`Master::mirror`] directly.

use crate::config::{MasterConfig, PollEntry};
use crate::frame::{ParamAddress, PkwWords};
use crate::master::{comm_status, Master, ParamRequest, RequestError};
use si_core::Instant;

/// A data block as a byte image; words and double words are high byte first (S7 order).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Db {
    /// The bytes (DBB0 …).
    pub bytes: Vec<u8>,
}

impl Db {
    /// A zeroed DB of `words` words.
    pub fn words(words: usize) -> Db {
        Db {
            bytes: vec![0; 2 * words],
        }
    }
    /// DBW at byte `offset`; 0 outside the DB.
    pub fn word(&self, offset: usize) -> u16 {
        match self.bytes.get(offset..offset + 2) {
            Some(b) => u16::from_be_bytes([b[0], b[1]]),
            None => 0,
        }
    }
    /// Write DBW at `offset`; ignored outside the DB.
    pub fn set_word(&mut self, offset: usize, value: u16) {
        if let Some(b) = self.bytes.get_mut(offset..offset + 2) {
            b.copy_from_slice(&value.to_be_bytes());
        }
    }
    /// DBB at `offset`; 0 outside.
    pub fn byte(&self, offset: usize) -> u8 {
        self.bytes.get(offset).copied().unwrap_or(0)
    }
    /// Write DBB at `offset`; ignored outside.
    pub fn set_byte(&mut self, offset: usize, value: u8) {
        if let Some(b) = self.bytes.get_mut(offset) {
            *b = value;
        }
    }
}

/// Byte offsets inside one slave's DBND block, relative to its start `n`
/// ([Modbus/USS] §3.7.7; general form [ET200S SI 2005] §3.8.8).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlaveLayout {
    /// PKW words: 0, 3 or 4.
    pub pkw: u8,
    /// PZD words: 0…16.
    pub pzd: u8,
}

impl SlaveLayout {
    /// KSTW, communication control word.
    pub const KSTW: usize = 0;
    /// Comm status word.
    pub const COMM_STATUS: usize = 4;
    /// Comm error word.
    pub const COMM_ERROR: usize = 6;
    /// Internal: PKW retry counter.
    pub const PKW_RETRIES: usize = 8;
    /// Pafe 1 (written by S_USSR).
    pub const PAFE1: usize = 10;
    /// Pafe 2 (written by S_USST).
    pub const PAFE2: usize = 11;
    /// PKW job buffer (PKE, IND, PWE…), written by the user.
    pub const JOB_PKW: usize = 12;

    fn p(&self) -> usize {
        usize::from(self.pkw)
    }
    fn z(&self) -> usize {
        usize::from(self.pzd)
    }
    /// Transmit buffer, PKW area.
    pub fn tx_pkw(&self) -> usize {
        12 + 2 * self.p()
    }
    /// Transmit buffer, PZD area (PZD1 = STW, PZD2 = HSW).
    pub fn tx_pzd(&self) -> usize {
        12 + 4 * self.p()
    }
    /// Receive buffer, PKW area.
    pub fn rx_pkw(&self) -> usize {
        12 + 4 * self.p() + 2 * self.z()
    }
    /// Receive buffer, PZD area (PZD1 = ZSW, PZD2 = HIW).
    pub fn rx_pzd(&self) -> usize {
        12 + 6 * self.p() + 2 * self.z()
    }
    /// Words of the block: 2 × (PKW + PZD) + PKW + 6.
    pub fn words(&self) -> usize {
        2 * (self.p() + self.z()) + self.p() + 6
    }
    /// Valid counts: PKW 0, 3 or 4, PZD 0…16.
    pub fn is_valid(&self) -> bool {
        matches!(self.pkw, 0 | 3 | 4) && self.pzd <= 16
    }
}

/// S_USSI's error byte ANZ ([Modbus/USS] §3.7.6, Table 3-31).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Anz {
    /// 1: too many slaves (SANZ outside 1…31).
    #[error("ANZ 1: too many slaves")]
    TooManySlaves = 1,
    /// 2: invalid net-data structure (PKW not 0/3/4, PZD not 0…16).
    #[error("ANZ 2: invalid net-data structure")]
    InvalidStructure = 2,
    /// 3: parameter DB too short.
    #[error("ANZ 3: parameter DB too short")]
    DbpaTooShort = 3,
    /// 4: net-data DB too short.
    #[error("ANZ 4: net-data DB too short")]
    DbndTooShort = 4,
    /// 5: station-number error (TNU1 outside 0…31, or TNU1 + SANZ − 1 over 31).
    #[error("ANZ 5: station number error")]
    StationNumber = 5,
    /// 6: CP DB too short.
    #[error("ANZ 6: CP DB too short")]
    DbcpTooShort = 6,
    /// 8: invalid retry counter (WDH outside 0…32 767).
    #[error("ANZ 8: invalid retry counter")]
    RetryCounter = 8,
}

/// S_USSI's inputs ([Modbus/USS] §3.7.6, Table 3-31).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UssiParams {
    /// SANZ: number of slaves, 1…31.
    pub sanz: i16,
    /// TNU1: first node number, 0…31.
    pub tnu1: i16,
    /// PKW words: 0, 3 or 4.
    pub pkw: i16,
    /// PZD words: 0…16.
    pub pzd: i16,
    /// DBND number.
    pub dbnd: u16,
    /// DBPA number.
    pub dbpa: u16,
    /// DBCP number.
    pub dbcp: u16,
    /// WDH: permitted PKW repetitions, 0…32 767.
    pub wdh: i16,
}

/// The three DBs of a USS installation.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct UssDbs {
    /// Parameter DB: the polling list.
    pub dbpa: Db,
    /// Net-data DB: one block per slave.
    pub dbnd: Db,
    /// CP DB: at least 50 words.
    pub dbcp: Db,
}

/// DBPA word offsets ([Modbus/USS] §3.7.8).
pub mod dbpa {
    /// DBW2: CP DB number.
    pub const DBCP: usize = 2;
    /// DBW4: SANZ.
    pub const SANZ: usize = 4;
    /// DBW6: SLAV, the current entry (1-based).
    pub const SLAV: usize = 6;
    /// DBW8: WDH.
    pub const WDH: usize = 8;
    /// Entry `i` (1-based): structure word (high byte PKW, low byte PZD).
    pub const fn structure(i: usize) -> usize {
        8 * i + 2
    }
    /// Entry `i`: TNU.
    pub const fn tnu(i: usize) -> usize {
        8 * i + 4
    }
    /// Entry `i`: DBND number.
    pub const fn dbnd(i: usize) -> usize {
        8 * i + 6
    }
    /// Entry `i`: byte offset of the slave's KSTW in DBND.
    pub const fn kstw(i: usize) -> usize {
        8 * i + 8
    }
}

/// FC19 S_USSI: check the parameters, create the DBs and preset DBPA. `existing` DBs are reused
/// when long enough (DBPA preset again, DBND and DBCP cleared) and refused when too short.
pub fn s_ussi(p: &UssiParams, existing: Option<UssDbs>) -> Result<UssDbs, Anz> {
    if !(1..=31).contains(&p.sanz) {
        return Err(Anz::TooManySlaves);
    }
    let layout = SlaveLayout {
        pkw: u8::try_from(p.pkw).unwrap_or(u8::MAX),
        pzd: u8::try_from(p.pzd).unwrap_or(u8::MAX),
    };
    if !layout.is_valid() {
        return Err(Anz::InvalidStructure);
    }
    if !(0..=31).contains(&p.tnu1) || p.tnu1 + p.sanz - 1 > 31 {
        return Err(Anz::StationNumber);
    }
    if p.wdh < 0 {
        return Err(Anz::RetryCounter);
    }
    let n = p.sanz as usize;
    let dbpa_words = 4 * n + 5;
    let dbnd_words = 1 + n * layout.words();
    let dbcp_words = 50;
    let mut dbs = match existing {
        Some(d) => {
            if d.dbpa.bytes.len() < 2 * dbpa_words {
                return Err(Anz::DbpaTooShort);
            }
            if d.dbnd.bytes.len() < 2 * dbnd_words {
                return Err(Anz::DbndTooShort);
            }
            if d.dbcp.bytes.len() < 2 * dbcp_words {
                return Err(Anz::DbcpTooShort);
            }
            d
        }
        None => UssDbs {
            dbpa: Db::words(dbpa_words),
            dbnd: Db::words(dbnd_words),
            dbcp: Db::words(dbcp_words),
        },
    };
    dbs.dbnd.bytes.fill(0);
    dbs.dbcp.bytes.fill(0);
    dbs.dbpa.bytes.fill(0);
    let a = &mut dbs.dbpa;
    a.set_word(dbpa::DBCP, p.dbcp);
    a.set_word(dbpa::SANZ, p.sanz as u16);
    a.set_word(dbpa::SLAV, 1);
    a.set_word(dbpa::WDH, p.wdh as u16);
    for i in 1..=n {
        a.set_word(
            dbpa::structure(i),
            (u16::from(layout.pkw) << 8) | u16::from(layout.pzd),
        );
        a.set_word(dbpa::tnu(i), (p.tnu1 as usize + i - 1) as u16);
        a.set_word(dbpa::dbnd(i), p.dbnd);
        a.set_word(dbpa::kstw(i), (2 + 2 * layout.words() * (i - 1)) as u16);
    }
    Ok(dbs)
}

/// One DBPA entry read back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Entry {
    /// Structure.
    pub layout: SlaveLayout,
    /// Node number.
    pub tnu: u8,
    /// Byte offset of the KSTW in DBND.
    pub kstw: usize,
}

/// Entry `i` (1-based) of a DBPA.
pub fn entry(dbpa_db: &Db, i: usize) -> Entry {
    let s = dbpa_db.word(dbpa::structure(i));
    Entry {
        layout: SlaveLayout {
            pkw: (s >> 8) as u8,
            pzd: s as u8,
        },
        tnu: dbpa_db.word(dbpa::tnu(i)).min(255) as u8,
        kstw: usize::from(dbpa_db.word(dbpa::kstw(i))),
    }
}

/// The master's polling list and WDH from a DBPA (entries with an invalid structure or TNU are
/// left out; S_USST/S_USSR report them in Pafe).
pub fn master_config(dbpa_db: &Db) -> MasterConfig {
    let sanz = usize::from(dbpa_db.word(dbpa::SANZ)).min(31);
    let list = (1..=sanz)
        .map(|i| entry(dbpa_db, i))
        .filter(|e| e.layout.is_valid() && e.tnu <= 31)
        .map(|e| {
            PollEntry::new(
                e.tnu,
                PkwWords::from_count(e.layout.pkw).unwrap_or(PkwWords::None),
                e.layout.pzd,
            )
        })
        .collect();
    let mut c = MasterConfig::new(list);
    c.retries = dbpa_db.word(dbpa::WDH).min(32_767);
    c
}

fn current(dbs: &UssDbs) -> (usize, Entry) {
    let sanz = usize::from(dbs.dbpa.word(dbpa::SANZ)).clamp(1, 31);
    let slav = usize::from(dbs.dbpa.word(dbpa::SLAV)).clamp(1, sanz);
    (slav, entry(&dbs.dbpa, slav))
}

/// Does the entry match what the master polls? (Pafe = 1 "wrong PKW/PZD data" otherwise.)
fn matches_master(e: &Entry, master: &Master) -> bool {
    e.layout.is_valid()
        && master.config().polling_list.iter().any(|p| {
            p.address == e.tnu && p.pkw.count() == e.layout.pkw && p.pzd_words == e.layout.pzd
        })
}

/// FC17 S_USST for the current slave (SLAV): parameter check (Pafe 2), transmit PZD to the
/// master, KSTW bit 0 → start the PKW job from the job buffer (status bit 3 on an invalid task),
/// KSTW bit 1 → acknowledge the change report (status bit 5 reset).
pub fn s_usst(dbs: &mut UssDbs, master: &mut Master, now: Instant) {
    let (_, e) = current(dbs);
    let n = e.kstw;
    let l = e.layout;
    let d = &mut dbs.dbnd;
    if !matches_master(&e, master) {
        d.set_byte(n + SlaveLayout::PAFE2, 1);
        return;
    }
    d.set_byte(n + SlaveLayout::PAFE2, 0);
    let pzd: Vec<u16> = (0..usize::from(l.pzd))
        .map(|k| d.word(n + l.tx_pzd() + 2 * k))
        .collect();
    let _ = master.set_control(e.tnu, &pzd);
    let mut kstw = d.word(n + SlaveLayout::KSTW);
    let mut status = d.word(n + SlaveLayout::COMM_STATUS);
    if kstw & 1 != 0 && l.pkw > 0 {
        let job = n + SlaveLayout::JOB_PKW;
        let pke = d.word(job);
        let ind = d.word(job + 2);
        let value = if l.pkw == 4 {
            (u32::from(d.word(job + 4)) << 16) | u32::from(d.word(job + 6))
        } else {
            u32::from(d.word(job + 4))
        };
        let request = ParamRequest {
            task: (pke >> 12) as u8,
            param: ParamAddress::join(pke & 0x7FF, ind),
            value,
        };
        match master.request_parameter(now, e.tnu, request) {
            // One job per slave: KSTW bit 0 stays set until the running job has ended.
            Err(RequestError::Busy(_)) => {}
            result => {
                kstw &= !1;
                // The job goes into the transmit buffer's PKW area as the manual's FC does.
                for k in 0..usize::from(l.pkw) {
                    let w = d.word(job + 2 * k);
                    d.set_word(n + l.tx_pkw() + 2 * k, w);
                }
                status &=
                    !(comm_status::PKW_DONE | comm_status::PKW_ERROR | comm_status::PKW_INVALID);
                status |= match result {
                    Ok(_) => comm_status::PKW_BUSY,
                    Err(_) => comm_status::PKW_INVALID,
                };
            }
        }
    }
    if kstw & 2 != 0 {
        kstw &= !2;
        status &= !comm_status::CHANGE_REPORT;
        let _ = master.acknowledge_change_report(e.tnu);
    }
    d.set_word(n + SlaveLayout::KSTW, kstw);
    d.set_word(n + SlaveLayout::COMM_STATUS, status);
}

/// FC18 S_USSR for the current slave: parameter check (Pafe 1), comm status and error words
/// from the master, the receive buffer only when the group error bit 9 is 0; then SLAV moves to
/// the next entry.
pub fn s_ussr(dbs: &mut UssDbs, master: &Master) {
    let (slav, e) = current(dbs);
    let n = e.kstw;
    let l = e.layout;
    let sanz = usize::from(dbs.dbpa.word(dbpa::SANZ)).clamp(1, 31);
    dbs.dbpa.set_word(dbpa::SLAV, (slav % sanz + 1) as u16);
    let d = &mut dbs.dbnd;
    let slave = match master.slave(e.tnu) {
        Some(s) if matches_master(&e, master) => s,
        _ => {
            d.set_byte(n + SlaveLayout::PAFE1, 1);
            return;
        }
    };
    d.set_byte(n + SlaveLayout::PAFE1, 0);
    // Bits the user acknowledges (5) stay until S_USST resets them; bit 3 is S_USST's own.
    let keep = d.word(n + SlaveLayout::COMM_STATUS) & comm_status::PKW_INVALID;
    d.set_word(n + SlaveLayout::COMM_STATUS, slave.comm_status | keep);
    d.set_word(n + SlaveLayout::COMM_ERROR, slave.comm_error);
    if slave.comm_status & comm_status::GROUP_ERROR != 0 {
        return;
    }
    // Response ID 0 ("no response", the answer to our AK 0 after a job) leaves the buffer as
    // it is, so the job's response stays readable after status bit 1 or 2 rises.
    if let Some(p) = slave.pkw_response.filter(|p| p.pke.ak() != 0) {
        let mut words = [0u16; 4];
        words[0] = p.pke.0;
        words[1] = p.ind;
        for (w, v) in words[2..].iter_mut().zip(p.pwe()) {
            *w = *v;
        }
        for (k, w) in words.iter().enumerate().take(usize::from(l.pkw)) {
            d.set_word(n + l.rx_pkw() + 2 * k, *w);
        }
    }
    for (k, w) in slave
        .status
        .words()
        .iter()
        .enumerate()
        .take(usize::from(l.pzd))
    {
        d.set_word(n + l.rx_pzd() + 2 * k, *w);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_reproduces_the_printed_table_for_pkw4_pzd16() {
        let l = SlaveLayout { pkw: 4, pzd: 16 };
        assert_eq!(
            (l.tx_pkw(), l.tx_pzd(), l.rx_pkw(), l.rx_pzd()),
            (20, 28, 60, 68)
        );
        assert_eq!(l.words(), 50);
        // [Modbus/USS] §3.7.7 example: PKW 3, PZD 2 → 19 words.
        assert_eq!(SlaveLayout { pkw: 3, pzd: 2 }.words(), 19);
    }

    #[test]
    fn s_ussi_checks_its_inputs_in_the_anz_order() {
        let ok = UssiParams {
            sanz: 3,
            tnu1: 1,
            pkw: 4,
            pzd: 2,
            dbnd: 10,
            dbpa: 11,
            dbcp: 12,
            wdh: 5,
        };
        assert_eq!(
            s_ussi(&UssiParams { sanz: 32, ..ok }, None),
            Err(Anz::TooManySlaves)
        );
        assert_eq!(
            s_ussi(&UssiParams { pkw: 2, ..ok }, None),
            Err(Anz::InvalidStructure)
        );
        assert_eq!(
            s_ussi(&UssiParams { tnu1: 30, ..ok }, None),
            Err(Anz::StationNumber)
        );
        assert_eq!(
            s_ussi(&UssiParams { wdh: -1, ..ok }, None),
            Err(Anz::RetryCounter)
        );
        let dbs = s_ussi(&ok, None).unwrap();
        // DBPA: 4 × 3 + 5 words; DBND: 1 + 3 × 22 words; DBCP 50 words.
        assert_eq!(dbs.dbpa.bytes.len(), 34);
        assert_eq!(dbs.dbnd.bytes.len(), 2 * (1 + 3 * 22));
        assert_eq!(dbs.dbpa.word(dbpa::SLAV), 1);
        assert_eq!(entry(&dbs.dbpa, 3).tnu, 3);
        assert_eq!(entry(&dbs.dbpa, 2).kstw, 2 + 44);
        let short = UssDbs {
            dbnd: Db::words(10),
            ..dbs.clone()
        };
        assert_eq!(s_ussi(&ok, Some(short)), Err(Anz::DbndTooShort));
        assert!(s_ussi(&ok, Some(dbs)).is_ok());
    }
}
