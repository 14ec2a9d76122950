//! The [`Client`] trait: one program for an RTU line and a Modbus TCP connection.

use super::error::{Error, Job};
use crate::frame::{Bits, Registers, Request, Response};
use std::future::Future;

/// The FC12 answer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CommEventLog {
    /// Status word.
    pub status: u16,
    /// Event counter.
    pub event_count: u16,
    /// Message counter.
    pub message_count: u16,
    /// Event bytes.
    pub events: Vec<u8>,
}

/// A checked response, owned: what [`Client::request`] returns.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Reply {
    /// `unit | PDU`, no CRC or MBAP header; empty for a broadcast.
    unit_pdu: Vec<u8>,
}

impl Reply {
    /// The answering unit; `None` for a broadcast, which has no answer.
    pub fn unit(&self) -> Option<u8> {
        self.unit_pdu.first().copied()
    }

    /// The response `unit | PDU` (no CRC, no MBAP header); empty for a broadcast.
    pub fn unit_pdu(&self) -> &[u8] {
        &self.unit_pdu
    }

    /// The decoded response; `None` for a broadcast. Coil and input reads come back in whole
    /// bytes ([`Bits::truncate`] to the quantity asked for).
    pub fn response(&self) -> Option<Response<'_>> {
        crate::frame::decode_unit_pdu_response(&self.unit_pdu)
            .ok()
            .map(|(_, r)| r)
    }
}

