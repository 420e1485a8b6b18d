//! Driveline resonance per gear (Myklebust & Eriksson (2012), §3): where the `F_dr → v` response
//! peaks, how high the peak stands over the rigid-driveline response, and the spatial frequency it
//! corresponds to at the gear's top speed (so it can be set against road spectra).
//!
//! Definitions:
//! - operating point: the speed at which the engine turns 1200 rpm in that gear (cruise);
//! - top speed of a gear: the vehicle speed at the last point of the engine's full-load curve;
//! - peak: the largest local maximum of |H(j2πf)| for 0.02 ≤ f ≤ 50 Hz (log grid of 2000
//!   points, refined by golden-section search); "no peak" when |H| has no local maximum there —
//!   the resonance has disappeared into the rigid-body roll-off;
//! - peak height: 20·log10(|H(f_peak)| / |H_rigid(f_peak)|), dB — the amplification over the
//!   response of the same vehicle with a rigid driveline ([`rigid_response`]), which is what the
//!   flexible model follows below its resonances;
//! - spatial frequency: f_s = f_peak / v_top(gear), 1/m (docs/models/driveline.md).

use super::driveline::DrivelineParams;
use super::linear::{linearize, rigid_response, LinearDriveline, StateSpace};
use crate::optim::golden_section;

/// Engine speed of the operating point, rad/s (1200 rpm).
pub const OPERATING_ENGINE_SPEED_RAD_S: f64 = 1200.0 * std::f64::consts::PI / 30.0;

/// Transfer paths analysed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Path {
    /// Engine torque to vehicle speed, open loop.
    EngineTorqueOpen,
    /// Drive-resistance force to vehicle speed, open loop.
    ResistanceOpen,
    /// Drive-resistance force to vehicle speed with the engine-speed PI controller.
    ResistanceClosed,
}

/// The resonance of one gear on one path.
#[derive(Debug, Clone, PartialEq)]
pub struct Resonance {
    /// Gear.
    pub gear: usize,
    /// Path.
    pub path: Path,
    /// Operating speed, m/s.
    pub v0_mps: f64,
    /// Top speed of the gear, m/s.
    pub v_top_mps: f64,
    /// Peak frequency, Hz (`None`: no peak).
    pub peak_hz: Option<f64>,
    /// Peak frequency at the gear's top speed, 1/m.
    pub peak_per_m: Option<f64>,
    /// Peak height over the rigid-driveline response, dB.
    pub peak_over_rigid_db: Option<f64>,
    /// |H| at the peak (m/s per N·m or per N).
    pub peak_gain: Option<f64>,
}

fn system(lin: &LinearDriveline, path: Path) -> (&StateSpace, usize) {
    match path {
        Path::EngineTorqueOpen => (&lin.open, 0),
        Path::ResistanceOpen => (&lin.open, 1),
        Path::ResistanceClosed => (&lin.closed, 1),
    }
}

/// Vehicle speed at engine speed `w_e` in `gear`, m/s.
pub fn vehicle_speed_at(p: &DrivelineParams, ratios: &[f64], gear: usize, w_e: f64) -> f64 {
    w_e * p.wheel_radius_m / (ratios[gear - 1] * p.final_drive_ratio)
}

/// Finds the resonance of `gear` on `path` (see the module doc for the definitions).
pub fn resonance(p: &DrivelineParams, ratios: &[f64], gear: usize, path: Path) -> Resonance {
    let v0 = vehicle_speed_at(p, ratios, gear, OPERATING_ENGINE_SPEED_RAD_S);
    let w_top = *p.engine_speed_rad_per_s.last().expect("curve has points");
    let v_top = vehicle_speed_at(p, ratios, gear, w_top);
    let lin = linearize(p, ratios, gear, v0);
    let (ss, input) = system(&lin, path);
    let mag = |f: f64| ss.freq_response(input, f).norm();
    let (f_lo, f_hi, n) = (0.02f64, 50.0f64, 2000usize);
    let grid: Vec<f64> = (0..n)
        .map(|k| f_lo * (f_hi / f_lo).powf(k as f64 / (n - 1) as f64))
        .collect();
    let m: Vec<f64> = grid.iter().map(|&f| mag(f)).collect();
    let best = (1..n - 1)
        .filter(|&k| m[k] > m[k - 1] && m[k] >= m[k + 1])
        .max_by(|&a, &b| {
            let ra = m[a] / rigid_response(p, &lin, input, grid[a]).norm();
            let rb = m[b] / rigid_response(p, &lin, input, grid[b]).norm();
            ra.total_cmp(&rb)
        });
    let mut out = Resonance {
        gear,
        path,
        v0_mps: v0,
        v_top_mps: v_top,
        peak_hz: None,
        peak_per_m: None,
        peak_over_rigid_db: None,
        peak_gain: None,
    };
    if let Some(k) = best {
        // golden-section search for the maximum on [grid[k-1], grid[k+1]] in log f
        let (log_f, _) = golden_section(|x| -mag(x.exp()), grid[k - 1].ln(), grid[k + 1].ln(), 80);
        let f = log_f.exp();
        let h = mag(f);
        out.peak_hz = Some(f);
        out.peak_per_m = Some(f / v_top);
        out.peak_gain = Some(h);
        out.peak_over_rigid_db =
            Some(20.0 * (h / rigid_response(p, &lin, input, f).norm()).log10());
    }
    out
}
