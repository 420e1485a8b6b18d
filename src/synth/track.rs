//! GNSS for synthetic drives: a plausible track in the plane along the road, placed on the WGS84
//! ellipsoid around an origin, and a receiver's readings of it.
//!
//! # Track in the plane
//! The road's distance axis `s` (m, the travelled distance of the drive, taken as horizontal
//! distance: the two differ by `1/cos α − 1`, 2·10⁻⁴ at a 2 % grade) is laid out on a 1 m grid
//! with a random horizontal curvature `κ(s)` (1/m, + turning right): a first-order
//! Gauss–Markov process in distance,
//! `κ_{k+1} = φ κ_k + σ_κ √(1 − φ²) ξ_k`, `φ = exp(−Δs / L_κ)`, `ξ_k ~ N(0, 1)`,
//! started from `κ_0 = σ_κ ξ`, with `σ_κ = ` [`GnssConfig::curvature_rms_fraction`]`/R_min` and
//! correlation length `L_κ` = [`GnssConfig::curvature_length_m`], each value then clamped to
//! `|κ| ≤ 1/R_min`: no curve is tighter than the road's smallest horizontal radius `R_min`.
//! `R_min` is [`GnssConfig::min_radius_m`] or, when `None`, the point-mass design rule
//! `R_min = v_d² / a_lat` at the drive's cruise speed `v_d` with the design lateral
//! acceleration `a_lat` = [`GnssConfig::design_lateral_accel_mps2`] (`g (e + f)`, superelevation
//! plus side friction: 1.8 m/s² = 9.81 · (0.06 + 0.12), e.g. 340 m at 89 km/h, 107 m at
//! 50 km/h), and never below 30 m. The heading `θ` (rad, clockwise from north) starts uniform in
//! `[0, 2π)` and integrates the curvature, `θ_{k+1} = θ_k + κ_k Δs`; east and north positions
//! integrate `(sin θ, cos θ)` at the step's mid heading. Draws come from one
//! [`Xoshiro256StarStar`] seeded with the drive's seed, so the same seed gives the same track.
//!
//! # On the ellipsoid
//! Latitude and longitude are integrated step by step from the origin
//! ([`GnssConfig::origin_lat_deg`], [`GnssConfig::origin_lon_deg`]):
//! `Δφ = Δn / M(φ)`, `Δλ = Δe / (N(φ) cos φ)` with the WGS84 meridian and prime-vertical radii
//! of curvature `M = a(1 − e²)/(1 − e² sin²φ)^{3/2}`, `N = a/√(1 − e² sin²φ)` at the step's
//! mid latitude; so every 1 m step has its planar length on the ellipsoid (to ~10⁻⁹ relative),
//! also on tracks long enough for the scale of a flat projection to drift. Between grid points
//! latitude and longitude are linear in distance. The altitude is the road's elevation at the
//! distance (m, linear between the road's grid points, held beyond its ends).
//!
//! # Receiver
//! A receiver's error is correlated over tens of seconds (atmosphere, multipath; measured on
//! the car drive, see [`crate::road::gnss_profile`]) and comes with a little white noise. Its
//! readings are the true position plus three independent first-order Gauss–Markov errors in
//! time — north and east with σ [`GnssConfig::horizontal_error_sigma_m`], up with σ
//! [`GnssConfig::vertical_error_sigma_m`], all with time constant
//! [`GnssConfig::error_time_constant_s`] (stationary from the start:
//! `e_{i+1} = φ_i e_i + σ √(1 − φ_i²) ξ_i`, `φ_i = exp(−Δt_i / τ)`), sampled at the drive's
//! samples and converted to degrees with the local radii. The CAN layer ([`super::can`]) then
//! adds white noise (σ [`GnssConfig::horizontal_noise_sigma_m`] and
//! [`GnssConfig::vertical_noise_sigma_m`], in degrees with the radii at the origin) and
//! quantises: latitude and longitude 10⁻⁷ deg, altitude 0.1 m, at
//! [`GnssConfig::rate_hz`] on `/gnss/fix` ([`gnss_message`]), as the bundled `j1939-json-mcap`
//! mapping names them. Defaults: 2 m (per axis) and 1.5 m correlated over 30 s, plus 0.5 m and
//! 0.3 m white: 2.1 m per horizontal axis and 1.5 m vertical in all.

use super::can::{CanChannel, CanMessage, Dropouts, TorqueReference};
use crate::rng::Xoshiro256StarStar;
use crate::road::wgs84::{WGS84_A_M, WGS84_F};
use std::f64::consts::TAU;
use thiserror::Error;

