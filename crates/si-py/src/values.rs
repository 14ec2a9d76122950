//! minimalmodbus's value helpers: a 32- or 64-bit integer or float in consecutive registers,
//! with the byte order named by minimalmodbus's constants. Presentation only: the registers
//! are read and written by si-modbus's client.

/// ABCD: registers in order, each high byte first (Modbus's own order).
pub const BYTEORDER_BIG: u8 = 0;
/// DCBA: the whole value little-endian.
pub const BYTEORDER_LITTLE: u8 = 1;
/// BADC: registers in order, bytes swapped within each.
pub const BYTEORDER_BIG_SWAP: u8 = 2;
/// CDAB: low register first, each high byte first.
pub const BYTEORDER_LITTLE_SWAP: u8 = 3;

/// The value's big-endian bytes from `registers` in `byteorder` (0–3; checked by the caller).
pub fn to_value_bytes(registers: &[u16], byteorder: u8) -> Vec<u8> {
    let mut bytes: Vec<u8> = registers.iter().flat_map(|r| r.to_be_bytes()).collect();
    if matches!(byteorder, BYTEORDER_BIG_SWAP | BYTEORDER_LITTLE_SWAP) {
        bytes.chunks_mut(2).for_each(|pair| pair.swap(0, 1));
    }
    if matches!(byteorder, BYTEORDER_LITTLE | BYTEORDER_LITTLE_SWAP) {
        bytes.reverse();
    }
    bytes
}

/// The registers holding a value's big-endian `bytes` in `byteorder`: the inverse of
/// [`to_value_bytes`].
pub fn to_registers(value_bytes: &[u8], byteorder: u8) -> Vec<u16> {
    let mut bytes = value_bytes.to_vec();
    if matches!(byteorder, BYTEORDER_LITTLE | BYTEORDER_LITTLE_SWAP) {
        bytes.reverse();
    }
    if matches!(byteorder, BYTEORDER_BIG_SWAP | BYTEORDER_LITTLE_SWAP) {
        bytes.chunks_mut(2).for_each(|pair| pair.swap(0, 1));
    }
    bytes
        .chunks(2)
        .map(|pair| u16::from_be_bytes([pair[0], pair[1]]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_four_orders_of_minimalmodbus() {
        // 1.0f32 = 3F 80 00 00.
        let value = 1.0f32.to_be_bytes();
        assert_eq!(to_registers(&value, BYTEORDER_BIG), [0x3F80, 0x0000]);
        assert_eq!(to_registers(&value, BYTEORDER_LITTLE), [0x0000, 0x803F]);
        assert_eq!(to_registers(&value, BYTEORDER_BIG_SWAP), [0x803F, 0x0000]);
        assert_eq!(
            to_registers(&value, BYTEORDER_LITTLE_SWAP),
            [0x0000, 0x3F80]
        );
        for order in 0..4 {
            assert_eq!(to_value_bytes(&to_registers(&value, order), order), value);
        }
    }
}
