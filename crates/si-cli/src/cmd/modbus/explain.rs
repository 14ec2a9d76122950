//! STATUS words as the user reads them: the code, the manual's text and a remedy.

use crate::error::CliError;
use si_core::Status;
use si_modbus::tokio::Error as ModbusError;

/// A failed job as the one-line error `si` exits with.
pub fn failure(e: ModbusError) -> CliError {
    match e.status() {
        Some(s) => CliError::new(status_text(s)),
        None => CliError::new(e.to_string()),
    }
}

/// The STATUS with its text and remedy: the remedy the engine gave this occurrence (a USB
/// adapter's latency, [`si_core::delivery::ADAPTER_REMEDY`]) or else the manual's.
pub fn status_text(s: Status) -> String {
    let s = s.described_by(si_modbus::status::lookup);
    match s.remedy() {
        Some(remedy) => format!("{s} (remedy: {remedy})"),
        None => s.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use si_core::delivery::ADAPTER_REMEDY;

    #[test]
    fn a_failure_prints_the_occurrences_remedy_else_the_manuals() {
        let crc = si_modbus::status::RESPONSE_CRC;
        let manual = crc.info().unwrap().remedy;
        assert!(status_text(crc).ends_with(&format!("(remedy: {manual})")));
        let adapter = status_text(crc.with_remedy(ADAPTER_REMEDY));
        assert!(adapter.starts_with("16#0E57 "), "{adapter}");
        assert!(adapter.ends_with(&format!("(remedy: {ADAPTER_REMEDY})")));
        // A bare code (as deserialised) gets the manual's text and keeps the given remedy.
        let bare = status_text(Status::from_code(0x0E57).with_remedy(ADAPTER_REMEDY));
        assert_eq!(bare, adapter);
    }
}
