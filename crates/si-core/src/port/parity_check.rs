//! Whether a port detects parity errors (`si ports --check PORT --loopback-peer PEER`): a known
//! pattern goes out on `PORT` with mark parity (`PARENB | CMSPAR | PARODD`) and is read on
//! `PEER`, wired to it (PORT's TX to PEER's RX, a null-modem cable), expecting space parity
//! (`PARENB | CMSPAR`, parity checked with `INPCK`) and marking bad characters in the stream
//! (`PARMRK`). Every character then carries the wrong parity bit: a receiver that detects
//! parity errors marks each one `FFH 00H x`; one that does not hands the bytes over clean.
//!
//! One UART cannot do this alone: it sends with the parity it checks. A pseudo-terminal cannot
//! at all: it has no wire and no parity bits. Either way the check says "not testable", with
//! the reason and what to wire, never a "yes" it has not seen. How the marked stream reads is
//! [`judge`], a pure function (bytes in, verdict out).
//!
//! The ports are opened through `serial2`'s safe calls, the termios flags set on its raw termios
//! (`libc` constants), as the port module does for mark/space parity and line-error marking.

use crate::port::check::{is_pseudo_terminal, Finding, Severity};
use std::io;
use std::time::{Duration, Instant};

/// The rate the pattern goes at: one every port has.
const BAUD: u32 = 9600;

/// The pattern: bytes without FFH and 00H (the marking's escape bytes), so every character
/// reads the same marked or not.
const PATTERN: [u8; 32] = [
    0x55, 0xAA, 0x01, 0x02, 0x10, 0x20, 0x40, 0x80, 0x7F, 0xFE, 0x3C, 0xC3, 0x0F, 0xF0, 0x11, 0x22,
    0x33, 0x44, 0x5A, 0xA5, 0x66, 0x99, 0x77, 0x88, 0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0xDE, 0x21,
];

/// What a stream marked with `PARMRK` says: how many characters came, how many of them marked
/// bad (`FFH 00H x`: a parity or framing error on `x`, or a BREAK as `x` = 00H).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Marks {
    /// Characters received, marked or not (an escaped `FFH FFH` is one, a data FFH).
    pub received: usize,
    /// Of them, marked bad.
    pub marked: usize,
}

impl Marks {
    /// Whether parity errors were detected: at least one character marked.
    pub fn detected(&self) -> bool {
        self.marked > 0
    }
}

/// Read a `PARMRK` stream (termios(3)): `FFH FFH` is a data FFH, `FFH 00H x` a character `x`
/// received with a parity or framing error, any other byte a character. An incomplete mark at
/// the end (a read cut short) counts as no mark: the judgement never says "detected" for what it
/// has not seen whole.
pub fn judge(stream: &[u8]) -> Marks {
    let mut m = Marks::default();
    let mut i = 0;
    while i < stream.len() {
        match (stream[i], stream.get(i + 1), stream.get(i + 2)) {
            (0xFF, Some(0xFF), _) => i += 2,
            (0xFF, Some(0x00), Some(_)) => {
                m.marked += 1;
                i += 3;
            }
            // FFH 00H cut off before its character: not counted at all.
            (0xFF, Some(0x00), None) => break,
            _ => i += 1,
        }
        m.received += 1;
    }
    m
}

/// The outcome of the parity test.
#[derive(Debug)]
pub enum ParityCheck {
    /// The test ran: what came back on the peer.
    Ran {
        /// The characters sent.
        sent: usize,
        /// What the peer's stream said.
        marks: Marks,
    },
    /// The test cannot be made here; why.
    NotTestable(String),
    /// A port could not be opened or set up.
    Failed(String),
}

