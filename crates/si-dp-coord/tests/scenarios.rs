//! The DP coordination window's scenarios, one module per topic
//! ([ET200S SI 2005]): the manual's window examples and §2.12.7 rules, host and
//! module together, the FBs over the window, modules on a line, end to end, the timing tables.

mod common;
#[path = "scenarios/end_to_end.rs"]
mod end_to_end;
#[path = "scenarios/exec_wrap.rs"]
mod exec_wrap;
#[path = "scenarios/fb_over_window.rs"]
mod fb_over_window;
#[path = "scenarios/host_module.rs"]
mod host_module;
#[path = "scenarios/modbus_master.rs"]
mod modbus_master;
#[path = "scenarios/module_on_line.rs"]
mod module_on_line;
#[path = "scenarios/one_v24_program.rs"]
mod one_v24_program;
#[path = "scenarios/section_2_8_rules.rs"]
mod section_2_8_rules;
#[path = "scenarios/timing_tables.rs"]
mod timing_tables;
#[path = "scenarios/window_examples.rs"]
mod window_examples;
