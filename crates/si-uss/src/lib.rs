//! si-uss
