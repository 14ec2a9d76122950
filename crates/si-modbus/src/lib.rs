//! # si-modbus (not yet implemented)
//!
//! Will hold Modbus RTU as the ET 200S SI module does it (et200s-si-modbus-uss.md §3–§5): the ADU
//! codec with CRC-16, frame detection by silence with the manual's gap table, the master and slave
//! engines, the SIMATIC address mapping of S_MODB. Nothing here works yet.
