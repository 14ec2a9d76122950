//! A port that is already open: `tokio-serial` reports the lock it could not take as "no
//! device" (`NotFound`); we report it as `ResourceBusy`, naming who holds the port where the
//! system says so (Linux `/proc/locks`).

use std::io;

/// The error for `path`, whose lock is held: `ResourceBusy`, "port already open by …". A
/// handle of this program that was just dropped releases the port as soon as its driver task
/// runs (`close().await` waits for that).
pub(super) fn already_open(path: &str) -> io::Error {
    let by = holder(path).unwrap_or_else(|| "another handle or program".into());
    io::Error::new(
        io::ErrorKind::ResourceBusy,
        format!("cannot open {path}: port already open by {by}"),
    )
}

/// Is `message` the lock failure of `tokio-serial`'s open ("Unable to acquire shared lock on
/// serial port", "… exclusive lock …")?
pub(super) fn is_lock_failure(message: &str) -> bool {
    message.contains("acquire") && message.contains("lock on serial port")
}

/// Who holds the `flock` on `path`: "process 1234 (name)", or this program.
#[cfg(target_os = "linux")]
fn holder(path: &str) -> Option<String> {
    use std::os::unix::fs::MetadataExt;
    let inode = std::fs::metadata(path).ok()?.ino();
    let locks = std::fs::read_to_string("/proc/locks").ok()?;
    let pid = locks.lines().find_map(|line| lock_holder(line, inode))?;
    if pid == std::process::id() {
        return Some("this program (a handle not yet closed: await its close())".into());
    }
    let name = std::fs::read_to_string(format!("/proc/{pid}/comm")).unwrap_or_default();
    Some(format!("process {pid} ({})", name.trim()))
}

#[cfg(not(target_os = "linux"))]
fn holder(_path: &str) -> Option<String> {
    None
}

/// The PID of a `/proc/locks` line for a FLOCK on `inode`: "1: FLOCK  ADVISORY  WRITE 1234
/// 00:05:56 0 EOF" (the third field of the device triple is the inode, in decimal).
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
fn lock_holder(line: &str, inode: u64) -> Option<u32> {
    let mut fields = line.split_whitespace().skip(1);
    if fields.next()? != "FLOCK" {
        return None;
    }
    let pid: u32 = fields.nth(2)?.parse().ok()?;
    let file_inode: u64 = fields.next()?.rsplit(':').next()?.parse().ok()?;
    (file_inode == inode).then_some(pid)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flock_line_names_its_holder_for_its_inode_only() {
        let line = "1: FLOCK  ADVISORY  WRITE 4242 00:05:1187 0 EOF";
        assert_eq!(lock_holder(line, 1187), Some(4242));
        assert_eq!(lock_holder(line, 1188), None);
        let posix = "2: POSIX  ADVISORY  WRITE 17 fd:01:1187 0 EOF";
        assert_eq!(lock_holder(posix, 1187), None);
    }

    #[test]
    fn the_lock_failure_becomes_resource_busy() {
        assert!(is_lock_failure(
            "Unable to acquire shared lock on serial port"
        ));
        assert!(!is_lock_failure("No such file or directory"));
        let e = already_open("/nonexistent/tty");
        assert_eq!(e.kind(), io::ErrorKind::ResourceBusy);
        assert!(e.to_string().contains("port already open by"), "{e}");
    }
}
