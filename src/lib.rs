//! fleetdyn: heavy-truck fleet logs to physics.
#![deny(missing_docs)]

pub mod signal;