/// A GNSS setting out of its domain.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("gnss {parameter} = {value} must be {requirement}")]
pub struct TrackError {
    /// Parameter name with unit.
    pub parameter: &'static str,
    /// The value given.
    pub value: f64,
    /// What it must be.
    pub requirement: &'static str,
}

/// Track and receiver settings. Units in the names.
#[derive(Debug, Clone, PartialEq)]
pub struct GnssConfig {
    /// Latitude of the road's start, WGS84 deg (within ±80°).
    pub origin_lat_deg: f64,
    /// Longitude of the road's start, WGS84 deg (within ±179°).
    pub origin_lon_deg: f64,
    /// Smallest horizontal curve radius, m; `None`: `v_d²/a_lat` at the cruise speed.
    pub min_radius_m: Option<f64>,
    /// Design lateral acceleration `g (e + f)` for the default radius, m/s².
    pub design_lateral_accel_mps2: f64,
    /// RMS curvature as a fraction of `1/R_min`.
    pub curvature_rms_fraction: f64,
    /// Correlation length of the curvature, m.
    pub curvature_length_m: f64,
    /// Fix rate, Hz.
    pub rate_hz: f64,
    /// Correlated horizontal error per axis (north, east), σ in m.
    pub horizontal_error_sigma_m: f64,
    /// Correlated vertical error, σ in m.
    pub vertical_error_sigma_m: f64,
    /// Time constant of the correlated errors, s.
    pub error_time_constant_s: f64,
    /// White horizontal noise per axis added on the wire, σ in m.
    pub horizontal_noise_sigma_m: f64,
    /// White vertical noise added on the wire, σ in m.
    pub vertical_noise_sigma_m: f64,
}

impl Default for GnssConfig {
    /// Origin 57.7° N 11.9° E (Gothenburg), radius from the cruise speed at 1.8 m/s², RMS
    /// curvature a quarter of `1/R_min` correlated over 250 m, 1 Hz fixes, errors as in the
    /// module doc.
    fn default() -> Self {
        Self {
            origin_lat_deg: 57.7,
            origin_lon_deg: 11.9,
            min_radius_m: None,
            design_lateral_accel_mps2: 1.8,
            curvature_rms_fraction: 0.25,
            curvature_length_m: 250.0,
            rate_hz: 1.0,
            horizontal_error_sigma_m: 2.0,
            vertical_error_sigma_m: 1.5,
            error_time_constant_s: 30.0,
            horizontal_noise_sigma_m: 0.5,
            vertical_noise_sigma_m: 0.3,
        }
    }
}

/// Smallest radius the default rule gives, m.
const MIN_RADIUS_FLOOR_M: f64 = 30.0;

/// WGS84 meridian (M) and prime-vertical (N) radii of curvature at latitude `lat_rad`, m.
pub fn radii_of_curvature(lat_rad: f64) -> (f64, f64) {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let w2 = 1.0 - e2 * lat_rad.sin().powi(2);
    let n = WGS84_A_M / w2.sqrt();
    (n * (1.0 - e2) / w2, n)
}

impl GnssConfig {
    /// Checks every setting.
    ///
    /// # Errors
    /// The first setting out of its domain.
    pub fn validate(&self) -> Result<(), TrackError> {
        let check = |parameter, value: f64, ok: bool, requirement| {
            if ok && value.is_finite() {
                Ok(())
            } else {
                Err(TrackError {
                    parameter,
                    value,
                    requirement,
                })
            }
        };
        check(
            "origin_lat_deg",
            self.origin_lat_deg,
            self.origin_lat_deg.abs() <= 80.0,
            "within ±80°",
        )?;
        check(
            "origin_lon_deg",
            self.origin_lon_deg,
            self.origin_lon_deg.abs() <= 179.0,
            "within ±179°",
        )?;
        if let Some(r) = self.min_radius_m {
            check("min_radius_m", r, r > 0.0, "finite and > 0")?;
        }
        for (name, v) in [
            ("design_lateral_accel_mps2", self.design_lateral_accel_mps2),
            ("curvature_length_m", self.curvature_length_m),
            ("rate_hz", self.rate_hz),
            ("error_time_constant_s", self.error_time_constant_s),
        ] {
            check(name, v, v > 0.0, "finite and > 0")?;
        }
        for (name, v) in [
            ("curvature_rms_fraction", self.curvature_rms_fraction),
            ("horizontal_error_sigma_m", self.horizontal_error_sigma_m),
            ("vertical_error_sigma_m", self.vertical_error_sigma_m),
            ("horizontal_noise_sigma_m", self.horizontal_noise_sigma_m),
            ("vertical_noise_sigma_m", self.vertical_noise_sigma_m),
        ] {
            check(name, v, v >= 0.0, "finite and >= 0")?;
        }
        Ok(())
    }

