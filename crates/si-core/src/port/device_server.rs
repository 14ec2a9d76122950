//! A serial device server in raw TCP mode (a port server's "TCP server" mode): the line's
//! bytes over one TCP connection, opened the way a long-running line wants it.

use std::time::Duration;

/// The longest wait for a serial device server to accept the connection (an unreachable host
/// would otherwise hold the opening, or a gateway line's reopening, for the kernel's two
/// minutes of SYN retries).
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// TCP keepalive on a device server's connection: the first probe after 10 s of silence, then
/// every 5 s, 3 unanswered probes end it. A server gone without closing the connection (cable
/// pulled, power lost) is thus seen within about 25 s as a lost line (a gateway line goes down
/// and is reopened), where the system default would take over two hours.
pub const KEEPALIVE: (Duration, Duration, u32) =
    (Duration::from_secs(10), Duration::from_secs(5), 3);

/// The device server at an address could not be reached.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("cannot connect to {addr}: {why}")]
pub struct ConnectError {
    /// The address tried (`HOST:PORT`).
    pub addr: String,
    /// Why: refused, unreachable, no answer within [`CONNECT_TIMEOUT`], keepalive refused.
    pub why: String,
}

/// Connect to the serial device server at `addr` (raw TCP mode): no Nagle delay (a frame's
/// bytes go at once), keepalive ([`KEEPALIVE`]), at most [`CONNECT_TIMEOUT`] to connect.
pub async fn device_server(addr: &str) -> Result<tokio::net::TcpStream, ConnectError> {
    let cannot = |why: String| ConnectError {
        addr: addr.to_owned(),
        why,
    };
    let stream = tokio::time::timeout(CONNECT_TIMEOUT, tokio::net::TcpStream::connect(addr))
        .await
        .map_err(|_| cannot(format!("no connection within {CONNECT_TIMEOUT:?}")))?
        .map_err(|e| cannot(e.to_string()))?;
    stream.set_nodelay(true).ok();
    let (time, interval, retries) = KEEPALIVE;
    let keepalive = socket2::TcpKeepalive::new()
        .with_time(time)
        .with_interval(interval);
    #[cfg(any(target_os = "linux", target_os = "macos", target_os = "freebsd"))]
    let keepalive = keepalive.with_retries(retries);
    #[cfg(not(any(target_os = "linux", target_os = "macos", target_os = "freebsd")))]
    let _ = retries;
    socket2::SockRef::from(&stream)
        .set_tcp_keepalive(&keepalive)
        .map_err(|e| cannot(format!("cannot set TCP keepalive: {e}")))?;
    Ok(stream)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn a_device_server_connection_has_keepalive_and_no_nagle() {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap().to_string();
        let stream = device_server(&addr).await.unwrap();
        let socket = socket2::SockRef::from(&stream);
        assert!(socket.keepalive().unwrap());
        assert_eq!(socket.tcp_keepalive_time().unwrap(), KEEPALIVE.0);
        #[cfg(target_os = "linux")]
        {
            assert_eq!(socket.tcp_keepalive_interval().unwrap(), KEEPALIVE.1);
            assert_eq!(socket.tcp_keepalive_retries().unwrap(), KEEPALIVE.2);
        }
        assert!(stream.nodelay().unwrap());
    }
}
