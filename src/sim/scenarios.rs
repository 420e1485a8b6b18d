//! Scripted scenarios shared by tests and benchmarks.

use super::hybrid::{steady_state_locked, ClutchMode, EngineInput, Scenario, N_STATES};
use super::inputs::Piecewise;
use crate::model::driveline::DrivelineParams;

/// One drive-hour (or `t_end_s`) cycling through all gears, 1 → 12 → 1, 30 s per gear: at each
/// shift the clutch opens (0.2 s), the gear changes, the clutch closes (0.5 s). The engine-speed
/// PI reference jumps at the shift to the engine speed that matches the vehicle in the new gear
/// (1200 rpm · i_new/i_old) and ramps back to 1200 rpm over the next 28 s, so the truck
/// accelerates through the upshifts and engine-brakes through the downshifts as a driver would;
/// the road undulates within ±0.5 % with a 10 s knot spacing. Returns the scenario and its steady
/// initial state (locked, 1st gear, flat road).
pub fn mixed_gear_drive(
    p: &DrivelineParams,
    ratios: &[f64],
    t_end_s: f64,
) -> (Scenario, [f64; N_STATES], ClutchMode) {
    let n_gears = ratios.len();
    let seg = 30.0;
    let n_seg = (t_end_s / seg).ceil() as usize;
    let w = 1200.0 * std::f64::consts::PI / 30.0;
    let mut gear_p = Vec::new();
    let mut clutch_p = Vec::new();
    let mut wref_p = Vec::new();
    let mut t = 0.0;
    let mut g_prev = 1usize;
    for k in 0..n_seg {
        // 1,2,…,12,11,…,2,1,2,…
        let period = 2 * (n_gears - 1);
        let m = k % period;
        let g = if m < n_gears { m + 1 } else { period - m + 1 };
        let t1 = (t + seg).min(t_end_s);
        if k == 0 {
            gear_p.push((t, t1, 1.0, 1.0));
            clutch_p.push((t, t1, 0.0, 0.0));
            wref_p.push((t, t1, w, w));
        } else {
            let w_match = w * ratios[g - 1] / ratios[g_prev - 1];
            wref_p.push((t, t + 0.3, w, w));
            wref_p.push((t + 0.3, t + 28.0, w_match, w));
            wref_p.push((t + 28.0, t1, w, w));
            // shift at t + 0.3 s with the clutch open from t + 0.2 s to t + 0.5 s
            gear_p.push((t, t + 0.3, g_prev as f64, g_prev as f64));
            gear_p.push((t + 0.3, t1, g as f64, g as f64));
            clutch_p.push((t, t + 0.2, 0.0, 1.0));
            clutch_p.push((t + 0.2, t + 0.5, 1.0, 1.0));
            clutch_p.push((t + 0.5, t + 1.0, 1.0, 0.0));
            clutch_p.push((t + 1.0, t1, 0.0, 0.0));
        }
        g_prev = g;
        t = t1;
    }
    let knots = (t_end_s / 10.0).ceil() as usize;
    let slope_at = |k: usize| {
        if k == 0 {
            0.0
        } else {
            0.005 * ((k as f64) * 0.7).sin() * ((k as f64) * 0.13).cos()
        }
    };
    let slope_p: Vec<_> = (0..knots)
        .map(|k| {
            let (a, b) = (k as f64 * 10.0, ((k + 1) as f64 * 10.0).min(t_end_s));
            (a, b, slope_at(k), slope_at(k + 1))
        })
        .filter(|p| p.1 > p.0)
        .collect();
    let v0 = w * p.wheel_radius_m / (ratios[0] * p.final_drive_ratio);
    let (y0, _) = steady_state_locked(p, ratios, 1, v0, 0.0, true);
    let sc = Scenario {
        t_end_s,
        gear: Piecewise::new(gear_p).expect("contiguous"),
        clutch_x: Piecewise::new(clutch_p).expect("contiguous"),
        slope: Piecewise::new(slope_p).expect("contiguous"),
        brake_n: Piecewise::constant(t_end_s, 0.0),
        engine: EngineInput::SpeedReference(Piecewise::new(wref_p).expect("contiguous")),
        smoothing: true,
        standstill_events: false,
    };
    (sc, y0, ClutchMode::Locked)
}

/// The scenario with every input replaced by its samples at `fs_hz` (gear held, the rest linear
/// between samples), as a recorded drive at that rate would provide it.
pub fn sampled_inputs(sc: &Scenario, fs_hz: f64) -> Scenario {
    let t = sc.t_end_s;
    Scenario {
        t_end_s: t,
        gear: sc.gear.resampled(t, fs_hz, true),
        clutch_x: sc.clutch_x.resampled(t, fs_hz, false),
        slope: sc.slope.resampled(t, fs_hz, false),
        brake_n: sc.brake_n.resampled(t, fs_hz, false),
        engine: match &sc.engine {
            EngineInput::Torque(m) => EngineInput::Torque(m.resampled(t, fs_hz, false)),
            EngineInput::SpeedReference(r) => {
                EngineInput::SpeedReference(r.resampled(t, fs_hz, false))
            }
        },
        smoothing: sc.smoothing,
        standstill_events: sc.standstill_events,
    }
}