impl ParityCheck {
    /// `yes`, `no` or `not testable` (also when the test failed: nothing was seen).
    pub fn verdict(&self) -> &'static str {
        match self {
            ParityCheck::Ran { marks, .. } if marks.detected() => "yes",
            ParityCheck::Ran { marks, .. } if marks.received > 0 => "no",
            _ => "not testable",
        }
    }

    /// The check's finding, with its remedy.
    pub fn finding(&self) -> Finding {
        let wire = "wire two ports, this one's TX to the other's RX (a null-modem cable), and \
                    give the second with --loopback-peer PATH";
        match self {
            ParityCheck::NotTestable(why) => Finding::new(
                "parity",
                Severity::Note,
                format!("parity errors detected: not testable ({why})"),
            )
            .remedy(wire),
            ParityCheck::Failed(why) => Finding::new(
                "parity",
                Severity::Problem,
                format!("parity errors detected: not testable ({why})"),
            )
            .remedy(wire),
            ParityCheck::Ran { sent, marks } if marks.received == 0 => Finding::new(
                "parity",
                Severity::Problem,
                format!(
                    "parity errors detected: not testable (none of {sent} bytes reached the peer)"
                ),
            )
            .remedy(wire),
            ParityCheck::Ran { marks, .. } => {
                let text = format!(
                    "parity errors detected: {} ({} of {} bytes marked; sent with mark parity, \
                     received expecting space)",
                    self.verdict(),
                    marks.marked,
                    marks.received
                );
                if marks.detected() {
                    Finding::new("parity", Severity::Ok, text)
                } else {
                    Finding::new("parity", Severity::Problem, text).remedy(
                        "the port hands characters with a wrong parity bit over as good ones: a \
                         protocol with parity cannot see a corrupt character on it; use an \
                         adapter whose driver takes CMSPAR and PARMRK",
                    )
                }
            }
        }
    }
}

/// Run the test from `path` to `peer` (`None`: no peer given).
pub fn parity_check(path: &str, peer: Option<&str>) -> ParityCheck {
    if is_pseudo_terminal(path) {
        return ParityCheck::NotTestable(format!(
            "{path} is a pseudo-terminal: no wire, no parity bits"
        ));
    }
    let Some(peer) = peer else {
        return ParityCheck::NotTestable(
            "one UART sends with the parity it checks: a second port must receive".to_owned(),
        );
    };
    if is_pseudo_terminal(peer) {
        return ParityCheck::NotTestable(format!(
            "{peer} is a pseudo-terminal: no wire, no parity bits"
        ));
    }
    match run(path, peer) {
        Ok(stream) => ParityCheck::Ran {
            sent: PATTERN.len(),
            marks: judge(&stream),
        },
        Err(e) => ParityCheck::Failed(e.to_string()),
    }
}

/// Open `path` sending mark parity and `peer` receiving space parity with marking, send the
/// pattern, and return what the peer read until the wire time and 300 ms have passed.
fn run(path: &str, peer: &str) -> io::Result<Vec<u8>> {
    let name = |what: &str, e: io::Error| io::Error::new(e.kind(), format!("{what}: {e}"));
    let receiver = serial2::SerialPort::open(peer, |mut s: serial2::Settings| {
        base(&mut s)?;
        let t = s.as_termios_mut();
        t.c_cflag |= libc::PARENB | libc::CMSPAR;
        t.c_cflag &= !libc::PARODD;
        t.c_iflag |= libc::PARMRK | libc::INPCK;
        t.c_iflag &= !(libc::IGNPAR | libc::IGNBRK | libc::BRKINT | libc::ISTRIP);
        Ok(s)
    })
    .map_err(|e| name(&format!("{peer} with space parity and PARMRK"), e))?;
    let sender = serial2::SerialPort::open(path, |mut s: serial2::Settings| {
        base(&mut s)?;
        s.as_termios_mut().c_cflag |= libc::PARENB | libc::CMSPAR | libc::PARODD;
        Ok(s)
    })
    .map_err(|e| name(&format!("{path} with mark parity"), e))?;
    let mut receiver = receiver;
    receiver.discard_input_buffer()?;
    receiver.set_read_timeout(Duration::from_millis(20))?;
    // 11 bits a character (start, 8 data, parity, stop).
    let wire = Duration::from_micros(PATTERN.len() as u64 * 11 * 1_000_000 / u64::from(BAUD));
    let deadline = Instant::now() + wire + Duration::from_millis(300);
    sender.write_all(&PATTERN)?;
    let mut stream = Vec::new();
    let mut buf = [0u8; 256];
    while Instant::now() < deadline && stream.len() < 3 * PATTERN.len() {
        match receiver.read(&mut buf) {
            Ok(n) => stream.extend_from_slice(&buf[..n]),
            Err(e) if e.kind() == io::ErrorKind::TimedOut => {}
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {}
            Err(e) => return Err(e),
        }
    }
    Ok(stream)
}

