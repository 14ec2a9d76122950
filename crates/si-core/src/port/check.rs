//! A port check (`si ports --check PORT`): what stands between a user and a working serial port, each finding
//! with its remedy. Most questions about serial tools are about setup, not protocol: the wrong
//! device, no permission, the port held by another program (ModemManager, a getty), an
//! adapter's latency timer, RS-485 direction control.
//!
//! Everything is read from the system (Linux: `/dev`, `/sys/class/tty`, `/proc`) and from the
//! port itself, opened without becoming a controlling terminal and without waiting for a
//! carrier; nothing is changed.

use std::fs;
use std::io;
use std::os::unix::fs::{FileTypeExt, MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

/// How much a finding matters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    /// As it should be.
    Ok,
    /// Worth knowing; si works with it.
    Note,
    /// Keeps si (or any program) from using the port: the check exits 1.
    Problem,
}

impl Severity {
    /// How a report names it: `ok`, `note`, `PROBLEM`.
    pub fn label(self) -> &'static str {
        match self {
            Severity::Ok => "ok",
            Severity::Note => "note",
            Severity::Problem => "PROBLEM",
        }
    }
}

/// One thing the check found.
#[derive(Debug, Clone)]
pub struct Finding {
    /// What was checked: `device`, `driver`, `access`, `holders`, `latency timer`, `rs485`,
    /// `modem lines`, `line errors`; with the loopback `loopback`, `echo`, `parity`.
    pub check: &'static str,
    /// How much it matters.
    pub severity: Severity,
    /// What was found.
    pub text: String,
    /// What to do about it, where something can be done.
    pub remedy: Option<String>,
}

impl Finding {
    /// A finding without a remedy.
    pub fn new(check: &'static str, severity: Severity, text: impl Into<String>) -> Self {
        Finding {
            check,
            severity,
            text: text.into(),
            remedy: None,
        }
    }

    /// The finding with what to do about it.
    pub fn remedy(mut self, remedy: impl Into<String>) -> Self {
        self.remedy = Some(remedy.into());
        self
    }
}

/// Check the port at `path`: the findings in the order a user would fix them.
pub fn check(path: &str) -> Vec<Finding> {
    let mut findings = Vec::new();
    let meta = match fs::metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            findings.push(
                Finding::new(
                    "device",
                    Severity::Problem,
                    format!("{path} does not exist"),
                )
                .remedy(
                    "`si ports` lists this machine's ports: a USB adapter is /dev/ttyUSB* or \
                         /dev/ttyACM* (named for good by /dev/serial/by-id/…), an on-board port \
                         /dev/ttyS*; is the adapter plugged in (dmesg | tail)?",
                ),
            );
            return findings;
        }
        Err(e) => {
            findings.push(Finding::new(
                "device",
                Severity::Problem,
                format!("cannot look at {path}: {e}"),
            ));
            return findings;
        }
    };
    if !meta.file_type().is_char_device() {
        findings.push(
            Finding::new(
                "device",
                Severity::Problem,
                format!("{path} is not a character device (no serial port)"),
            )
            .remedy("name the device node, e.g. /dev/ttyUSB0; `si ports` lists them"),
        );
        return findings;
    }
    let real = fs::canonicalize(path).unwrap_or_else(|_| PathBuf::from(path));
    let name = real
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let pty = is_pseudo_terminal(path);
    findings.push(Finding::new(
        "device",
        Severity::Ok,
        if real.as_os_str() == path {
            format!("{path} is a character device")
        } else {
            format!("{path} is a character device ({})", real.display())
        },
    ));
    findings.push(driver(&name, pty));
    let access = access(path, &meta);
    let opened = access.severity == Severity::Ok;
    findings.push(access);
    findings.extend(holders(&real, pty));
    if let Some(f) = latency(&name) {
        findings.push(f);
    }
    if opened {
        findings.push(rs485(path, pty));
        findings.push(modem_lines(path, pty));
        findings.push(line_errors(path));
    }
    findings
}

/// Whether `path` (a link followed) is a pseudo-terminal: under `/dev/pts`, or a character device
/// of the majors Linux gives Unix 98 pty slaves (136–143). A pseudo-terminal has no
/// wire and no parity bits: what it is told of parity it drops or ignores.
pub fn is_pseudo_terminal(path: &str) -> bool {
    let real = fs::canonicalize(path).unwrap_or_else(|_| PathBuf::from(path));
    if real.starts_with("/dev/pts") || real == Path::new("/dev/ptmx") {
        return true;
    }
    fs::metadata(&real).is_ok_and(|m| {
        let dev = m.rdev();
        // The major number's bits of a Linux dev_t (glibc's gnu_dev_major).
        let major = ((dev >> 8) & 0xfff) | ((dev >> 32) & !0xfff);
        m.file_type().is_char_device() && (136..=143).contains(&major)
    })
}

