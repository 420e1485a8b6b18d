//! Raw CAN logs: frames recorded by a bus logger, decoded with DBC files into the canonical
//! drive log.
//!
//! - [`frames`]: the frame type every source yields;
//! - [`mdf4`]: ASAM MDF4 bus-logging files (CANedge and other loggers), several files of one
//!   session concatenated in time;
//! - [`mcap_frames`]: MCAP channels of CAN frames (ROS 2 `can_msgs/msg/Frame` in CDR, JSON
//!   frames);
//! - [`dbc`]: DBC parsing (the `can-dbc` crate) and signal decoding (byte order, sign,
//!   scaling, multiplexing);
//! - [`j1939`]: SAE J1939 PGN matching, "not available" / "error" values, and transport-protocol
//!   (BAM) reassembly of multi-packet groups;
//! - [`mapping`]: decoded signals → canonical channels through a `can-dbc` mapping
//!   (`schemas/mappings/can-*.toml`).
//!
//! The channels then go through the same checks and alignment ([`super::align`]) as every other
//! multi-rate source.

pub mod dbc;
pub mod frames;
pub mod j1939;
pub mod mapping;
pub mod mcap_frames;
pub mod mdf4;
mod mdf4_blocks;
mod mdf4_groups;
mod mdf4_records;
pub mod mdf4_write;
pub mod session;

pub use dbc::Database;
pub use frames::CanFrame;
pub use mdf4::{read_mdf4, BusLog};
pub use session::{ingest_session, ingest_session_recording, read_session, Session};

use std::path::PathBuf;
use thiserror::Error;

/// Why raw CAN input could not be read or decoded.
#[derive(Debug, Error)]
pub enum CanError {
    /// A file could not be read.
    #[error("{file}: {source}")]
    Io {
        /// File.
        file: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// A DBC file that cannot be used.
    #[error("DBC {file}: {message}")]
    Dbc {
        /// DBC file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// An MDF4 file outside the subset read, or malformed.
    #[error("{file}: MDF4 {block} block at offset {offset}: {message}")]
    Mdf {
        /// MDF4 file.
        file: PathBuf,
        /// Byte offset of the block in the file.
        offset: u64,
        /// Block type (`DG`, `CG`, `CN`, `DZ`, …).
        block: String,
        /// What is wrong.
        message: String,
    },
    /// An MCAP file that is invalid, or a frame message in it that does not decode.
    #[error("{file}: MCAP CAN frames: {message}")]
    Mcap {
        /// MCAP file.
        file: PathBuf,
        /// What is wrong (topic, message index).
        message: String,
    },
    /// A session file that is neither MDF4 nor MCAP.
    #[error("{file}: not an MDF4 or MCAP file (first bytes {head})")]
    UnknownFormat {
        /// File.
        file: PathBuf,
        /// First bytes, hex.
        head: String,
    },
    /// `%` torque needs a reference torque the log does not carry.
    #[error("{column} is a percentage of the reference torque {message}.{signal}, but no {message} frame was decoded from {files}; log {message} (J1939 EC1 is sent with the transport protocol) or set reference_torque_nm in the mapping")]
    MissingReference {
        /// Canonical column.
        column: String,
        /// Message needed (e.g. `EC1`).
        message: String,
        /// Signal needed.
        signal: String,
        /// The files read.
        files: String,
    },
}