    /// `R_min` for a drive at cruise speed `cruise_mps` (module doc), m.
    pub fn min_radius_for(&self, cruise_mps: f64) -> f64 {
        self.min_radius_m.unwrap_or_else(|| {
            (cruise_mps * cruise_mps / self.design_lateral_accel_mps2).max(MIN_RADIUS_FLOOR_M)
        })
    }
}

/// A track in the plane on a 1 m distance grid (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneTrack {
    /// Smallest curve radius allowed, m.
    pub min_radius_m: f64,
    /// Curvature per step, 1/m (+ right).
    pub curvature_per_m: Vec<f64>,
    /// Heading at each grid point, rad clockwise from north.
    pub heading_rad: Vec<f64>,
    /// East of the origin, m.
    pub east_m: Vec<f64>,
    /// North of the origin, m.
    pub north_m: Vec<f64>,
    /// Latitude, WGS84 deg.
    pub latitude_deg: Vec<f64>,
    /// Longitude, WGS84 deg.
    pub longitude_deg: Vec<f64>,
}

/// Grid step of the plane track, m.
pub const TRACK_STEP_M: f64 = 1.0;

/// The track of a road at least `length_m` long (grid `k·1 m`, k = 0 … ⌈length_m⌉), smallest
/// radius `min_radius_m`, placed at the configured origin, from `seed` (module doc).
///
/// # Errors
/// [`TrackError`] for bad settings or a length or radius that is not finite and positive.
pub fn plane_track(
    cfg: &GnssConfig,
    length_m: f64,
    min_radius_m: f64,
    seed: u64,
) -> Result<PlaneTrack, TrackError> {
    cfg.validate()?;
    for (parameter, value) in [("length_m", length_m), ("min_radius_m", min_radius_m)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(TrackError {
                parameter,
                value,
                requirement: "finite and > 0",
            });
        }
    }
    let n = (length_m / TRACK_STEP_M).ceil() as usize + 1;
    let mut rng = Xoshiro256StarStar::seed_from_u64(seed ^ 0x7472_6163_6b00);
    let k_max = 1.0 / min_radius_m;
    let sigma = cfg.curvature_rms_fraction * k_max;
    let phi = (-TRACK_STEP_M / cfg.curvature_length_m).exp();
    let drive = sigma * (1.0 - phi * phi).sqrt();
    let mut t = PlaneTrack {
        min_radius_m,
        curvature_per_m: Vec::with_capacity(n),
        heading_rad: Vec::with_capacity(n),
        east_m: Vec::with_capacity(n),
        north_m: Vec::with_capacity(n),
        latitude_deg: Vec::with_capacity(n),
        longitude_deg: Vec::with_capacity(n),
    };
    let mut theta = rng.uniform(0.0, TAU);
    let mut kappa = (sigma * rng.standard_normal()).clamp(-k_max, k_max);
    let (mut e, mut nn) = (0.0, 0.0);
    // angles integrated from the origin (rad), so the origin itself is exact in degrees
    let lat0 = cfg.origin_lat_deg.to_radians();
    let (mut dlat, mut dlon) = (0.0f64, 0.0f64);
    for k in 0..n {
        t.curvature_per_m.push(kappa);
        t.heading_rad.push(theta);
        t.east_m.push(e);
        t.north_m.push(nn);
        t.latitude_deg.push(cfg.origin_lat_deg + dlat.to_degrees());
        t.longitude_deg.push(cfg.origin_lon_deg + dlon.to_degrees());
        let lat = lat0 + dlat;
        if k + 1 == n {
            break;
        }
        let mid = theta + 0.5 * kappa * TRACK_STEP_M;
        let (de, dn) = (mid.sin() * TRACK_STEP_M, mid.cos() * TRACK_STEP_M);
        let (m, _) = radii_of_curvature(lat);
        let mid_lat = lat + 0.5 * dn / m;
        let (m, nv) = radii_of_curvature(mid_lat);
        dlat += dn / m;
        dlon += de / (nv * mid_lat.cos());
        e += de;
        nn += dn;
        theta += kappa * TRACK_STEP_M;
        kappa = (phi * kappa + drive * rng.standard_normal()).clamp(-k_max, k_max);
    }
    Ok(t)
}

