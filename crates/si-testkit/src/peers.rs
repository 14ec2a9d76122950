//! External test peers (socat, pymodbus, mbpoll, …): whether one is there, and a child process
//! that ends with the test.
//!
//! A missing peer skips its test with a message saying how to install it; with the environment
//! variable `CI` set it is a failure instead, so a CI image without the peer cannot pass by
//! skipping (`.ci/run` installs every peer).

use std::process::{Child, Command, Stdio};

/// Is the external program `name` runnable (`check` exits 0)? See the module doc for what
/// happens when it is not.
pub fn peer(name: &str, check: &mut Command, install: &str) -> bool {
    let ok = check
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if ok {
        return true;
    }
    if std::env::var_os("CI").is_some() {
        panic!("test peer {name} is missing and CI is set; install it with: {install}");
    }
    eprintln!("SKIPPED: test peer {name} is not installed ({install})");
    false
}

/// Is `socat` (the pseudo-terminal pairs of the pty tests) installed?
pub fn have_socat() -> bool {
    peer(
        "socat",
        Command::new("socat").arg("-V"),
        "apt-get install socat",
    )
}

/// Is pymodbus importable by `python3` (Modbus TCP peers)?
pub fn have_pymodbus() -> bool {
    peer(
        "pymodbus",
        Command::new("python3").args(["-c", "import pymodbus"]),
        "pip install pymodbus==3.16.1",
    )
}

/// Are pymodbus and pyserial importable by `python3` (Modbus RTU peers on a serial port)?
pub fn have_pymodbus_serial() -> bool {
    peer(
        "pymodbus",
        Command::new("python3").args(["-c", "import pymodbus, serial"]),
        "pip install pymodbus==3.16.1 pyserial==3.5",
    )
}

/// Is `mbpoll` (libmodbus's command-line master) installed?
pub fn have_mbpoll() -> bool {
    peer(
        "mbpoll",
        Command::new("mbpoll").arg("-V"),
        "apt-get install mbpoll",
    )
}

/// The values mbpoll printed, one per `[ref]: \tvalue` line, in order.
pub fn mbpoll_values(o: &std::process::Output) -> Vec<String> {
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter(|l| l.starts_with('['))
        .filter_map(|l| l.split(':').nth(1))
        .map(|v| v.trim().to_string())
        .collect()
}

/// A child process killed and reaped when dropped, so a failing test leaves no peer behind.
#[derive(Debug)]
pub struct Kill(pub Child);

impl Drop for Kill {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}