/// Which kernel driver serves the port, from `/sys/class/tty/<name>/device/driver`.
fn driver(name: &str, pty: bool) -> Finding {
    if pty {
        return Finding::new(
            "driver",
            Severity::Ok,
            "pseudo-terminal (no hardware: bytes arrive as the other end writes them)",
        );
    }
    let class = Path::new("/sys/class/tty").join(name);
    let Some(driver) = fs::read_link(class.join("device/driver"))
        .ok()
        .and_then(|l| l.file_name().map(|n| n.to_string_lossy().into_owned()))
    else {
        return Finding::new("driver", Severity::Note, "no driver named in sysfs");
    };
    let what = match driver.as_str() {
        "ftdi_sio" => "FTDI USB adapter: hands received bytes over in packets, at the latest when its latency timer runs out",
        "cp210x" | "ch341" | "pl2303" => "USB adapter without a latency timer in sysfs: received bytes come in packets whose hold the port does not announce",
        "cdc_acm" => "USB CDC-ACM device (often the device's own USB port rather than an RS-232/485 adapter)",
        d if d.starts_with("serial8250") || d == "8250" || d == "serial" => "16550-compatible UART: a receive FIFO hands bytes over at its trigger level or after about 4 character times",
        _ => "",
    };
    // An 8250 port without a UART behind it: the kernel makes ttyS0…ttyS3 whether or not one is
    // fitted, and reports its type as 0 (unknown).
    let no_uart = fs::read_to_string(class.join("type")).is_ok_and(|t| t.trim() == "0");
    if no_uart {
        return Finding::new(
            "driver",
            Severity::Problem,
            format!("{driver}: no UART behind {name} (type unknown)"),
        )
        .remedy(
            "the wrong device: the kernel makes ttyS0 … ttyS3 whether or not a UART is fitted; \
             `si ports` lists the real ones, `dmesg | grep tty` shows which were found",
        );
    }
    let text = if what.is_empty() {
        driver
    } else {
        format!("{driver} ({what})")
    };
    Finding::new("driver", Severity::Ok, text)
}

/// May this user open the port read-write? Tried, not guessed from the mode bits (root may open
/// anything; a port held exclusively refuses even root).
fn access(path: &str, meta: &fs::Metadata) -> Finding {
    let opened = fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(libc::O_NOCTTY | libc::O_NONBLOCK)
        .open(path);
    let who = format!("uid {}", effective_uid());
    match opened {
        Ok(_) => Finding::new(
            "access",
            Severity::Ok,
            format!("may be opened read-write ({who})"),
        ),
        Err(e) if e.kind() == io::ErrorKind::PermissionDenied => {
            let group = group_name(meta.gid()).unwrap_or_else(|| meta.gid().to_string());
            let member = own_groups().contains(&meta.gid());
            // The group gives read and write, and is not root's: joining it is the remedy.
            let group_helps = meta.mode() & 0o060 == 0o060 && meta.gid() != 0;
            Finding::new(
                "access",
                Severity::Problem,
                format!(
                    "permission denied: mode {:04o}, owner uid {}, group {group}; {who} is {}in \
                     group {group}",
                    meta.mode() & 0o7777,
                    meta.uid(),
                    if member { "" } else { "not " }
                ),
            )
            .remedy(if member || !group_helps {
                "the port's group may not read and write it: a udev rule can give it to a \
                 group you are in, e.g. GROUP=\"dialout\", MODE=\"0660\""
                    .to_owned()
            } else {
                format!(
                    "add yourself to the port's group: sudo usermod -aG {group} $USER, then log \
                     in again (groups take effect at login)"
                )
            })
        }
        Err(e) if e.raw_os_error() == Some(libc::EBUSY) => Finding::new(
            "access",
            Severity::Problem,
            "busy: another program holds the port exclusively",
        )
        .remedy("end that program (the holders below), or use another port"),
        Err(e) => Finding::new("access", Severity::Problem, format!("cannot open it: {e}")).remedy(
            "a port that is there but cannot be opened (no such device or address, I/O \
                 error) has no hardware behind it or a failing driver: dmesg | tail",
        ),
    }
}

