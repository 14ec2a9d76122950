//! The Python bindings of si: the `si-serial` wheel, imported as `si_serial` (its Python part
//! re-exports this extension module, `si_serial._si_serial`).
//!
//! Thin glue only: every protocol rule, range and STATUS is the protocol crates'. What is
//! here converts keyword arguments to configs (`options`), runs the async handles on one
//! shared runtime with the GIL released (`runtime`) and maps their errors onto one
//! exception tree (`errors`).

mod aio_modbus;
mod callback_store;
mod errors;
mod frames;
mod lifecycle;
mod link3964r;
mod link_ascii;
mod modbus_client;
mod modbus_config;
mod modbus_jobs;
mod modbus_slave;
mod monitor;
mod options;
mod rk512;
mod runtime;
mod sim;
mod sim_trace;
mod store;
mod store_class;
mod uss;
mod values;
mod window;

use pyo3::prelude::*;

/// The extension module.
#[pymodule]
fn _si_serial(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    frames::register(m)?;
    m.add_class::<modbus_client::ModbusClient>()?;
    m.add_class::<modbus_client::RtuClient>()?;
    m.add_class::<modbus_client::TcpClient>()?;
    m.add_class::<store_class::ModbusStore>()?;
    m.add_class::<link3964r::Link3964R>()?;
    m.add_class::<link_ascii::AsciiLink>()?;
    m.add_class::<rk512::Rk512Station>()?;
    m.add_class::<uss::UssMaster>()?;
    m.add_class::<sim::Simulator>()?;
    m.add_class::<monitor::Monitor>()?;
    m.add_class::<window::WindowHost>()?;
    m.add_class::<window::WindowModule>()?;
    m.add_function(wrap_pyfunction!(monitor::monitor_trace, m)?)?;
    m.add_class::<modbus_slave::ModbusSlave>()?;
    m.add_class::<modbus_slave::TcpServer>()?;
    m.add("BYTEORDER_BIG", values::BYTEORDER_BIG)?;
    m.add("BYTEORDER_LITTLE", values::BYTEORDER_LITTLE)?;
    m.add("BYTEORDER_BIG_SWAP", values::BYTEORDER_BIG_SWAP)?;
    m.add("BYTEORDER_LITTLE_SWAP", values::BYTEORDER_LITTLE_SWAP)?;
    let aio = PyModule::new(m.py(), "_aio")?;
    aio.add_class::<aio_modbus::AioModbusClient>()?;
    aio.add_class::<aio_modbus::AioRtuClient>()?;
    aio.add_class::<aio_modbus::AioTcpClient>()?;
    m.add_submodule(&aio)?;
    // One runtime for both APIs; a second import of the module finds it set already.
    let _ = pyo3_async_runtimes::tokio::init_with_runtime(runtime::runtime());
    Ok(())
}
