//! A simulated drive on the output grid: the signals [`super::drive`] produces and the truth
//! table ([`super::truth_file`]) and the logs are written from.

/// One gear shift of the AMT while driving (torque ramp-down to ramp-up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShiftRecord {
    /// Gear before.
    pub from: usize,
    /// Gear after.
    pub to: usize,
    /// Start of the torque ramp-down, s.
    pub t_start_s: f64,
    /// Time the gear input changed, s.
    pub t_change_s: f64,
    /// End of the torque ramp-up, s.
    pub t_end_s: f64,
}

/// A simulated drive on the output grid.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DriveTrajectory {
    /// Times, s from the start.
    pub t_s: Vec<f64>,
    /// Travelled distance, m.
    pub distance_m: Vec<f64>,
    /// Vehicle speed r_w ω_w, m/s.
    pub speed_mps: Vec<f64>,
    /// Engine speed, rad/s.
    pub engine_speed_rad_s: Vec<f64>,
    /// Engine torque, N·m.
    pub engine_torque_nm: Vec<f64>,
    /// Drive-shaft torque M_d, N·m.
    pub drive_torque_nm: Vec<f64>,
    /// Gear input.
    pub gear: Vec<f64>,
    /// Clutch position, 0 = engaged … x_max = open.
    pub clutch_x: Vec<f64>,
    /// Clutch position normalised, `clutch_x / x_max`: 0 = engaged … 1 = open.
    pub clutch_position: Vec<f64>,
    /// Road slope, tan α.
    pub slope: Vec<f64>,
    /// Service-brake force, N.
    pub brake_n: Vec<f64>,
    /// Retarder torque at the propeller shaft, N·m (≥ 0 brakes).
    pub retarder_torque_nm: Vec<f64>,
    /// The retarder's torque at the driven wheels `T_r i_f`, N·m (≥ 0 brakes).
    pub aux_brake_wheel_nm: Vec<f64>,
    /// Target speed of the driver, m/s.
    pub target_mps: Vec<f64>,
    /// Shifts while driving.
    pub shifts: Vec<ShiftRecord>,
    /// Launch intervals (launch start, clutch locked), s.
    pub launches: Vec<(f64, f64)>,
    /// Planned stop positions, m (the last is the road end).
    pub planned_stops_m: Vec<f64>,
}
