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

/// A job as a future that owns what it needs: the blocking API waits for it ([`wait`]), the
/// asyncio API hands it to the event loop.
pub type Job<T> = std::pin::Pin<Box<dyn Future<Output = PyResult<T>> + Send + 'static>>;

/// Received bytes, which Python gets as `bytes`.
pub type Data = std::borrow::Cow<'static, [u8]>;

/// A handle that jobs borrow one at a time and `close` takes away.
pub type Shared<H> = std::sync::Arc<tokio::sync::Mutex<Option<H>>>;

/// `handle` shared.
pub fn shared<H>(handle: H) -> Shared<H> {
    std::sync::Arc::new(tokio::sync::Mutex::new(Some(handle)))
}

/// Runs `job` on the handle in `cell`; ProtocolError "`what` is closed" after `close`.
pub async fn with_handle<H, T>(
    cell: Shared<H>,
    what: &'static str,
    job: impl AsyncFnOnce(&mut H) -> PyResult<T>,
) -> PyResult<T> {
    let mut guard = cell.lock().await;
    let handle = guard
        .as_mut()
        .ok_or_else(|| crate::errors::ProtocolError::new_err(format!("the {what} is closed")))?;
    job(handle).await
}

/// Takes the handle out of `cell` (once) and closes it with `close`.
pub async fn close_handle<H>(cell: Shared<H>, close: impl AsyncFnOnce(H)) -> PyResult<()> {
    let taken = cell.lock().await.take();
    if let Some(handle) = taken {
        close(handle).await;
    }
    Ok(())
}

/// Waits up to `limit` (None: for ever) for `received`; `Ok(None)` when the time ran out.
pub async fn within<T>(
    limit: Option<si_core::Duration>,
    received: impl Future<Output = T>,
) -> Option<T> {
    match limit {
        Some(l) => tokio::time::timeout(l.into(), received).await.ok(),
        None => Some(received.await),
    }
}
