//! The module a configuration speaks for, and the limits that follow from it: the one place the
//! maximum frame length of each module type is written down.
//!
//! Several crates need the same number for the same module: the ASCII driver's longest frame
//! (si-ascii), the coordination window's longest job (si-dp-coord). It lives here, next to
//! [`Interface`](crate::Interface), because si-core is the crate both already depend on; a
//! protocol crate owning it would make the other depend on it for one table.
//!
//! | Preset | Module | Longest frame | Source |
//! |---|---|---|---|
//! | [`Et200s1Si`](ModulePreset::Et200s1Si) | ET 200S 1SI 3964(R)/ASCII (2004) | 200 bytes | [ET200S SI] §2.10, Tables 2-13/2-14 (S_SEND/S_RCV LEN 1 … 200), §2.13, Table 2-28 (050EH "> 200 bytes"), §2.14 |
//! | [`Si2005`](ModulePreset::Si2005) | ET 200S 1SI of the 2005 manual | 224 bytes | [ET200S SI 2005] `[derived]` (chapter 2: LEN, 050EH, 0850H, fixed length all 224) |
//! | [`Cp341`](ModulePreset::Cp341) | CP 341 (S7-300 rack) | 1024 bytes | [CP 341 Diag] 0517H "length too large for the CP (> 1 KB)", [CP 341] §2.3.3, Tables 2-7 to 2-11 (fixed length 1 … 1024) |
//!
//! # Readings
//!
//! - **2005 module: 224, not 200 or 256.** `[derived]`: chapter 2 says 224 everywhere it gives a
//!   number for the frame (LEN, 050EH, 0850H, fixed-length receive); the 1E41H text's "1 … 200"
//!   and chapter 3's "256" belong to other tables (the FB's parameter check, the Modbus/USS
//!   module). We take chapter 2's 224.
//! - **CP 341 has no DP coordination window.** It sits in the S7-300 rack and talks to the CPU
//!   over the backplane ([CP 341]); the window protocol of
//!   [ET200S SI 2005] §2.12 belongs to the ET 200S modules only, so
//!   [`ModulePreset::has_dp_window`] is false for it.

use core::fmt;
use serde::{Deserialize, Serialize};

/// A module type whose limits a configuration follows.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModulePreset {
    /// ET 200S 1SI 3964(R)/ASCII as in [ET200S SI]: 200-byte frames. The default,
    /// the module this workspace models first.
    #[default]
    #[serde(rename = "et200s")]
    Et200s1Si,
    /// ET 200S 1SI of the 2005 manual ([ET200S SI 2005]): 224-byte frames.
    #[serde(rename = "2005")]
    Si2005,
    /// CP 341 ([CP 341]): frames up to 1 KB.
    #[serde(rename = "cp341")]
    Cp341,
}

impl ModulePreset {
    /// Every preset, in the order of the table above.
    pub const ALL: [ModulePreset; 3] = [
        ModulePreset::Et200s1Si,
        ModulePreset::Si2005,
        ModulePreset::Cp341,
    ];

    /// The longest frame the module sends or receives, in bytes (see the module docs' table).
    pub const fn max_frame_len(self) -> u16 {
        match self {
            ModulePreset::Et200s1Si => 200,
            ModulePreset::Si2005 => 224,
            ModulePreset::Cp341 => 1024,
        }
    }

    /// True for the modules that talk to the DP master through the coordination-byte window
    /// (the ET 200S modules); false for the CP 341, a rack module.
    pub const fn has_dp_window(self) -> bool {
        !matches!(self, ModulePreset::Cp341)
    }

    /// The preset's short name, as configuration files and the command line spell it.
    pub const fn name(self) -> &'static str {
        match self {
            ModulePreset::Et200s1Si => "et200s",
            ModulePreset::Si2005 => "2005",
            ModulePreset::Cp341 => "cp341",
        }
    }
}

impl fmt::Display for ModulePreset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let module = match self {
            ModulePreset::Et200s1Si => "ET 200S 1SI",
            ModulePreset::Si2005 => "ET 200S 1SI (2005)",
            ModulePreset::Cp341 => "CP 341",
        };
        write!(f, "{module} ({} bytes)", self.max_frame_len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_lengths_follow_the_manuals() {
        let lens: Vec<u16> = ModulePreset::ALL
            .iter()
            .map(|m| m.max_frame_len())
            .collect();
        assert_eq!(lens, [200, 224, 1024]);
        assert_eq!(ModulePreset::default(), ModulePreset::Et200s1Si);
        assert!(ModulePreset::Si2005.has_dp_window() && !ModulePreset::Cp341.has_dp_window());
    }

    #[test]
    fn serde_names_are_the_short_names() {
        for m in ModulePreset::ALL {
            let json = serde_json::to_string(&m).unwrap();
            assert_eq!(json, format!("\"{}\"", m.name()));
            assert_eq!(serde_json::from_str::<ModulePreset>(&json).unwrap(), m);
        }
        assert_eq!(ModulePreset::Cp341.to_string(), "CP 341 (1024 bytes)");
    }
}
