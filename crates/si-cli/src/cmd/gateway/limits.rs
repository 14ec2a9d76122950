//! The open-file limit of a gateway with many lines (1,000 lines in one process).
//!
//! Every line holds a descriptor (its serial port, or the socket to its device server), every
//! listening address one, and every client connection one. Most Linux systems start a process
//! with a soft `RLIMIT_NOFILE` of 1,024 and a hard one far higher (systemd: 524,288), so a
//! gateway with 1,000 lines would fail half-way through opening its ports. At start the gateway
//! raises its soft limit to the hard one, as servers commonly do (nginx's
//! `worker_rlimit_nofile`, systemd's `LimitNOFILE=`); if even the hard limit is below what the
//! configuration needs, it stops before opening anything, naming the limit and how to raise it.
//! Client connections beyond what is left are refused by the TCP server, which pauses and
//! retries its accept (si-modbus `tokio::tcp`), so only the lower bound is checked here.

use crate::error::CliError;
use si_gateway::config::{Device, Gateway};

/// Descriptors a process has open before the gateway opens any line: stdin, stdout, stderr,
/// the runtime's epoll and wake-up descriptors, the Ctrl-C signal pipe, with room to spare.
const RUNTIME_DESCRIPTORS: u64 = 32;

/// The largest soft limit we ask for: Linux's default `fs.nr_open` (2^20), above which
/// `setrlimit` fails even when the hard limit is unlimited.
const NR_OPEN_DEFAULT: u64 = 1 << 20;

/// Descriptors per line on a serial port: si-core opens the tty twice on Linux, the stream and
/// a second handle for termios and RS-485 (`si_core::port`); a device-server line has one socket.
const PORT_DESCRIPTORS: u64 = 2;

/// Descriptors the gateway needs at least: for each line its port's or socket's, one per
/// listening address, the connections one listener may hold, and the runtime's own.
pub fn descriptors_needed(gw: &Gateway, listeners: usize) -> u64 {
    let lines: u64 = gw
        .lines
        .iter()
        .map(|l| match l.device {
            // A sysfs RS-485 direction file stays open with its port.
            Device::Port(_) => PORT_DESCRIPTORS + u64::from(l.rs485_file.is_some()),
            Device::Tcp(_) => 1,
        })
        .sum();
    lines + (listeners + gw.max_connections) as u64 + RUNTIME_DESCRIPTORS
}

/// What to do with the limits `soft` and `hard` for `needed` descriptors: `Ok(Some(new
/// soft))` to raise the soft limit, `Ok(None)` to leave it, or the error when the hard limit
/// is too low.
fn plan(soft: u64, hard: u64, needed: u64) -> Result<Option<u64>, String> {
    let target = hard.min(NR_OPEN_DEFAULT);
    if target < needed {
        return Err(format!(
            "the configuration needs at least {needed} open files (two per serial line, three with an rs485_file, one per \
             device-server line, listener and connection), but the hard limit RLIMIT_NOFILE is {hard}: raise it (e.g. \
             `ulimit -Hn {needed}` as root, LimitNOFILE={needed} in a systemd unit, or \
             nofile in /etc/security/limits.conf), or serve fewer lines per process"
        ));
    }
    Ok((soft < target).then_some(target))
}

/// Raise the soft open-file limit to the hard one; an error naming the limit when even the
/// hard one is below `needed`. Returns the soft limit in force afterwards.
#[cfg(unix)]
pub fn raise_open_files(needed: u64) -> Result<u64, CliError> {
    use nix::sys::resource::{getrlimit, setrlimit, Resource};
    let (soft, hard) = getrlimit(Resource::RLIMIT_NOFILE)
        .map_err(|e| CliError::new(format!("cannot read RLIMIT_NOFILE: {e}")))?;
    match plan(soft, hard, needed).map_err(CliError::new)? {
        Some(target) => {
            setrlimit(Resource::RLIMIT_NOFILE, target, hard).map_err(|e| {
                CliError::new(format!(
                    "cannot raise RLIMIT_NOFILE from {soft} to {target}: {e}"
                ))
            })?;
            Ok(target)
        }
        None => Ok(soft),
    }
}

/// Elsewhere the limit is the system's business; nothing to raise.
#[cfg(not(unix))]
pub fn raise_open_files(needed: u64) -> Result<u64, CliError> {
    Ok(needed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_soft_limit_is_raised_to_the_hard_one() {
        assert_eq!(plan(1024, 524_288, 1100), Ok(Some(524_288)));
        assert_eq!(plan(1024, 4096, 100), Ok(Some(4096)));
    }

    #[test]
    fn a_soft_limit_at_the_hard_one_is_left() {
        assert_eq!(plan(20_000, 20_000, 1100), Ok(None));
    }

    #[test]
    fn an_unlimited_hard_limit_asks_for_linux_nr_open_only() {
        assert_eq!(plan(1024, u64::MAX, 1100), Ok(Some(1 << 20)));
    }

    #[test]
    fn a_hard_limit_below_the_need_names_the_limit_and_the_remedy() {
        let e = plan(1024, 1024, 1100).unwrap_err();
        assert!(e.contains("at least 1100 open files"), "{e}");
        assert!(e.contains("RLIMIT_NOFILE is 1024"), "{e}");
        assert!(e.contains("ulimit -Hn 1100"), "{e}");
    }

    /// The checked gateway of TOML `text`.
    fn check(text: &str) -> Gateway {
        si_gateway::config::File::from_toml(text)
            .unwrap()
            .check()
            .unwrap()
    }

    #[test]
    fn a_port_line_needs_two_descriptors_and_a_device_server_line_one() {
        let toml = "listen = \"127.0.0.1:5020\"\n\
                    [[line]]\ndevice = \"/dev/ttyS0\"\nunits = \"1\"\n\
                    [[line]]\ndevice = \"tcp:127.0.0.1:4001\"\nunits = \"2\"\n";
        let gw = check(toml);
        // 2 + 1 for the lines, 1 listener, mbusd's 32 connections, the runtime's 32.
        assert_eq!(descriptors_needed(&gw, 1), 68);
        // A sysfs direction file stays open with its port: one more.
        let sysfs = "rs485 = \"sysfs\"\nrs485_file = \"/sys/class/gpio/gpio17/value\"\n";
        let with_file = toml.replace("units = \"1\"\n", &format!("units = \"1\"\n{sysfs}"));
        let gw = check(&with_file);
        assert_eq!(descriptors_needed(&gw, 1), 69);
    }

    #[cfg(unix)]
    #[test]
    fn raising_leaves_the_soft_limit_at_least_the_need() {
        let soft = raise_open_files(64).unwrap();
        assert!(soft >= 64);
    }
}