/// Who else holds the port open, from `/proc/*/fd`. On a pseudo-terminal the program that made
/// it (it holds the master, `/dev/ptmx`, with this `tty-index`) is the other end, not a problem.
fn holders(real: &Path, pty: bool) -> Vec<Finding> {
    let own = std::process::id().to_string();
    let index = pty
        .then(|| real.file_name().map(|n| n.to_string_lossy().into_owned()))
        .flatten();
    let Ok(procs) = fs::read_dir("/proc") else {
        return vec![Finding::new(
            "holders",
            Severity::Note,
            "cannot read /proc: other holders unknown",
        )];
    };
    let mut found = Vec::new();
    let mut unreadable = 0;
    for entry in procs.flatten() {
        let pid = entry.file_name().to_string_lossy().into_owned();
        if !pid.bytes().all(|b| b.is_ascii_digit()) || pid == own {
            continue;
        }
        let dir = entry.path();
        let Ok(fds) = fs::read_dir(dir.join("fd")) else {
            unreadable += 1;
            continue;
        };
        let mut holds = false;
        let mut masters = false;
        for fd in fds.flatten() {
            let Ok(target) = fs::read_link(fd.path()) else {
                continue;
            };
            if target == real {
                holds = true;
            } else if let Some(index) = &index {
                if target.ends_with("ptmx") {
                    let info = fs::read_to_string(dir.join("fdinfo").join(fd.file_name()))
                        .unwrap_or_default();
                    masters |= info
                        .lines()
                        .any(|l| l.strip_prefix("tty-index:").map(str::trim) == Some(index));
                }
            }
        }
        if !(holds || masters) {
            continue;
        }
        let comm = fs::read_to_string(dir.join("comm"))
            .map(|c| c.trim().to_owned())
            .unwrap_or_default();
        let cmdline = fs::read(dir.join("cmdline"))
            .map(|c| {
                String::from_utf8_lossy(&c)
                    .split('\0')
                    .filter(|s| !s.is_empty())
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .unwrap_or_default();
        if masters {
            found.push(Finding::new(
                "holders",
                Severity::Ok,
                format!("the other end is held by {pid} {comm} ({cmdline}), which made the pseudo-terminal"),
            ));
        } else {
            found.push(
                Finding::new(
                    "holders",
                    Severity::Problem,
                    format!("held open by {pid} {comm} ({cmdline})"),
                )
                .remedy(holder_remedy(&pid, &comm, real)),
            );
        }
    }
    if found.is_empty() && unreadable > 0 {
        found.push(
            Finding::new(
                "holders",
                Severity::Note,
                format!(
                    "none among the processes this user may look at; {unreadable} others \
                     cannot be looked at"
                ),
            )
            .remedy("to see every holder: sudo si ports --check …"),
        );
    } else if found.is_empty() {
        found.push(Finding::new(
            "holders",
            Severity::Ok,
            "no other program holds it open",
        ));
    }
    found
}

/// What to do about a program that holds the port, for the usual suspects.
fn holder_remedy(pid: &str, comm: &str, real: &Path) -> String {
    let name = real
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    match comm {
        "ModemManager" => "ModemManager probes serial ports for modems: stop it (sudo systemctl \
                           stop ModemManager) or keep it off this port with a udev rule \
                           ENV{ID_MM_DEVICE_IGNORE}=\"1\""
            .to_owned(),
        c if c.ends_with("getty") => format!(
            "a login prompt runs on the port: sudo systemctl stop serial-getty@{name}.service \
             (and disable it to keep it off)"
        ),
        "brltty" => "brltty takes USB serial adapters for braille displays: sudo systemctl stop \
                     brltty, or remove it if no braille display is used"
            .to_owned(),
        "gpsd" => {
            "gpsd watches serial ports for GPS receivers: sudo systemctl stop gpsd".to_owned()
        }
        _ => format!("end it (kill {pid}) or use another port"),
    }
}

/// The USB adapter's latency timer and whether this user may change it.
fn latency(name: &str) -> Option<Finding> {
    let file = Path::new("/sys/bus/usb-serial/devices")
        .join(name)
        .join("latency_timer");
    let ms: u64 = fs::read_to_string(&file).ok()?.trim().parse().ok()?;
    let writable = fs::OpenOptions::new().write(true).open(&file).is_ok();
    let text = format!(
        "{ms} ms: received bytes reach si up to {ms} ms late (si allows for it); {}",
        if writable {
            "writable"
        } else {
            "not writable by this user"
        }
    );
    let finding = Finding::new("latency timer", Severity::Note, text);
    Some(match (ms > 1, writable) {
        (true, true) => finding.remedy(format!(
            "lower it for exact frame ends: si --port /dev/{name} --latency-timer 1 ports"
        )),
        (true, false) => finding.remedy(
            "as root: si --port … --latency-timer 1 ports, or for good a udev rule \
             ATTR{latency_timer}=\"1\"",
        ),
        _ => Finding {
            severity: Severity::Ok,
            ..finding
        },
    })
}

/// The kernel's RS-485 mode (`TIOCGRS485`).
fn rs485(path: &str, pty: bool) -> Finding {
    match crate::port::kernel_rs485(path) {
        Ok(true) => Finding::new("rs485", Severity::Ok, "the kernel's RS-485 mode is on"),
        Ok(false) => Finding::new(
            "rs485",
            Severity::Ok,
            "the kernel's RS-485 mode is available (si --rs485 kernel)",
        ),
        Err(_) if pty => Finding::new(
            "rs485",
            Severity::Ok,
            "none (a pseudo-terminal has no transceiver)",
        ),
        Err(e) if e.kind() == io::ErrorKind::Unsupported => Finding::new(
            "rs485",
            Severity::Note,
            "the port's driver has no kernel RS-485 mode",
        )
        .remedy(
            "on a two-wire bus use an adapter that switches direction by itself, or let si \
             switch RTS (--rs485 rts)",
        ),
        Err(e) => Finding::new("rs485", Severity::Note, format!("cannot tell: {e}")),
    }
}

/// The modem inputs as they are now.
fn modem_lines(path: &str, pty: bool) -> Finding {
    match crate::port::modem_inputs(path) {
        Ok([cts, dsr, dcd, ri]) => {
            let on = |b: bool| if b { "on" } else { "off" };
            Finding::new(
                "modem lines",
                Severity::Ok,
                format!(
                    "CTS {}, DSR {}, DCD {}, RI {}",
                    on(cts),
                    on(dsr),
                    on(dcd),
                    on(ri)
                ),
            )
        }
        Err(_) if pty => Finding::new("modem lines", Severity::Ok, "none (a pseudo-terminal)"),
        Err(e) => Finding::new(
            "modem lines",
            Severity::Note,
            format!("cannot read them: {e}"),
        ),
    }
}

/// The UART driver's line-error counters (`TIOCGICOUNT`): characters lost to overruns show
/// nowhere else.
fn line_errors(path: &str) -> Finding {
    match crate::port::line_counters(path) {
        Ok(c) => {
            let text = format!(
                "since the driver loaded: overrun {}, buffer overrun {}, parity {}, framing {}, \
                 break {} ({} received, {} sent)",
                c.overrun, c.buf_overrun, c.parity, c.frame, c.brk, c.rx, c.tx
            );
            if c.lost() > 0 {
                Finding::new("line errors", Severity::Note, text).remedy(
                    "characters were lost (the host read too late): a lower latency timer, \
                     fewer programs on the CPU, or a lower baud rate",
                )
            } else {
                Finding::new("line errors", Severity::Ok, text)
            }
        }
        Err(e) if e.kind() == io::ErrorKind::Unsupported => Finding::new(
            "line errors",
            Severity::Ok,
            "no counters kept by this port's driver (overruns cannot be seen)",
        ),
        Err(e) => Finding::new(
            "line errors",
            Severity::Note,
            format!("cannot read them: {e}"),
        ),
    }
}

/// This process's effective user id, from `/proc/self/status`.
fn effective_uid() -> u32 {
    proc_status_ids("Uid:").get(1).copied().unwrap_or(u32::MAX)
}

/// This process's supplementary groups and its effective group.
fn own_groups() -> Vec<u32> {
    let mut groups = proc_status_ids("Groups:");
    groups.extend(proc_status_ids("Gid:").get(1));
    groups
}

/// The numbers on the line `key` of `/proc/self/status`.
fn proc_status_ids(key: &str) -> Vec<u32> {
    fs::read_to_string("/proc/self/status")
        .unwrap_or_default()
        .lines()
        .find_map(|l| l.strip_prefix(key).map(str::to_owned))
        .map(|rest| {
            rest.split_whitespace()
                .filter_map(|n| n.parse().ok())
                .collect()
        })
        .unwrap_or_default()
}

/// A group's name from `/etc/group`.
fn group_name(gid: u32) -> Option<String> {
    fs::read_to_string("/etc/group")
        .ok()?
        .lines()
        .find_map(|l| {
            let mut fields = l.split(':');
            let name = fields.next()?;
            let id: u32 = fields.nth(1)?.parse().ok()?;
            (id == gid).then(|| name.to_owned())
        })
}
