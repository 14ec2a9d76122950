//! One typed method per function code, written once for every async client: the RTU
//! [`Master`](super::Master) and the Modbus TCP [`Client`](super::tcp::Client) both get them
//! from [`typed_requests!`], and differ only in how one request is exchanged.
//!
//! The type the macro is used on provides
//!
//! - `async fn exchange_typed<T>(&mut self, unit: u8, request: Request<'_>,
//!   pick: impl FnOnce(Response<'_>) -> Option<T>) -> Result<T, E>`: send the request and pick
//!   the typed result out of its response (`None`: the response does not fit the request);
//! - `async fn request(&mut self, unit: u8, request: &Request<'_>) -> Result<_, E>`: send any
//!   request and check its answer (a write needs nothing more);
//!
//! and passes its error type `E`. Methods are inherent, so callers need no trait import.

/// The typed methods (FC01–08, 11, 12, 15, 16) over `exchange_typed` and `request`.
macro_rules! typed_requests {
    ($error:ty) => {
        /// A write: its answer (an echo, or start and quantity) was checked by `request`.
        async fn write(
            &mut self,
            unit: u8,
            request: $crate::frame::Request<'_>,
        ) -> Result<(), $error> {
            self.request(unit, &request).await.map(|_| ())
        }

        /// FC01: `quantity` coils from `address`.
        pub async fn read_coils(
            &mut self,
            unit: u8,
            address: u16,
            quantity: u16,
        ) -> Result<Vec<bool>, $error> {
            let request = $crate::frame::Request::ReadCoils { address, quantity };
            self.exchange_typed(unit, request, |r| match r {
                $crate::frame::Response::ReadCoils(b) => {
                    Some(b.truncate(quantity).iter().collect())
                }
                _ => None,
            })
            .await
        }

        /// FC02: `quantity` discrete inputs from `address`.
        pub async fn read_discrete_inputs(
            &mut self,
            unit: u8,
            address: u16,
            quantity: u16,
        ) -> Result<Vec<bool>, $error> {
            let request = $crate::frame::Request::ReadDiscreteInputs { address, quantity };
            self.exchange_typed(unit, request, |r| match r {
                $crate::frame::Response::ReadDiscreteInputs(b) => {
                    Some(b.truncate(quantity).iter().collect())
                }
                _ => None,
            })
            .await
        }

        /// FC03: `quantity` holding registers from `address`.
        pub async fn read_holding_registers(
            &mut self,
            unit: u8,
            address: u16,
            quantity: u16,
        ) -> Result<Vec<u16>, $error> {
            let request = $crate::frame::Request::ReadHoldingRegisters { address, quantity };
            self.exchange_typed(unit, request, |r| match r {
                $crate::frame::Response::ReadHoldingRegisters(w) => Some(w.iter().collect()),
                _ => None,
            })
            .await
        }

        /// FC04: `quantity` input registers from `address`.
        pub async fn read_input_registers(
            &mut self,
            unit: u8,
            address: u16,
            quantity: u16,
        ) -> Result<Vec<u16>, $error> {
            let request = $crate::frame::Request::ReadInputRegisters { address, quantity };
            self.exchange_typed(unit, request, |r| match r {
                $crate::frame::Response::ReadInputRegisters(w) => Some(w.iter().collect()),
                _ => None,
            })
            .await
        }

        /// FC05.
        pub async fn write_single_coil(
            &mut self,
            unit: u8,
            address: u16,
            value: bool,
        ) -> Result<(), $error> {
            self.write(
                unit,
                $crate::frame::Request::WriteSingleCoil { address, value },
            )
            .await
        }

        /// FC06.
        pub async fn write_single_register(
            &mut self,
            unit: u8,
            address: u16,
            value: u16,
        ) -> Result<(), $error> {
            self.write(
                unit,
                $crate::frame::Request::WriteSingleRegister { address, value },
            )
            .await
        }

        /// FC07: the eight exception status bits.
        pub async fn read_exception_status(&mut self, unit: u8) -> Result<u8, $error> {
            let request = $crate::frame::Request::ReadExceptionStatus;
            self.exchange_typed(unit, request, |r| match r {
                $crate::frame::Response::ReadExceptionStatus(s) => Some(s),
                _ => None,
            })
            .await
        }

        /// FC08 sub-function 0000: the slave echoes `data`.
        pub async fn diagnostics(&mut self, unit: u8, data: u16) -> Result<u16, $error> {
            let request = $crate::frame::Request::Diagnostics { data };
            self.exchange_typed(unit, request, |r| match r {
                $crate::frame::Response::Diagnostics { data } => Some(data),
                _ => None,
            })
            .await
        }

        /// FC11: `(status, event_count)`.
        pub async fn get_comm_event_counter(&mut self, unit: u8) -> Result<(u16, u16), $error> {
            let request = $crate::frame::Request::GetCommEventCounter;
            self.exchange_typed(unit, request, |r| match r {
                $crate::frame::Response::GetCommEventCounter {
                    status,
                    event_count,
                } => Some((status, event_count)),
                _ => None,
            })
            .await
        }

        /// FC12.
        pub async fn get_comm_event_log(
            &mut self,
            unit: u8,
        ) -> Result<$crate::tokio::CommEventLog, $error> {
            let request = $crate::frame::Request::GetCommEventLog;
            self.exchange_typed(unit, request, |r| match r {
                $crate::frame::Response::GetCommEventLog {
                    status,
                    event_count,
                    message_count,
                    events,
                } => Some($crate::tokio::CommEventLog {
                    status,
                    event_count,
                    message_count,
                    events: events.to_vec(),
                }),
                _ => None,
            })
            .await
        }

        /// FC15.
        pub async fn write_multiple_coils(
            &mut self,
            unit: u8,
            address: u16,
            values: &[bool],
        ) -> Result<(), $error> {
            let values = $crate::frame::Bits::Bools(values);
            self.write(
                unit,
                $crate::frame::Request::WriteMultipleCoils { address, values },
            )
            .await
        }

        /// FC16.
        pub async fn write_multiple_registers(
            &mut self,
            unit: u8,
            address: u16,
            values: &[u16],
        ) -> Result<(), $error> {
            let values = $crate::frame::Registers::Words(values);
            self.write(
                unit,
                $crate::frame::Request::WriteMultipleRegisters { address, values },
            )
            .await
        }
    };
}

pub(crate) use typed_requests;
