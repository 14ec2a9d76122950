//! The FC equivalents S_USSI / S_USST / S_USSR over a simulated bus, called once per "PLC cycle"
//! in the mandatory order ([Modbus/USS] §3.7.3–§3.7.8).

use si_core::Duration;
use si_sim::{Simulator, StationId};
use si_uss::config::uss_settings;
use si_uss::drive::{stw, zsw, Drive, DriveConfig};
use si_uss::fb::{entry, master_config, s_ussi, s_ussr, s_usst, SlaveLayout, UssDbs, UssiParams};
use si_uss::master::{comm_error, comm_status, Master};

const L: SlaveLayout = SlaveLayout { pkw: 4, pzd: 2 };

struct Plant {
    sim: Simulator,
    m: StationId<Master>,
    dbs: UssDbs,
}

/// S_USSI for drives 1 and 2 (drive 2 silent), a master built from DBPA, both on a bus.
fn plant() -> Plant {
    let settings = uss_settings(9_600).unwrap();
    let dbs = s_ussi(
        &UssiParams {
            sanz: 2,
            tnu1: 1,
            pkw: 4,
            pzd: 2,
            dbnd: 10,
            dbpa: 11,
            dbcp: 12,
            wdh: 10,
        },
        None,
    )
    .unwrap();
    let mut config = master_config(&dbs.dbpa);
    config.settings = settings;
    config.local_echo = true;
    let mut sim = Simulator::new(11);
    let m = sim.add_station("master", settings, Master::new(config).unwrap());
    let mut members = vec![m.index()];
    for a in [1u8, 2] {
        let d = sim.add_station(
            &format!("drive{a}"),
            settings,
            Drive::new(DriveConfig {
                local_echo: true,
                ..DriveConfig::new(settings, a)
            })
            .unwrap(),
        );
        members.push(d.index());
        if a == 2 {
            sim.silence(d, si_core::Instant::ZERO);
        }
    }
    sim.bus(&members);
    sim.with(m, |m, now| m.start(now));
    Plant { sim, m, dbs }
}

impl Plant {
    /// One PLC cycle of 10 ms: S_USST, (the line runs), S_USSR.
    fn cycle(&mut self) {
        let dbs = &mut self.dbs;
        self.sim.with(self.m, |m, now| s_usst(dbs, m, now));
        self.sim.run_for(Duration::from_millis(10));
        let master = self.sim.engine(self.m);
        s_ussr(&mut self.dbs, master);
    }
    fn n(&self, slave: usize) -> usize {
        entry(&self.dbs.dbpa, slave).kstw
    }
}

#[test]
fn s6_7_net_data_db_carries_stw_hsw_out_and_zsw_hiw_in() {
    let mut p = plant();
    let n = p.n(1);
    p.dbs.dbnd.set_word(n + L.tx_pzd(), stw::RUN);
    p.dbs.dbnd.set_word(n + L.tx_pzd() + 2, 800);
    for _ in 0..40 {
        p.cycle();
    }
    let d = &p.dbs.dbnd;
    let zsw_word = d.word(n + L.rx_pzd());
    assert_ne!(zsw_word & zsw::RUNNING, 0, "{zsw_word:04X}");
    assert!(d.word(n + L.rx_pzd() + 2) > 0);
    assert_eq!(
        d.word(n + SlaveLayout::COMM_STATUS) & comm_status::GROUP_ERROR,
        0
    );
    assert_eq!(d.word(n + SlaveLayout::COMM_ERROR), 0);
    // The silent drive 2: group error and "telegram monitoring time exceeded".
    let n2 = p.n(2);
    assert_ne!(
        d.word(n2 + SlaveLayout::COMM_STATUS) & comm_status::GROUP_ERROR,
        0
    );
    assert_eq!(
        d.word(n2 + SlaveLayout::COMM_ERROR),
        comm_error::MONITORING_TIME
    );
    assert_eq!(
        d.word(n2 + L.rx_pzd()),
        0,
        "no data taken while bit 9 is set"
    );
}

#[test]
fn s6_7_kstw_bit_0_starts_a_pkw_job_and_status_bits_1_and_2_report_its_end() {
    let mut p = plant();
    let n = p.n(1);
    // Read P700: PKE = 1000H | 700.
    let job = n + SlaveLayout::JOB_PKW;
    p.dbs.dbnd.set_word(job, 0x1000 | 700);
    p.dbs.dbnd.set_word(n + SlaveLayout::KSTW, 1);
    p.cycle();
    assert_eq!(
        p.dbs.dbnd.word(n + SlaveLayout::KSTW) & 1,
        0,
        "S_USST resets KSTW bit 0"
    );
    for _ in 0..20 {
        p.cycle();
    }
    let d = &p.dbs.dbnd;
    assert_eq!(
        d.word(n + SlaveLayout::COMM_STATUS) & 0x7,
        comm_status::PKW_DONE
    );
    assert_eq!(d.word(n + L.rx_pkw()), 0x1000 | 700);
    assert_eq!(d.word(n + L.rx_pkw() + 6), 5);

    // Write P1082 := 1000 is over its limit: AK 7, error number 2 in PWE.
    p.dbs.dbnd.set_word(job, 0x2000 | 1082);
    p.dbs.dbnd.set_word(job + 6, 1000);
    p.dbs.dbnd.set_word(n + SlaveLayout::KSTW, 1);
    for _ in 0..20 {
        p.cycle();
    }
    let d = &p.dbs.dbnd;
    assert_eq!(
        d.word(n + SlaveLayout::COMM_STATUS) & 0x7,
        comm_status::PKW_ERROR
    );
    assert_eq!(d.word(n + L.rx_pkw()) >> 12, 7);
    assert_eq!(d.word(n + L.rx_pkw() + 6), 2);

    // Task 15 is invalid: status bit 3.
    p.dbs.dbnd.set_word(job, 0xF000 | 700);
    p.dbs.dbnd.set_word(n + SlaveLayout::KSTW, 1);
    p.cycle();
    p.cycle();
    assert_ne!(
        p.dbs.dbnd.word(n + SlaveLayout::COMM_STATUS) & comm_status::PKW_INVALID,
        0
    );
}

#[test]
fn s6_8_a_wrong_structure_in_dbpa_is_reported_in_pafe() {
    let mut p = plant();
    // Entry 1 claims PKW 3: deviates from what the master polls.
    p.dbs.dbpa.set_word(si_uss::fb::dbpa::structure(1), 0x0302);
    let n = p.n(1);
    p.cycle();
    assert_eq!(p.dbs.dbnd.byte(n + SlaveLayout::PAFE2), 1);
    assert_eq!(p.dbs.dbnd.byte(n + SlaveLayout::PAFE1), 1);
}