/// Raw 8-bit characters at [`BAUD`], one stop bit, no flow control.
fn base(s: &mut serial2::Settings) -> io::Result<()> {
    s.set_raw();
    s.set_baud_rate(BAUD)?;
    s.set_char_size(serial2::CharSize::Bits8);
    s.set_stop_bits(serial2::StopBits::One);
    s.set_flow_control(serial2::FlowControl::None);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_marked_character_is_detected() {
        let m = judge(&[0xFF, 0x00, 0x55, 0x41, 0xFF, 0x00, 0xAA]);
        assert_eq!(
            m,
            Marks {
                received: 3,
                marked: 2
            }
        );
        assert!(m.detected());
    }

    #[test]
    fn a_clean_stream_is_not_detected() {
        let m = judge(&PATTERN);
        assert_eq!(m.received, PATTERN.len());
        assert!(!m.detected());
    }

    #[test]
    fn an_escaped_ff_is_data() {
        let m = judge(&[0xFF, 0xFF, 0x00, 0xFF, 0xFF]);
        assert_eq!(
            m,
            Marks {
                received: 3,
                marked: 0
            }
        );
        assert!(!m.detected());
    }

    #[test]
    fn a_mark_cut_short_is_no_mark() {
        assert_eq!(judge(&[0x41, 0xFF, 0x00]).marked, 0);
        assert_eq!(judge(&[0x41, 0xFF]).marked, 0);
        assert_eq!(judge(&[]), Marks::default());
    }

    #[test]
    fn verdicts_never_say_yes_without_a_mark() {
        let ran = |received, marked| ParityCheck::Ran {
            sent: 32,
            marks: Marks { received, marked },
        };
        assert_eq!(ran(32, 32).verdict(), "yes");
        assert_eq!(ran(32, 32).finding().severity, Severity::Ok);
        assert_eq!(ran(32, 0).verdict(), "no");
        assert_eq!(ran(32, 0).finding().severity, Severity::Problem);
        assert_eq!(ran(0, 0).verdict(), "not testable");
        assert_eq!(ran(0, 0).finding().severity, Severity::Problem);
        let pty = ParityCheck::NotTestable("a pseudo-terminal".into());
        assert_eq!(pty.verdict(), "not testable");
        let f = pty.finding();
        assert_eq!(f.severity, Severity::Note);
        assert!(f.remedy.unwrap().contains("--loopback-peer"));
        assert!(
            f.text.contains("not testable (a pseudo-terminal)"),
            "{}",
            f.text
        );
    }

    #[test]
    fn a_pseudo_terminal_is_not_testable_without_opening_it() {
        let Ok((a, b)) = serial2::SerialPort::pair() else {
            return;
        };
        let link = |p: &serial2::SerialPort| {
            let fd = std::os::fd::AsRawFd::as_raw_fd(p);
            std::fs::read_link(format!("/proc/self/fd/{fd}")).unwrap()
        };
        let slave = [link(&a), link(&b)]
            .into_iter()
            .find(|p| p.starts_with("/dev/pts"))
            .expect("one end of a pair is under /dev/pts");
        let path = slave.to_string_lossy();
        assert!(is_pseudo_terminal(&path));
        for peer in [None, Some("/dev/null")] {
            let c = parity_check(&path, peer);
            assert!(matches!(c, ParityCheck::NotTestable(_)), "{c:?}");
        }
    }
}
