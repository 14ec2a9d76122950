//! `si ports`: the serial ports the OS knows, with USB identity and the adapter's latency
//! timer (Linux), which decides how late received bytes reach the host; with `--port`, that
//! port's line-error counters; with `--check [PORT]`, what keeps a port from working
//! (`si_core::port::check`).

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use si_core::port::{self, PortInfo};

/// `si ports` arguments.
#[derive(Debug, clap::Args)]
pub struct PortsArgs {
    /// Check a port (PORT, or the one given with --port): that it exists, its driver, that
    /// you may open it, who else holds it, its latency timer, RS-485 mode, modem lines and
    /// line-error counters; each finding with its remedy. Exit code 0 when nothing is wrong,
    /// 1 otherwise.
    #[arg(long, value_name = "PORT", num_args = 0..=1, default_missing_value = "")]
    pub check: Option<String>,
    /// With --check: TX is wired to RX (or the other end of a pty echoes): round trips at each
    /// baud rate, the packets and hold measured, the echo present or not, and the parity and
    /// framing errors the driver counted meanwhile.
    #[arg(long, requires = "check")]
    pub loopback: bool,
    /// With --check: a second port wired to the first (its RX to the first's TX, a null-modem
    /// cable): whether parity errors are detected, sending with mark parity on the first and
    /// receiving expecting space on this one. Without it (or on a pseudo-terminal), --loopback
    /// reports that test as not testable.
    #[arg(long, requires = "check", value_name = "PATH")]
    pub loopback_peer: Option<String>,
}

impl PortsArgs {
    /// Check one port, or list them all.
    pub fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        match self.check {
            Some(path) => {
                let path = if path.is_empty() {
                    conn.port.clone().ok_or_else(|| {
                        CliError::usage("--check needs the port: --check PATH or --port PATH")
                    })?
                } else {
                    path
                };
                check(&path, self.loopback, self.loopback_peer.as_deref(), out)
            }
            None => run(conn, out),
        }
    }
}

/// One screen for one port: the findings, then exit 1 if any is a problem. With `loopback` the
/// round trips; with `loopback` or a `peer` the parity test (`si_core::port::parity_check`).
#[cfg(target_os = "linux")]
fn check(path: &str, loopback: bool, peer: Option<&str>, out: &Output) -> Result<(), CliError> {
    use si_core::port::check::{self, Severity};
    use si_core::port::parity_check::{parity_check, ParityCheck};
    let mut findings = check::check(path);
    let usable = !findings.iter().any(|f| f.severity == Severity::Problem);
    if loopback && usable {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()?;
        findings.extend(rt.block_on(si_core::port::loopback::loopback(path)));
    }
    let parity = ((loopback || peer.is_some()) && usable).then(|| parity_check(path, peer));
    if let Some(p) = &parity {
        findings.push(p.finding());
    }
    let problems = findings
        .iter()
        .filter(|f| f.severity == Severity::Problem)
        .count();
    if out.json {
        let mut report = serde_json::json!({
            "port": path,
            "ok": problems == 0,
            "findings": findings.iter().map(finding_json).collect::<Vec<_>>(),
        });
        if let Some(p) = &parity {
            // "yes", "no" or "not testable"; the counts where the test ran.
            report["parity_errors_detected"] = p.verdict().into();
            if let ParityCheck::Ran { sent, marks } = p {
                report["parity_test"] = serde_json::json!({
                    "sent": sent, "received": marks.received, "marked": marks.marked,
                });
            }
        }
        out.line("", report);
    } else {
        let mut text = format!("{path}\n");
        for f in &findings {
            text += &finding_text(f);
            text.push('\n');
        }
        text += &match problems {
            0 => "nothing wrong found".to_owned(),
            1 => "1 problem".to_owned(),
            n => format!("{n} problems"),
        };
        out.line(&text, serde_json::Value::Null);
    }
    match problems {
        0 => Ok(()),
        n => Err(CliError::new(format!(
            "{path}: {n} problem{} found",
            if n == 1 { "" } else { "s" }
        ))),
    }
}