/// Linear interpolation of `v` on the grid `x0 + k·step` at `x`, held beyond the ends.
fn on_grid(v: &[f64], x0: f64, step: f64, x: f64) -> f64 {
    let f = ((x - x0) / step).max(0.0);
    let k = f.floor() as usize;
    if k + 1 >= v.len() {
        return v[v.len() - 1];
    }
    v[k] + (f - k as f64) * (v[k + 1] - v[k])
}

/// GNSS of one drive on its samples: the true position and the receiver's readings.
#[derive(Debug, Clone, PartialEq)]
pub struct GnssTrack {
    /// The track in the plane and on the ellipsoid.
    pub plane: PlaneTrack,
    /// True latitude at each drive sample, deg.
    pub latitude_deg: Vec<f64>,
    /// True longitude at each drive sample, deg.
    pub longitude_deg: Vec<f64>,
    /// True altitude (the road's elevation) at each drive sample, m.
    pub altitude_m: Vec<f64>,
    /// Receiver latitude (true + correlated error), deg.
    pub receiver_latitude_deg: Vec<f64>,
    /// Receiver longitude (true + correlated error), deg.
    pub receiver_longitude_deg: Vec<f64>,
    /// Receiver altitude (true + correlated error), m.
    pub receiver_altitude_m: Vec<f64>,
}

impl GnssTrack {
    /// The receiver's readings as truth columns of the CAN layer (`latitude`, `longitude`,
    /// `altitude`).
    pub fn receiver_columns(&self) -> Vec<(String, Vec<f64>)> {
        vec![
            ("latitude".into(), self.receiver_latitude_deg.clone()),
            ("longitude".into(), self.receiver_longitude_deg.clone()),
            ("altitude".into(), self.receiver_altitude_m.clone()),
        ]
    }
}

/// The GNSS of a drive: track of the road (elevation `elevation_m` on the grid `k·road_step_m`)
/// at the drive's samples (times `t_s`, travelled distance `distance_m`), with `R_min` from
/// `cruise_mps` unless configured, from `seed` (module doc).
///
/// # Errors
/// [`TrackError`] for bad settings, an empty road or drive.
pub fn gnss_track(
    cfg: &GnssConfig,
    road_step_m: f64,
    elevation_m: &[f64],
    t_s: &[f64],
    distance_m: &[f64],
    cruise_mps: f64,
    seed: u64,
) -> Result<GnssTrack, TrackError> {
    if elevation_m.is_empty() || t_s.is_empty() || t_s.len() != distance_m.len() {
        return Err(TrackError {
            parameter: "samples",
            value: t_s.len().min(elevation_m.len()) as f64,
            requirement:
                "a road and a drive of at least one sample each, times and distances alike",
        });
    }
    let x_max = distance_m.iter().fold(0.0f64, |m, &x| m.max(x));
    let plane = plane_track(cfg, x_max.max(1.0), cfg.min_radius_for(cruise_mps), seed)?;
    let at = |v: &[f64], x: f64| on_grid(v, 0.0, TRACK_STEP_M, x);
    let latitude_deg: Vec<f64> = distance_m
        .iter()
        .map(|&x| at(&plane.latitude_deg, x))
        .collect();
    let longitude_deg: Vec<f64> = distance_m
        .iter()
        .map(|&x| at(&plane.longitude_deg, x))
        .collect();
    let altitude_m: Vec<f64> = distance_m
        .iter()
        .map(|&x| on_grid(elevation_m, 0.0, road_step_m, x))
        .collect();
    let mut rng = Xoshiro256StarStar::seed_from_u64(seed ^ 0x676e_7373_0000);
    let (sh, sv, tau) = (
        cfg.horizontal_error_sigma_m,
        cfg.vertical_error_sigma_m,
        cfg.error_time_constant_s,
    );
    let mut err = [
        sh * rng.standard_normal(),
        sh * rng.standard_normal(),
        sv * rng.standard_normal(),
    ];
    let n = t_s.len();
    let (mut rlat, mut rlon, mut ralt) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    for i in 0..n {
        if i > 0 {
            let phi = (-(t_s[i] - t_s[i - 1]) / tau).exp();
            let w = (1.0 - phi * phi).max(0.0).sqrt();
            for (e, s) in err.iter_mut().zip([sh, sh, sv]) {
                *e = phi * *e + s * w * rng.standard_normal();
            }
        }
        let lat = latitude_deg[i].to_radians();
        let (m, nv) = radii_of_curvature(lat);
        rlat.push(latitude_deg[i] + (err[0] / m).to_degrees());
        rlon.push(longitude_deg[i] + (err[1] / (nv * lat.cos())).to_degrees());
        ralt.push(altitude_m[i] + err[2]);
    }
    Ok(GnssTrack {
        plane,
        latitude_deg,
        longitude_deg,
        altitude_m,
        receiver_latitude_deg: rlat,
        receiver_longitude_deg: rlon,
        receiver_altitude_m: ralt,
    })
}

