//! si-modbus
