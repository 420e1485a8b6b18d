//! Per-vehicle evidence over weeks of drives (docs/fleet.md): each vehicle's per-drive parameter
//! estimates (the diagnosis's `parameter_estimates` tables, [`series`]) pooled parameter by
//! parameter into one estimate with an interval ([`pool`]), changes over time found with a
//! false-alarm rate fixed in advance ([`change`]), set against the vehicle file's tolerance
//! ([`evidence`]), written as tables ([`tables`]) and as a suggested vehicle-file update
//! ([`suggest`]). The mass and the centre of gravity change with the payload and are kept per
//! trip ([`trips`]).
//!
//! One drive is weak evidence (a 15-minute city drive hides a drag error; one noisy drive raises
//! a false alarm); thirty drives of one truck are strong evidence. Values in each parameter's SI
//! unit; times in ns since the Unix epoch (UTC).

pub mod change;
pub mod evidence;
pub mod pool;
pub mod series;
pub mod suggest;
pub mod tables;
pub mod trips;

pub use evidence::{vehicle_evidence, ParameterEvidence, Status, VehicleEvidence};
pub use series::{DriveEstimates, EstimateRow, FleetError};
