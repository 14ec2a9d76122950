//! When a handle's driver task has ended and released its port: [`Lifetime`] watches the task,
//! so `closed()` can wait on `&self` and `close()` returns once the transport is dropped.

use std::io;
use tokio::sync::watch;
use tokio::task::JoinHandle;

/// How the driver task ended: `Ok`, or the I/O error's kind and text (an `io::Error` cannot be
/// cloned to every waiter).
type Ended = Result<(), (io::ErrorKind, String)>;

/// The end of a driver task, watched.
#[derive(Debug)]
pub(crate) struct Lifetime {
    ended: watch::Receiver<Option<Ended>>,
}

impl Lifetime {
    /// Watch `task`: a small task awaits it and publishes how it ended.
    pub(crate) fn watch(task: JoinHandle<io::Result<()>>) -> Lifetime {
        let (tx, ended) = watch::channel(None);
        tokio::spawn(async move {
            let result = match task.await {
                Ok(Ok(())) => Ok(()),
                Ok(Err(e)) => Err((e.kind(), e.to_string())),
                // A driver task that panicked or was cancelled has dropped its transport too.
                Err(e) => Err((io::ErrorKind::Other, e.to_string())),
            };
            let _ = tx.send(Some(result));
        });
        Lifetime { ended }
    }

    /// Wait until the task has ended and its transport is dropped; its I/O result.
    pub(crate) async fn ended(&self) -> io::Result<()> {
        let mut ended = self.ended.clone();
        let result = match ended.wait_for(Option::is_some).await {
            Ok(r) => r.clone().unwrap_or(Ok(())),
            // The watcher is gone only once it has published.
            Err(_) => Ok(()),
        };
        result.map_err(|(kind, text)| io::Error::new(kind, text))
    }
}
