//! Modbus TCP over tokio: a [`Client`] (one request at a time, each with its own transaction
//! id and a timeout) and a [`Server`] that serves a [`Store`](crate::slave::Store) to several
//! clients at once, or answers with any [`Handler`] (a gateway's routing to serial lines) while
//! keeping the connection handling: the connection limit, the idle timeout, the unit-id filter
//! and closing on a bad header.
//!
//! Both use the Sans-IO MBAP codec ([`crate::mbap`]) and the RTU PDU codec
//! ([`crate::frame`]); the server executes requests with the RTU slave's code
//! ([`crate::serve`]), so a store answers the same over TCP as on a serial line. Exceptions
//! pass as they are: the client returns any exception code the server sends
//! ([`Error::exception_code`](crate::tokio::Error::exception_code)), including gateway codes
//! 0AH/0BH that the serial module never sends. The client's function codes are the
//! [`Client`](crate::tokio::Client) trait's, as on an RTU line.
//!
//! ```
//! # #[tokio::main(flavor = "current_thread")]
//! # async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use si_modbus::slave::Tables;
//! use si_modbus::tokio::tcp::{Client, Server, ServerConfig};
//! use si_modbus::tokio::Client as _; // the function codes
//!
//! // Port 0: the system picks a free loopback port.
//! let server = Server::bind("127.0.0.1:0", ServerConfig::default(), Tables::new(16, 16, 16, 16)).await?;
//! let addr = server.local_addr()?;
//! let store = server.store();
//! let task = tokio::spawn(server.run());
//!
//! let client = Client::connect(addr).await?;
//! client.write_multiple_registers(1, 2, &[0xAAAA, 0x5555]).await?;
//! assert_eq!(client.read_holding_registers(1, 1, 3).await?, [0, 0xAAAA, 0x5555]);
//! assert_eq!(store.lock().unwrap().holding_registers[3], 0x5555);
//! // Register 16 is past the table: exception 02, passed as it is.
//! let e = client.read_holding_registers(1, 16, 1).await.unwrap_err();
//! assert_eq!(e.exception_code(), Some(2));
//! task.abort();
//! # Ok(()) }
//! ```

mod accept;
mod client;
mod server;

pub use accept::{accept_limited, ACCEPT_RETRY};
pub use client::{Client, ClientConfig, DEFAULT_RESPONSE_TIMEOUT};
pub use server::{
    Handler, Peer, Server, ServerConfig, StoreHandler, Units, DEFAULT_IDLE_TIMEOUT,
    DEFAULT_MAX_CONNECTIONS,
};
