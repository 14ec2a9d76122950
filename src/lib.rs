//! si-serial
