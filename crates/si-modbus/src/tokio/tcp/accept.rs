//! The accept loop of a TCP face: connections served at once up to a limit, each in its own
//! task, and an accept that fails (no file descriptor left) retried after a pause. Shared by
//! the Modbus TCP [`Server`](super::Server) and any other face that serves connections the
//! same way (si-gateway's RTU-over-TCP listener), so that both refuse and recover alike.

use std::future::Future;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::Semaphore;

/// The pause after a failed accept (out of file descriptors and the like) before the next: a
/// failing connection attempt must not end the listener, and retrying at once would spin.
pub const ACCEPT_RETRY: Duration = Duration::from_millis(100);

/// Accept connections on `listener` for ever, serving at most `max_connections` at once: one
/// more is accepted and closed at once (a clear refusal instead of a hang). Each connection
/// is served by `serve(stream, number, peer address)` (numbers from 1) in its own task; the
/// stream `serve` hands back is closed after the connection's slot is free, so a client that
/// sees the close can connect again at once.
pub async fn accept_limited<F, Fut>(
    listener: &TcpListener,
    max_connections: usize,
    serve: F,
) -> std::convert::Infallible
where
    F: Fn(TcpStream, u64, SocketAddr) -> Fut,
    Fut: Future<Output = TcpStream> + Send + 'static,
{
    let slots = Arc::new(Semaphore::new(max_connections));
    let mut accepted = 0u64;
    loop {
        let (stream, addr) = match listener.accept().await {
            Ok(accepted) => accepted,
            Err(_) => {
                tokio::time::sleep(ACCEPT_RETRY).await;
                continue;
            }
        };
        let Ok(slot) = Arc::clone(&slots).try_acquire_owned() else {
            drop(stream);
            continue;
        };
        accepted += 1;
        let served = serve(stream, accepted, addr);
        tokio::spawn(async move {
            let stream = served.await;
            drop(slot);
            drop(stream);
        });
    }
}
