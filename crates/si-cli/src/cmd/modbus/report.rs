//! One line per job outcome, in the user's address numbering and value format, stamped with
//! the wall clock: always in JSON (`timestamp`), in text with `--timestamps`.

use crate::output::Output;
use serde_json::{json, Value as Json};
use si_core::tracefile::rfc3339_millis;
use si_core::Status;
use si_modbus::frame::{Request, Response};
use si_modbus::master::Completion;
use si_modbus::values::{show, ValueFormat, WordOrder};

/// How job outcomes are printed.
#[derive(Debug, Clone, Copy)]
pub struct Report<'a> {
    /// Text or JSON lines.
    pub out: &'a Output,
    /// Text lines start with the wall-clock time.
    pub timestamps: bool,
    /// Address numbering: 0 as on the wire, 1 Modicon-style (`--base`).
    pub base: u8,
    /// How registers are shown (`--format`).
    pub format: ValueFormat,
    /// Which register of a pair is the high word (`--word-order`).
    pub order: WordOrder,
}

impl Report<'_> {
    /// Print one line: JSON always carries `timestamp`, text starts with it on request.
    pub fn emit(&self, text: &str, mut json: Json) {
        let now = rfc3339_millis(std::time::SystemTime::now());
        if let Json::Object(fields) = &mut json {
            fields.insert("timestamp".into(), Json::String(now.clone()));
        }
        if self.timestamps {
            self.out.line(&format!("{now} {text}"), json);
        } else {
            self.out.line(text, json);
        }
    }

    /// A PDU address in the user's numbering.
    fn shown(&self, pdu: u16) -> u32 {
        u32::from(pdu) + u32::from(self.base)
    }

    /// A job that failed on the line, as one line: what the poll counts it as (`kind`) and the
    /// STATUS with its text (`status` is null for a failure the module has no STATUS for, a
    /// Modbus TCP gateway exception). The poll passes its failure's fields, so this file does
    /// not import the poll that imports it.
    pub fn failed(&self, unit: u8, function: u8, kind: &str, status: Option<Status>, text: &str) {
        self.emit(
            &format!("unit {unit} FC{function:02} failed: {text}"),
            json!({"unit": unit, "function": function, "failed": kind,
                   "status": status.map(Status::code), "error": text}),
        );
    }

    /// One line per result of the RTU master: values for reads, the echo for writes.
    pub fn completion(&self, c: &Completion) {
        self.answer(c.unit(), c.request(), c.response());
    }

    /// One line per answer however it came (RTU or Modbus TCP): values for reads, the echo
    /// for writes; `None` is a broadcast. Coil and input reads are shown up to the quantity
    /// asked (a response carries whole bytes).
    pub fn answer(&self, unit: u8, request: Request<'_>, response: Option<Response<'_>>) {
        let function = request.function();
        let Some(response) = response else {
            self.emit(
                &format!("broadcast FC{function:02} sent (no reply by design)"),
                json!({"unit": unit, "function": function, "broadcast": true}),
            );
            return;
        };
        let start = match request {
            Request::ReadCoils { address, .. }
            | Request::ReadDiscreteInputs { address, .. }
            | Request::ReadHoldingRegisters { address, .. }
            | Request::ReadInputRegisters { address, .. } => address,
            _ => 0,
        };
        let first = self.shown(start);
        let range = |n: usize| format!("{first}…{}", first as usize + n.saturating_sub(1));
        let base = self.base;
        match response {
            Response::ReadCoils(bits) | Response::ReadDiscreteInputs(bits) => {
                let asked = match request {
                    Request::ReadCoils { quantity, .. }
                    | Request::ReadDiscreteInputs { quantity, .. } => quantity,
                    _ => u16::MAX,
                };
                let values: Vec<u8> = bits.truncate(asked).iter().map(u8::from).collect();
                let text: Vec<String> = values.iter().map(u8::to_string).collect();
                self.emit(
                    &format!(
                        "unit {unit} FC{function:02} {}: {}",
                        range(values.len()),
                        text.join(" ")
                    ),
                    json!({"unit": unit, "function": function, "address": first, "base": base,
                           "values": values}),
                );
            }
            Response::ReadHoldingRegisters(regs) | Response::ReadInputRegisters(regs) => {
                let raw: Vec<u16> = regs.iter().collect();
                let values = show(&raw, self.format, self.order);
                let text: Vec<String> = values.iter().map(ToString::to_string).collect();
                let mut j = json!({"unit": unit, "function": function, "address": first,
                                   "base": base, "format": self.format.name(),
                                   "values": values.iter().map(super::format::json).collect::<Vec<_>>()});
                if self.format != ValueFormat::U16 {
                    j["registers"] = json!(raw);
                }
                if self.format.registers_per_value() == 2 {
                    j["word_order"] = json!(self.order.name());
                }
                self.emit(
                    &format!(
                        "unit {unit} FC{function:02} {}: {}",
                        range(raw.len()),
                        text.join(" ")
                    ),
                    j,
                );
            }
            Response::WriteSingleCoil { address, value } => self.emit(
                &format!(
                    "unit {unit} coil {} = {} written",
                    self.shown(address),
                    if value { "ON" } else { "OFF" }
                ),
                json!({"unit": unit, "function": function, "address": self.shown(address),
                       "base": base, "value": value}),
            ),
            Response::WriteSingleRegister { address, value } => self.emit(
                &format!(
                    "unit {unit} register {} = {value} written",
                    self.shown(address)
                ),
                json!({"unit": unit, "function": function, "address": self.shown(address),
                       "base": base, "value": value}),
            ),
            Response::WriteMultipleCoils { address, quantity }
            | Response::WriteMultipleRegisters { address, quantity } => self.emit(
                &format!(
                    "unit {unit} FC{function:02} wrote {quantity} from {}",
                    self.shown(address)
                ),
                json!({"unit": unit, "function": function, "address": self.shown(address),
                       "base": base, "quantity": quantity}),
            ),
            Response::ReadExceptionStatus(s) => self.emit(
                &format!("unit {unit} exception status {s:08b} (0x{s:02X})"),
                json!({"unit": unit, "function": function, "exception_status": s}),
            ),
            Response::Diagnostics { data } => self.emit(
                &format!("unit {unit} diagnostics echo 0x{data:04X}"),
                json!({"unit": unit, "function": function, "data": data}),
            ),
            Response::GetCommEventCounter {
                status,
                event_count,
            } => self.emit(
                &format!("unit {unit} status 0x{status:04X}, event counter {event_count}"),
                json!({"unit": unit, "function": function, "status": status,
                       "event_count": event_count}),
            ),
            Response::GetCommEventLog {
                status,
                event_count,
                message_count,
                events,
            } => self.emit(
                &format!(
                    "unit {unit} status 0x{status:04X}, events {event_count}, messages \
                     {message_count}, log {}",
                    si_core::hex::format(events)
                ),
                json!({"unit": unit, "function": function, "status": status,
                       "event_count": event_count, "message_count": message_count,
                       "events": events}),
            ),
            Response::Exception { function, code } => self.emit(
                &format!("unit {unit} FC{function:02} {code}"),
                json!({"unit": unit, "function": function, "exception": code.code()}),
            ),
        }
    }
}
