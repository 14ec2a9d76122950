//! The quantities a Modbus TCP client may ask of an RTU slave through the gateway: the Modbus
//! application protocol's ranges, checked before a request goes to the line.
//!
//! si-modbus's codec accepts the module's wider lengths (2040 bits, 127 registers,
//! [Modbus/USS] §3.4.5–§3.4.16), so that frames the module sends round-trip; a gateway in front
//! of arbitrary slaves holds the specification's limits instead, as a slave would
//! ([Modbus AP] §6.1–§6.4, §6.11, §6.12, §6.17: exception 03H "illegal data value" for a
//! quantity outside them). Answering 03H at once spares the line a request whose answer would
//! not fit an RTU frame (a 126-register answer is 257 bytes) and the client a 04H after the
//! slave's malformed reply. A leaf module: it imports nothing of the crate.

/// FC01/FC02: 1–2000 bits (0x7D0), [Modbus AP] §6.1, §6.2.
const MAX_READ_BITS: u16 = 2000;
/// FC03/FC04, and FC23's read part: 1–125 registers (0x7D), [Modbus AP] §6.3, §6.4, §6.17.
const MAX_READ_REGISTERS: u16 = 125;
/// FC15: 1–1968 coils (0x7B0), [Modbus AP] §6.11.
const MAX_WRITE_BITS: u16 = 1968;
/// FC16: 1–123 registers (0x7B), [Modbus AP] §6.12.
const MAX_WRITE_REGISTERS: u16 = 123;
/// FC23's write part: 1–121 registers (0x79), [Modbus AP] §6.17.
const MAX_READ_WRITE_WRITES: u16 = 121;

/// Whether the request `unit_pdu` (unit id, function code, data, as MBAP carries it) asks for
/// a quantity outside its function's range: the gateway answers it with 03H and nothing goes
/// to the line. Requests too short to hold their quantity are left to the codec, functions
/// without a quantity pass.
pub fn out_of_range(unit_pdu: &[u8]) -> bool {
    let word = |at: usize| {
        unit_pdu
            .get(at..at + 2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]))
    };
    let outside = |at: usize, max: u16| word(at).is_some_and(|q| q == 0 || q > max);
    match unit_pdu.get(1) {
        Some(0x01 | 0x02) => outside(4, MAX_READ_BITS),
        Some(0x03 | 0x04) => outside(4, MAX_READ_REGISTERS),
        Some(0x0F) => outside(4, MAX_WRITE_BITS),
        Some(0x10) => outside(4, MAX_WRITE_REGISTERS),
        Some(0x17) => outside(4, MAX_READ_REGISTERS) || outside(8, MAX_READ_WRITE_WRITES),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::out_of_range;

    /// Unit 1, function `fc`, address 0, quantity `q`.
    fn read(fc: u8, q: u16) -> Vec<u8> {
        let [hi, lo] = q.to_be_bytes();
        vec![1, fc, 0, 0, hi, lo]
    }

    #[test]
    fn reads_hold_the_specification_limits() {
        for fc in [3, 4] {
            assert!(!out_of_range(&read(fc, 1)));
            assert!(!out_of_range(&read(fc, 125)));
            assert!(out_of_range(&read(fc, 126)));
            assert!(out_of_range(&read(fc, 0)));
            assert!(out_of_range(&read(fc, 65535)));
        }
        for fc in [1, 2] {
            assert!(!out_of_range(&read(fc, 2000)));
            assert!(out_of_range(&read(fc, 2001)));
        }
    }

    #[test]
    fn writes_and_read_write_hold_theirs() {
        assert!(!out_of_range(&read(0x0F, 1968)));
        assert!(out_of_range(&read(0x0F, 1969)));
        assert!(!out_of_range(&read(0x10, 123)));
        assert!(out_of_range(&read(0x10, 124)));
        let fc23 = |r: u16, w: u16| {
            let ([rh, rl], [wh, wl]) = (r.to_be_bytes(), w.to_be_bytes());
            vec![1, 0x17, 0, 0, rh, rl, 0, 0, wh, wl, 2, 0, 0]
        };
        assert!(!out_of_range(&fc23(125, 121)));
        assert!(out_of_range(&fc23(126, 1)));
        assert!(out_of_range(&fc23(1, 122)));
    }

    #[test]
    fn other_functions_and_short_requests_pass() {
        assert!(!out_of_range(&[1, 0x06, 0, 0, 0xFF, 0xFF]));
        assert!(!out_of_range(&[1, 0x2B, 0x0E, 1, 0]));
        assert!(!out_of_range(&[1, 0x03, 0]));
        assert!(!out_of_range(&[]));
    }
}
