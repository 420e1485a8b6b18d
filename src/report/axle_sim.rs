//! Writer of an axle-load simulation (`axle_sim`, `schemas/outputs/axle-sim.toml`), for scripted
//! scenarios (time axis only) and recorded drives (with the recording's timestamps).
//!
//! Columns: the simulated normal forces (N, and as scale readings N/g in t), bellow gauge
//! pressures (Pa), suspension travel (m), pitch (rad), pitch rate (rad/s), bounce (m), the
//! slip-limited auxiliary brake torque (N·m), the vehicle speed if given, and the inputs sampled
//! at the output times. Sign conventions are those of `sim::axle`. The file appears atomically
//! (temporary name, then rename) or not at all.

use crate::io::{write_table, OutColumn, OutputError, TableMeta};
use crate::sim::axle::{AxleInputs, AxleTrajectory};
use crate::sim::inputs::Piecewise;
use std::path::Path;

/// The time column(s) of the table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeAxis<'a> {
    /// A scripted scenario: only `time` (s from the start, `AxleTrajectory::t_s`).
    Simulation,
    /// A recorded drive: `timestamp` (ns since the Unix epoch, one per output sample) and
    /// `time` (`AxleTrajectory::t_s`, s from the first sample).
    Recorded {
        /// The recording's time of every output sample, ns.
        timestamp_ns: &'a [i64],
    },
}

/// What the table needs besides the trajectory.
#[derive(Debug, Clone, Copy)]
pub struct AxleSimExtra<'a> {
    /// Time column(s).
    pub time: TimeAxis<'a>,
    /// The inputs the trajectory was simulated with (sampled at `AxleTrajectory::t_s`; absent
    /// optional inputs become null columns).
    pub inputs: &'a AxleInputs,
    /// Vehicle speed at every output sample, m/s; `None` writes a null column.
    pub vehicle_speed_mps: Option<&'a [f64]>,
    /// Gravity for the normal forces in tonnes (`N / g / 1000`), m/s².
    pub gravity_m_per_s2: f64,
}

/// The table's columns in schema order.
pub fn axle_sim_columns(traj: &AxleTrajectory, extra: &AxleSimExtra<'_>) -> Vec<OutColumn> {
    const AXLES: [&str; 3] = ["front", "rear", "tag"];
    let n = traj.t_s.len();
    let mut cols = Vec::with_capacity(27);
    if let TimeAxis::Recorded { timestamp_ns } = extra.time {
        cols.push(OutColumn::timestamp(timestamp_ns.to_vec()));
    }
    cols.push(OutColumn::f64("time", "s", traj.t_s.clone()));
    for (i, a) in AXLES.iter().enumerate() {
        cols.push(OutColumn::f64(
            &format!("normal_force_{a}"),
            "N",
            traj.normal_n[i].clone(),
        ));
    }
    let to_t = 1.0 / (extra.gravity_m_per_s2 * 1000.0);
    for (i, a) in AXLES.iter().enumerate() {
        cols.push(OutColumn::f64(
            &format!("normal_force_{a}_t"),
            "t",
            traj.normal_n[i].iter().map(|x| x * to_t).collect(),
        ));
    }
    for (i, a) in AXLES.iter().enumerate() {
        cols.push(OutColumn::f64(
            &format!("bellow_pressure_{a}"),
            "Pa",
            traj.pressure_pa[i].clone(),
        ));
    }
    for (i, a) in AXLES.iter().enumerate() {
        cols.push(OutColumn::f64(
            &format!("suspension_travel_{a}"),
            "m",
            traj.travel_m[i].clone(),
        ));
    }
    cols.push(OutColumn::f64("pitch", "rad", traj.pitch_rad.clone()));
    cols.push(OutColumn::f64(
        "pitch_rate",
        "rad/s",
        traj.pitch_rate_rad_per_s.clone(),
    ));
    cols.push(OutColumn::f64("bounce", "m", traj.bounce_m.clone()));
    cols.push(OutColumn::f64(
        "aux_brake_torque_limit_wheel",
        "N*m",
        traj.aux_brake_limit_wheel_nm.clone(),
    ));
    cols.push(OutColumn::f64(
        "vehicle_speed",
        "m/s",
        extra
            .vehicle_speed_mps
            .map_or_else(|| vec![f64::NAN; n], <[f64]>::to_vec),
    ));
    let sample = |s: Option<&Piecewise>| -> Vec<f64> {
        s.map_or_else(
            || vec![f64::NAN; n],
            |s| traj.t_s.iter().map(|&t| s.eval(t)).collect(),
        )
    };
    let u = extra.inputs;
    cols.push(OutColumn::f64(
        "acceleration",
        "m/s^2",
        sample(Some(&u.accel_mps2)),
    ));
    cols.push(OutColumn::f64("road_slope", "1", sample(Some(&u.slope))));
    cols.push(OutColumn::f64(
        "drive_torque_wheel",
        "N*m",
        sample(u.drive_torque_wheel_nm.as_ref()),
    ));
    cols.push(OutColumn::f64(
        "aux_brake_torque_wheel",
        "N*m",
        sample(u.aux_brake_torque_wheel_nm.as_ref()),
    ));
    cols.push(OutColumn::f64(
        "service_brake_force",
        "N",
        sample(u.service_brake_n.as_ref()),
    ));
    cols
}

/// Writes `traj` with its inputs as an `axle_sim` Parquet table at `path`, atomically. The
/// metadata's `table` is set to `axle_sim`; the rest of `meta` (drive, vehicle, source,
/// configuration hash, extras) is written as given.
///
/// # Errors
/// [`OutputError::Ragged`] when the timestamps or the speed do not have one value per output
/// sample; I/O and encoder errors. On any error no file is left at `path`.
pub fn write_axle_sim(
    path: &Path,
    traj: &AxleTrajectory,
    extra: &AxleSimExtra<'_>,
    meta: &TableMeta,
) -> Result<(), OutputError> {
    let meta = TableMeta {
        table: "axle_sim".into(),
        ..meta.clone()
    };
    write_table(path, &meta, &axle_sim_columns(traj, extra))
}
