//! The one tokio runtime every handle of the module runs on, and the blocking wait that lets
//! other Python threads run meanwhile.

use pyo3::prelude::*;
use std::future::Future;
use std::sync::OnceLock;
use tokio::runtime::Runtime;

/// The shared runtime: two worker threads drive every port's engine, whatever the number of
/// handles (a test rig opens a handful of ports, not hundreds).
pub fn runtime() -> &'static Runtime {
    static RUNTIME: OnceLock<Runtime> = OnceLock::new();
    RUNTIME.get_or_init(|| {
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("si-serial")
            .enable_all()
            .build()
            .expect("the tokio runtime of si_serial cannot start")
    })
}

/// Runs `job` to its end on the shared runtime with the GIL released, so other Python threads
/// run while the line is waited for.
pub fn wait<F>(py: Python<'_>, job: F) -> F::Output
where
    F: Future + Send,
    F::Output: Send,
{
    py.detach(|| runtime().block_on(job))
}
