//! # si-rk512 (in progress)
//!
//! RK 512 on top of 3964(R) (cp341-3964r-rk512-ascii.md §4, public-facts.md §2).
