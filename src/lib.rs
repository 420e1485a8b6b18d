//! fleetdyn: heavy-truck fleet logs to physics.
//!
//! Inputs (MCAP, Parquet) become one canonical drive-log table ([`ingest`], [`schema`]), which is
//! resampled to travelled distance ([`signal::distance`]), filtered without phase lag
//! ([`signal`], [`road`]) and written as Parquet with units and provenance ([`io`]).
//! Synthetic logs as real loggers deliver them (CAN rates, resolutions, noise, dropouts) come
//! from [`synth`]. [`truth`] is an independent truck simulator written from physics (no code
//! shared with [`sim`] or the diagnosis) whose drives prove the diagnosis against a truck it was
//! not built from.
//! The binary `fleetdyn` is a thin shell over this library.
#![deny(missing_docs)]

pub mod diagnose;
pub mod fleet;
pub mod heap;
pub mod ingest;
pub mod io;
pub mod model;
pub mod number_fmt;
pub mod optim;
pub mod pipeline;
pub mod proof;
pub mod report;
pub mod rng;
pub mod road;
pub mod schema;
pub mod settings;
pub mod signal;
pub mod sim;
pub mod synth;
pub mod table;
pub mod time_fmt;
pub mod truth;
pub mod units;
