//! Grinding plant (in progress).
