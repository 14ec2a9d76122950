//! The open-file limit of a gateway with many lines: raised to the hard one at start, as
//! [`si_gateway::limits`] plans for what the configuration needs.

use crate::error::CliError;
use si_gateway::limits::plan;

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

/// Where there is no `RLIMIT_NOFILE`: nothing to raise.
#[cfg(not(unix))]
pub fn raise_open_files(needed: u64) -> Result<u64, CliError> {
    let _ = plan;
    Ok(needed)
}

#[cfg(test)]
mod tests {
    #[cfg(unix)]
    #[test]
    fn raising_leaves_the_soft_limit_at_least_the_need() {
        let soft = super::raise_open_files(64).unwrap();
        assert!(soft >= 64);
    }
}