/// The `/gnss/fix` message (`GNSS`) of the bus: `latitude` and `longitude` (deg, 10⁻⁷ deg
/// steps, ±90° / ±180°) and `altitude` (m, 0.1 m steps, −500 … 9000 m as the drive-log schema
/// allows) at [`GnssConfig::rate_hz`], phase 16 ms (after the J1939 topics' 0 … 14 ms), with the
/// white noise of the module doc in degrees at the origin's radii. No dropouts.
pub fn gnss_message(cfg: &GnssConfig) -> CanMessage {
    let lat = cfg.origin_lat_deg.to_radians();
    let (m, n) = radii_of_curvature(lat);
    let ch = |column: &str, unit: &str, resolution, sigma, lo, hi| CanChannel {
        column: column.into(),
        field: column.into(),
        wire_unit: unit.into(),
        torque_reference: TorqueReference::None,
        resolution,
        noise_sigma: sigma,
        delay_s: 0.0,
        wire_min: lo,
        wire_max: hi,
    };
    CanMessage {
        name: "GNSS".into(),
        topic: "/gnss/fix".into(),
        rate_hz: cfg.rate_hz,
        phase_s: 0.016,
        dropouts: Dropouts::NONE,
        channels: vec![
            ch(
                "latitude",
                "deg",
                1e-7,
                (cfg.horizontal_noise_sigma_m / m).to_degrees(),
                -90.0,
                90.0,
            ),
            ch(
                "longitude",
                "deg",
                1e-7,
                (cfg.horizontal_noise_sigma_m / (n * lat.cos())).to_degrees(),
                -180.0,
                180.0,
            ),
            ch(
                "altitude",
                "m",
                0.1,
                cfg.vertical_noise_sigma_m,
                -500.0,
                9000.0,
            ),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::road::wgs84::chord_distance_m;

    #[test]
    fn curves_never_tighter_than_the_minimum_radius_and_steps_keep_their_length() {
        let cfg = GnssConfig {
            curvature_rms_fraction: 0.8, // often at the bound
            ..GnssConfig::default()
        };
        let t = plane_track(&cfg, 20_000.0, 150.0, 3).unwrap();
        assert_eq!(t.east_m.len(), 20_001);
        let k_max = t.curvature_per_m.iter().fold(0.0f64, |m, k| m.max(k.abs()));
        assert!(k_max <= 1.0 / 150.0 + 1e-15, "{k_max}");
        assert!(k_max > 0.99 / 150.0, "the bound is reached: {k_max}");
        for w in t.heading_rad.windows(2) {
            assert!((w[1] - w[0]).abs() <= 1.0 / 150.0 + 1e-15);
        }
        // every 1 m step is 1 m on the ellipsoid (chord), to 1e-6 relative
        let mut worst = 0.0f64;
        for k in 1..t.latitude_deg.len() {
            let c = chord_distance_m(
                t.latitude_deg[k - 1],
                t.longitude_deg[k - 1],
                t.latitude_deg[k],
                t.longitude_deg[k],
            );
            worst = worst.max((c - 1.0).abs());
        }
        assert!(worst < 1e-6, "step length off by {worst} m");
        assert_eq!(t.latitude_deg[0], 57.7);
        assert_eq!(t.longitude_deg[0], 11.9);
    }

    #[test]
    fn same_seed_same_track_and_default_radius_from_the_speed() {
        let cfg = GnssConfig::default();
        let a = plane_track(&cfg, 500.0, 300.0, 9).unwrap();
        let b = plane_track(&cfg, 500.0, 300.0, 9).unwrap();
        let c = plane_track(&cfg, 500.0, 300.0, 10).unwrap();
        assert_eq!(a, b);
        assert_ne!(a.east_m, c.east_m);
        assert!((cfg.min_radius_for(89.0 / 3.6) - 339.5).abs() < 0.1);
        assert_eq!(cfg.min_radius_for(1.0), MIN_RADIUS_FLOOR_M);
        let bad = GnssConfig {
            origin_lat_deg: 85.0,
            ..cfg
        };
        assert_eq!(
            plane_track(&bad, 10.0, 100.0, 0).unwrap_err().parameter,
            "origin_lat_deg"
        );
    }
}
