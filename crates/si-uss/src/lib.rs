//! # si-uss (not yet implemented)
//!
//! Will hold the USS master (et200s-si-modbus-uss.md §6, public-facts.md §3): the telegram codec
//! (STX LGE ADR net data BCC), the cyclic polling list with its timing, the PKW/PZD handshakes and
//! the FB equivalents S_USST, S_USSR and S_USSI. Nothing here works yet.
