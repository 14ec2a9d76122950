//! # si-dp-coord (not yet implemented)
//!
//! Will hold the coordination-byte window protocol through which a PROFIBUS-DP master talks to an
//! ET 200S serial module (et200s-si-2005-window-protocol.md §2): the host side (the FBs' view) and
//! the module side (a simulated module driving a line engine). Nothing here works yet.
