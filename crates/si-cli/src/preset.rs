//! `--module et200s|2005|cp341`: the module type whose limits a command follows
//! ([`si_core::ModulePreset`]; 200, 224 and 1024-byte frames).
//!
//! A leaf module: `si ascii` and `si dp-coord` both take the option.

use si_core::ModulePreset;

/// The preset named `text` (its [`ModulePreset::name`]), for clap's `value_parser`.
pub fn module_preset(text: &str) -> Result<ModulePreset, String> {
    ModulePreset::ALL
        .into_iter()
        .find(|m| m.name() == text)
        .ok_or_else(|| {
            let names: Vec<&str> = ModulePreset::ALL.iter().map(|m| m.name()).collect();
            format!("{text:?} is not a module type: {}", names.join(", "))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_parses_by_its_name_and_others_are_refused() {
        for m in ModulePreset::ALL {
            assert_eq!(module_preset(m.name()), Ok(m));
        }
        assert_eq!(
            module_preset("cp340").unwrap_err(),
            "\"cp340\" is not a module type: et200s, 2005, cp341"
        );
    }
}
