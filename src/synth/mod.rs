//! Synthetic sensor logs: truth signals delivered the way real loggers record them.
//!
//! [`can`] turns SI truth signals into CAN-decoded JSON messages — each message group at its own
//! rate and phase, each field at its wire resolution and range, with Gaussian noise, optional
//! delay and dropouts — and writes them as multi-rate MCAP plus the canonical Parquet drive log
//! that ingest makes of that MCAP. Output bytes are a function of the bus, the truth and the
//! seed (the project's own PRNG, [`crate::rng`]).
//!
//! [`drive`] makes the truth itself: a [`driver`] and an [`amt`] co-simulated with the fast
//! driveline model over a synthetic road (or one read by [`road_source`]), the axle model run
//! on the result; the driver brakes with engine brake, [`retarder`] and service brake in that
//! order, and [`track`] adds a GNSS track along the road. [`effects`] hides one physical effect
//! of the diagnosis catalogue in that truth, with its answer kept apart.
//!
//! [`log_writer`] chooses how a drive is logged — MCAP with zstd or LZ4 chunks, or the wide
//! fleet-portal and long J1939 exports of [`export`] — with the drive's ids, start time, logger
//! jitter and dropouts; [`truth_file`] writes the drive's truth as a canonical table. The
//! bundled fixture drives (`fixtures/drives/`) are made this way (`fixtures/gen/make_drives.sh`).

pub mod amt;
pub mod can;
pub mod can_bus;
pub mod can_error;
pub mod can_mcap;
pub mod can_sample;
pub mod drive;
pub mod drive_axles;
pub mod drive_error;
pub mod drive_loop;
pub mod driver;
pub mod effects;
pub mod export;
pub mod log_writer;
pub mod retarder;
pub mod road_source;
pub mod track;
pub mod trajectory;
pub mod truth_file;

pub use can::{
    sample, write_can_drive, write_mcap, write_mcap_with, CanBus, CanChannel, CanFrame, CanMessage,
    Dropouts, McapCompression, SynthError, SynthOptions, TorqueReference, Truth,
};
