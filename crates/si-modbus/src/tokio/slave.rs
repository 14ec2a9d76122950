//! The async RTU slave handle: a [`Slave`] serving a [`Store`] on one line in a driver task.

use super::error::Error;
use super::lifetime::Lifetime;
use crate::config::SlaveConfig;
use crate::slave::{self, SlaveEvent, Store};
use si_core::driver::{self, DriverOptions, Transport};
use si_core::Instant;

/// A Modbus slave serving a [`Store`] on one line, as a tokio task. Dropping the handle stops
/// it and releases the port; [`close`](Self::close) waits until it has.
pub struct Slave<S: Store + Send + 'static> {
    driver: driver::Handle<slave::Slave<S>>,
    lifetime: Lifetime,
}

impl<S: Store + Send + 'static> Slave<S> {
    /// Start serving `store` on `transport`.
    pub fn spawn<T: Transport>(config: SlaveConfig, store: S, transport: T) -> Result<Self, Error> {
        Ok(Self::spawn_engine(
            slave::Slave::new(config, store)?,
            transport,
        ))
    }

    /// Open the serial port at `path` with the config's own line settings and serve `store`
    /// on it (feature `serial`).
    #[cfg(feature = "serial")]
    #[cfg_attr(docsrs, doc(cfg(feature = "serial")))]
    pub fn open(config: SlaveConfig, store: S, path: &str) -> Result<Self, Error> {
        let slave = slave::Slave::new(config, store)?;
        let port = si_core::port::open(
            path,
            &config.line.settings,
            &si_core::port::PortOptions::default(),
        )?;
        Ok(Self::spawn_engine(slave, port))
    }

    /// Serve with an engine built by the caller (for options beyond [`SlaveConfig`], such as
    /// [`slave::Slave::with_frame_end`]) on `transport`.
    pub fn spawn_engine<T: Transport>(slave: slave::Slave<S>, transport: T) -> Self {
        // Report tx-done when the write completes, not after the estimated wire time: on
        // transports without wire time (pseudo-terminals, TCP) a fast master's next request
        // would otherwise look like a sequence error (0837H).
        let options = DriverOptions {
            settings: None,
            ..DriverOptions::default()
        };
        let (driver, task) = driver::spawn(slave, transport, options);
        Slave {
            driver,
            lifetime: Lifetime::watch(task),
        }
    }

    /// The next thing the slave did; `None` once the line has closed.
    pub async fn next_event(&mut self) -> Option<SlaveEvent> {
        self.driver.next_event().await
    }

    /// Look at or change the store (a simulated process) inside the driver.
    pub async fn with_store<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut S) -> R + Send + 'static,
    ) -> Result<R, Error> {
        self.call(move |s, _| f(s.store_mut())).await
    }

    /// Run `f` on the slave engine inside the driver (counters, state).
    pub async fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut slave::Slave<S>, Instant) -> R + Send + 'static,
    ) -> Result<R, Error> {
        Ok(self.driver.call(f).await?)
    }

    /// Wait until the line has closed (the port failed or was closed by the peer); its I/O
    /// result.
    pub async fn closed(&self) -> Result<(), Error> {
        Ok(self.lifetime.ended().await?)
    }

    /// Stop serving and wait until the port is released; the line's I/O result.
    pub async fn close(self) -> Result<(), Error> {
        let Slave { driver, lifetime } = self;
        drop(driver);
        Ok(lifetime.ended().await?)
    }
}
