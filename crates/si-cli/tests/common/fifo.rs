//! A FIFO standing in for a GPIO's sysfs `value` file (RS-485 direction control, `--rs485
//! sysfs`): the test reads every level written, in order, where a real `value` file would only
//! hold the last.

use std::io::Read;
use std::path::Path;
use std::sync::mpsc::Receiver;

/// Make a FIFO at `path` (`mkfifo`, coreutils), replacing what was there.
pub fn mkfifo(path: &Path) {
    let _ = std::fs::remove_file(path);
    let made = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("run mkfifo");
    assert!(made.success(), "mkfifo {}", path.display());
}

/// Everything written into the FIFO at `path` until its writer closes it, read on a thread of
/// its own (opening a FIFO waits for the other end, so start this before the writer).
pub fn drain(path: &Path) -> Receiver<String> {
    let (tx, rx) = std::sync::mpsc::channel();
    let path = path.to_owned();
    std::thread::spawn(move || {
        let mut text = String::new();
        std::fs::File::open(&path)
            .expect("open the FIFO")
            .read_to_string(&mut text)
            .expect("read the FIFO");
        let _ = tx.send(text);
    });
    rx
}
