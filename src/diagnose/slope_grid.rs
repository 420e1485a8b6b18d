//! The recorded slope on the 1 m distance grid and its cure for `slope_quantization`
//! (docs/diagnosis/method.md, step 3; [`super::extended`]).
//!
//! `slope_quantization`'s parameter is the slope sensor's resolution `Δ` (tan α per step): a
//! value above the nominal resolution replaces the recorded slope by its consistent
//! reconstruction from cells of width `Δ` on the 1 m distance grid, each widened by the
//! sensor's noise as the recording shows it ([`crate::signal::dequantise`]; a zero-phase
//! spatial reconstruction, the kind of cure the catalogue names; [`SlopeGrid::cured`]), so
//! the model does not see the steps. The road-slope low-pass of Myklebust & Eriksson (2012),
//! §5 (4·10⁻³ 1/m), would remove real grade on city hills (on the proof's seed-1 city drives,
//! 0.013–0.019 rms of grade against 0.005 of quantisation error); the reconstruction never
//! moves a sample more than `Δ/2` plus the noise's σ.
//!
//! Slope in tan α, distances in m.

use super::effect_parameters::Theta;
use crate::model::catalogue::Effect;
use crate::schema::Interpolation;
use crate::signal::dequantise::{dequantise, DequantiseConfig};
use crate::signal::distance::{
    fill_gaps, resample_columns_to_distance, DistanceMap, ResampleConfig,
};
use crate::signal::sensor_noise::{grid_step_s, SampleKind};
use crate::signal::sensor_noise_estimate::estimate_sensor_noise;
use crate::table::DriveLog;
use std::sync::{Arc, Mutex, OnceLock};

/// The recorded slope on the 1 m distance grid, for `slope_quantization`'s cure.
#[derive(Debug, Clone)]
pub struct SlopeGrid {
    /// Recorded slope on the grid (held, gaps filled), tan α.
    raw: Vec<f64>,
    /// Grid step, m.
    step_m: f64,
    /// The log's time ↔ distance map.
    map: DistanceMap,
    /// The slope sensor's white noise, estimated blind from the recording
    /// ([`estimate_sensor_noise`]; its flicker rate on a coarse step), tan α (0 when it cannot
    /// be estimated).
    noise_sigma: f64,
    /// The last cure ([`SlopeGrid::cured`]) by the bits of its resolution: a fit that has
    /// accepted `slope_quantization` simulates every later candidate on the same cure.
    last: Arc<Mutex<Option<CachedCure>>>,
}

/// A cure's resolution (its bits) and the cured slope on the log's rows.
type CachedCure = (u64, Vec<f64>);

impl SlopeGrid {
    /// The grid of `log`'s slope (`None` without a slope column or when the drive is too short
    /// to resample).
    pub fn new(log: &DriveLog) -> Option<SlopeGrid> {
        let recorded = log.signal("road_slope")?;
        let d =
            resample_columns_to_distance(log, Some(&["road_slope"]), &ResampleConfig::default())
                .ok()?;
        let raw = fill_gaps(d.signal("road_slope")?, Interpolation::Hold)?;
        let noise_sigma = grid_step_s(log)
            .ok()
            .and_then(|dt| {
                estimate_sensor_noise(
                    "road_slope",
                    "1",
                    recorded,
                    dt,
                    SampleKind::of_column("road_slope"),
                )
                .ok()
            })
            .map(|e| e.sigma_white)
            .filter(|s| s.is_finite())
            .unwrap_or(0.0);
        Some(SlopeGrid {
            raw,
            step_m: d.step_m,
            map: d.map,
            noise_sigma,
            last: Arc::default(),
        })
    }

    /// The slope sensor's estimated white noise, tan α.
    pub fn noise_sigma(&self) -> f64 {
        self.noise_sigma
    }

    /// The slope with a sensor resolution of `resolution` (tan α per step) undone, on the
    /// log's rows: [`dequantise`] on the grid with its default settings and every cell widened
    /// by the sensor's estimated noise (a reading flipped by noise lies within about σ of its
    /// cell, not inside it), mapped back through the time ↔ distance map; `None` for a
    /// resolution that is not finite and positive.
    pub fn cured(&self, resolution: f64) -> Option<Vec<f64>> {
        let key = resolution.to_bits();
        // a poisoned lock (a thread panicked while holding it) only loses the kept cure
        if let Ok(g) = self.last.lock() {
            if let Some((k, v)) = g.as_ref() {
                if *k == key {
                    return Some(v.clone());
                }
            }
        }
        let v = self.cured_with(
            resolution,
            &DequantiseConfig {
                cell_margin: self.noise_sigma,
                ..DequantiseConfig::default()
            },
        )?;
        if let Ok(mut g) = self.last.lock() {
            *g = Some((key, v.clone()));
        }
        Some(v)
    }

    /// [`SlopeGrid::cured`] with the reconstruction's settings `cfg` (its cell margin as given).
    pub fn cured_with(&self, resolution: f64, cfg: &DequantiseConfig) -> Option<Vec<f64>> {
        let g = dequantise(&self.raw, resolution, cfg).ok()?;
        Some(self.map.to_time_axis(&g, self.step_m))
    }
}

/// The slope `theta` asks for: the cure of `log`'s slope grid (built in `grid` on first use)
/// at `theta`'s slope resolution when it is above `nominal`'s, else `None` (the recorded
/// slope).
pub(super) fn cured_slope(
    log: &DriveLog,
    grid: &OnceLock<Option<SlopeGrid>>,
    theta: &Theta,
    nominal: &Theta,
) -> Option<Vec<f64>> {
    let r = theta.get(Effect::SlopeQuantization);
    if r > nominal.get(Effect::SlopeQuantization) {
        grid.get_or_init(|| SlopeGrid::new(log)).as_ref()?.cured(r)
    } else {
        None
    }
}
