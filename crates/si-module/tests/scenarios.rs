//! The module's descriptions against the manual's tables, one module per topic: slave diagnosis,
//! I&M records, LED states and parameter tables (with their properties).

#[path = "scenarios/diag_slave_diagnosis.rs"]
mod diag_slave_diagnosis;
#[path = "scenarios/ident_records.rs"]
mod ident_records;
#[path = "scenarios/led_states.rs"]
mod led_states;
#[path = "scenarios/params_tables.rs"]
mod params_tables;