/// One trait for every Modbus client of this crate, so a program is written once for
/// an RTU line and a Modbus TCP connection.
///
/// An implementor provides one method, [`Client::exchange`]: send a request and pick the typed
/// result out of the checked response. Every function code the module's master supports
/// (FC01–08, 11, 12, 15, 16, [Modbus/USS] §3.4) is a provided method over it. Implemented by
/// the RTU [`Master`](super::Master) (engine in a driver task), the
/// [`InlineMaster`](super::InlineMaster) (engine in the caller's future) and the Modbus TCP
/// [`tcp::Client`](super::tcp::Client).
///
/// ```
/// use si_modbus::tokio::{Client, Error};
///
/// /// Reads one holding register from unit 1, over whatever line `client` is.
/// async fn poll(client: &impl Client) -> Result<u16, Error> {
///     Ok(client.read_holding_registers(1, 0, 1).await?[0])
/// }
/// ```
///
/// FC22 (mask write) and FC23 (read/write multiple registers) are not among the module's
/// function codes ([Modbus/USS] §3.3.3, Table 3-10), so neither the codec nor this trait has them; a raw
/// [`Client::request`] carries any request the codec encodes.
///
/// Every method takes `&self`; a client runs one job at a time on its line ([Modbus/USS] §4.2),
/// so concurrent calls wait for each other.
pub trait Client: Sync {
    /// Send `request` to `unit` and pick the typed result out of its checked response; `pick`
    /// returns `None` when the response does not fit the request (then the job fails with
    /// 0E51H, [`Error::Failed`]). A broadcast (unit 0, RTU only) has no response: `pick` gets
    /// `None`.
    fn exchange<T: Send>(
        &self,
        unit: u8,
        request: &Request<'_>,
        pick: impl FnOnce(Option<Response<'_>>) -> Option<T> + Send,
    ) -> impl Future<Output = Result<T, Error>> + Send;

    /// Any request; the checked response, owned.
    fn request(
        &self,
        unit: u8,
        request: &Request<'_>,
    ) -> impl Future<Output = Result<Reply, Error>> + Send {
        self.exchange(unit, request, move |r| {
            let mut buf = [0u8; crate::frame::MAX_ADU];
            let n = r
                .map_or(Ok(0), |r| r.encode_unit_pdu(unit, &mut buf))
                .ok()?;
            Some(Reply {
                unit_pdu: buf[..n].to_vec(),
            })
        })
    }

    /// FC01: `quantity` coils from `address`.
    fn read_coils(
        &self,
        unit: u8,
        address: u16,
        quantity: u16,
    ) -> impl Future<Output = Result<Vec<bool>, Error>> + Send {
        let request = Request::ReadCoils { address, quantity };
        async move {
            self.exchange(unit, &request, |r| match r? {
                Response::ReadCoils(b) => Some(bools(b.truncate(quantity))),
                _ => None,
            })
            .await
        }
    }

    /// FC02: `quantity` discrete inputs from `address`.
    fn read_discrete_inputs(
        &self,
        unit: u8,
        address: u16,
        quantity: u16,
    ) -> impl Future<Output = Result<Vec<bool>, Error>> + Send {
        let request = Request::ReadDiscreteInputs { address, quantity };
        async move {
            self.exchange(unit, &request, |r| match r? {
                Response::ReadDiscreteInputs(b) => Some(bools(b.truncate(quantity))),
                _ => None,
            })
            .await
        }
    }

    /// FC03: `quantity` holding registers from `address`.
    fn read_holding_registers(
        &self,
        unit: u8,
        address: u16,
        quantity: u16,
    ) -> impl Future<Output = Result<Vec<u16>, Error>> + Send {
        let request = Request::ReadHoldingRegisters { address, quantity };
        async move {
            self.exchange(unit, &request, |r| match r? {
                Response::ReadHoldingRegisters(w) => Some(words(w)),
                _ => None,
            })
            .await
        }
    }

    /// FC04: `quantity` input registers from `address`.
    fn read_input_registers(
        &self,
        unit: u8,
        address: u16,
        quantity: u16,
    ) -> impl Future<Output = Result<Vec<u16>, Error>> + Send {
        let request = Request::ReadInputRegisters { address, quantity };
        async move {
            self.exchange(unit, &request, |r| match r? {
                Response::ReadInputRegisters(w) => Some(words(w)),
                _ => None,
            })
            .await
        }
    }

    /// FC05.
    fn write_single_coil(
        &self,
        unit: u8,
        address: u16,
        value: bool,
    ) -> impl Future<Output = Result<(), Error>> + Send {
        let request = Request::WriteSingleCoil { address, value };
        async move { self.exchange(unit, &request, |_| Some(())).await }
    }

    /// FC06.
    fn write_single_register(
        &self,
        unit: u8,
        address: u16,
        value: u16,
    ) -> impl Future<Output = Result<(), Error>> + Send {
        let request = Request::WriteSingleRegister { address, value };
        async move { self.exchange(unit, &request, |_| Some(())).await }
    }

    /// FC07: the eight exception status bits.
    fn read_exception_status(&self, unit: u8) -> impl Future<Output = Result<u8, Error>> + Send {
        async move {
            self.exchange(unit, &Request::ReadExceptionStatus, |r| match r? {
                Response::ReadExceptionStatus(s) => Some(s),
                _ => None,
            })
            .await
        }
    }

    /// FC08 sub-function 0000: the slave echoes `data`.
    fn diagnostics(&self, unit: u8, data: u16) -> impl Future<Output = Result<u16, Error>> + Send {
        async move {
            self.exchange(unit, &Request::Diagnostics { data }, |r| match r? {
                Response::Diagnostics { data } => Some(data),
                _ => None,
            })
            .await
        }
    }

    /// FC11: `(status, event_count)`.
    fn get_comm_event_counter(
        &self,
        unit: u8,
    ) -> impl Future<Output = Result<(u16, u16), Error>> + Send {
        async move {
            self.exchange(unit, &Request::GetCommEventCounter, |r| match r? {
                Response::GetCommEventCounter {
                    status,
                    event_count,
                } => Some((status, event_count)),
                _ => None,
            })
            .await
        }
    }

    /// FC12.
    fn get_comm_event_log(
        &self,
        unit: u8,
    ) -> impl Future<Output = Result<CommEventLog, Error>> + Send {
        async move {
            self.exchange(unit, &Request::GetCommEventLog, |r| match r? {
                Response::GetCommEventLog {
                    status,
                    event_count,
                    message_count,
                    events,
                } => Some(CommEventLog {
                    status,
                    event_count,
                    message_count,
                    events: events.to_vec(),
                }),
                _ => None,
            })
            .await
        }
    }

    /// FC15.
    fn write_multiple_coils(
        &self,
        unit: u8,
        address: u16,
        values: &[bool],
    ) -> impl Future<Output = Result<(), Error>> + Send {
        let request = Request::WriteMultipleCoils {
            address,
            values: Bits::Bools(values),
        };
        async move { self.exchange(unit, &request, |_| Some(())).await }
    }

    /// FC16.
    fn write_multiple_registers(
        &self,
        unit: u8,
        address: u16,
        values: &[u16],
    ) -> impl Future<Output = Result<(), Error>> + Send {
        let request = Request::WriteMultipleRegisters {
            address,
            values: Registers::Words(values),
        };
        async move { self.exchange(unit, &request, |_| Some(())).await }
    }
}

/// The registers as numbers, allocated once at their count.
fn words(w: Registers<'_>) -> Vec<u16> {
    match w {
        // Straight from the wire's pairs, taken as arrays (`as_chunks`): a loop with no bounds
        // check at all (neither `Registers::get`'s per register nor a slice chunk's per byte),
        // which the compiler vectorises.
        Registers::Wire(bytes) => bytes
            .as_chunks::<2>()
            .0
            .iter()
            .map(|&pair| u16::from_be_bytes(pair))
            .collect(),
        Registers::Words(words) => words.to_vec(),
    }
}

/// The bits as booleans, allocated once (see [`words`]).
fn bools(b: Bits<'_>) -> Vec<bool> {
    let mut v = Vec::with_capacity(b.len());
    v.extend(b.iter());
    v
}

/// The error for a response `pick` did not accept.
pub(crate) fn unexpected(unit: u8, request: &Request<'_>) -> Error {
    Error::unexpected(Job::of(unit, request))
}
