//! si-dp-coord
