//! # si-ascii (not yet implemented)
//!
//! Will hold the ET 200S ASCII driver (et200s-si-3964r-ascii.md §6): the three receive end
//! criteria (character delay time, end-of-text characters, fixed length), the 1024-byte receive
//! frame buffer, XON/XOFF and RTS/CTS flow control, automatic V.24 signal handling, and the FBs
//! S_SEND, S_RCV, S_VSTAT, S_VSET, S_XON, S_RTS and S_V24. Nothing here works yet.
