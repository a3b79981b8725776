//! Milling plant (in progress).
