//! FC equivalents (in progress).
