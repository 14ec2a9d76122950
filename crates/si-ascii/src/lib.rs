//! si-ascii