/// `  PROBLEM  held open by …` and the remedy indented below it.
#[cfg(target_os = "linux")]
fn finding_text(f: &si_core::port::check::Finding) -> String {
    let mut s = format!("  {:<8} {}: {}", f.severity.label(), f.check, f.text);
    if let Some(r) = &f.remedy {
        s += &format!("\n           remedy: {r}");
    }
    s
}

/// The finding as a JSON object.
#[cfg(target_os = "linux")]
fn finding_json(f: &si_core::port::check::Finding) -> serde_json::Value {
    serde_json::json!({
        "check": f.check,
        "severity": f.severity.label().to_lowercase(),
        "text": f.text,
        "remedy": f.remedy,
    })
}

#[cfg(not(target_os = "linux"))]
fn check(path: &str, _: bool, _: Option<&str>, _: &Output) -> Result<(), CliError> {
    Err(CliError::new(format!(
        "{path}: --check reads /dev, /sys and /proc and needs Linux"
    )))
}

/// List serial ports, one per line (or JSON objects with `--json`). With `--port` and
/// `--latency-timer MS`, set that port's latency timer first; with `--port`, show its
/// line-error counters after the list.
fn run(conn: &Connection, out: &Output) -> Result<(), CliError> {
    if let Some(ms) = conn.latency_timer {
        let path = conn.port.as_deref().ok_or_else(|| {
            CliError::new("--latency-timer with `si ports` needs the port: --port PATH")
        })?;
        port::set_latency_timer(path, si_core::Duration::from_millis(ms))?;
    }
    let ports =
        port::list().map_err(|e| CliError::new(format!("cannot list serial ports: {e}")))?;
    if ports.is_empty() && !out.json {
        println!("no serial ports found");
    }
    for p in ports {
        out.line(&describe(&p), json(&p));
    }
    if let Some(path) = &conn.port {
        let (text, json) = counters(path)?;
        out.line(&text, json);
    }
    Ok(())
}

/// The port's line-error counters (`TIOCGICOUNT`): zero or not kept (a pseudo-terminal) is
/// no error; a port that cannot be opened is.
fn counters(path: &str) -> Result<(String, serde_json::Value), CliError> {
    match port::line_counters(path) {
        Ok(c) => Ok((
            format!(
                "{path}  line errors since the driver loaded: overrun {}, buffer overrun {}, \
                 parity {}, framing {}, break {}",
                c.overrun, c.buf_overrun, c.parity, c.frame, c.brk
            ),
            serde_json::json!({
                "port": path,
                "counters": {
                    "overrun": c.overrun, "buf_overrun": c.buf_overrun, "parity": c.parity,
                    "frame": c.frame, "brk": c.brk, "rx": c.rx, "tx": c.tx,
                },
            }),
        )),
        Err(e) if e.kind() == std::io::ErrorKind::Unsupported => Ok((
            format!("{path}  line-error counters: not supported by this port's driver"),
            serde_json::json!({ "port": path, "counters": null }),
        )),
        Err(e) => Err(CliError::new(e.to_string())),
    }
}

/// `/dev/ttyUSB0  usb 0403:6001 FTDI FT232R USB UART  latency 16 ms`.
fn describe(p: &PortInfo) -> String {
    let mut text = format!("{}  {}", p.path, p.kind);
    if let Some(u) = &p.usb {
        text += &format!(" {:04x}:{:04x}", u.vendor_id, u.product_id);
        for name in [&u.manufacturer, &u.product].into_iter().flatten() {
            text += &format!(" {name}");
        }
    }
    if let Some(latency) = p.latency_timer {
        text += &format!("  latency timer {} ms", latency.as_millis());
        if latency.as_millis() > 1 {
            text += " (si --latency-timer 1 … to lower it)";
        }
    }
    text
}

fn json(p: &PortInfo) -> serde_json::Value {
    serde_json::json!({
        "port": p.path,
        "type": p.kind,
        "usb": p.usb.as_ref().map(|u| serde_json::json!({
            "vid": u.vendor_id,
            "pid": u.product_id,
            "manufacturer": u.manufacturer,
            "product": u.product,
            "serial_number": u.serial_number,
        })),
        "latency_timer_ms": p.latency_timer.map(|l| l.as_millis()),
    })
}
