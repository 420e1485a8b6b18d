//! Road profiles from real tracks: a synthetic GNSS track with a known hill, the VECTO Long Haul
//! cycle, the measured car drive against its OBD speed and IMU pitch, the slope spectra against
//! `fixtures/reference/road_profile.json` (fixtures/gen/make_road_profile_reference.py), and bad
//! input through the CLI.

use crate::common::*;
use fleetdyn::ingest::{ingest_file, IngestOptions};
use fleetdyn::report::spectrum;
use fleetdyn::road::gnss_profile::{gnss_profile, gnss_profile_of};
use fleetdyn::road::profile::{GnssProfileConfig, ProfileError, ProfileSource, RoadProfile};
use fleetdyn::road::profile_table::read_profile_column;
use fleetdyn::road::vdri::{cycle_profile, read_vdri};
use fleetdyn::road::wgs84::{WGS84_A_M, WGS84_F};
use fleetdyn::table::{DriveLog, DriveMeta, Signal};
use std::path::Path;
use std::process::Command;

fn reference() -> serde_json::Value {
    let text = std::fs::read_to_string(fixture("fixtures/reference/road_profile.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn num(v: &serde_json::Value, path: &[&str]) -> f64 {
    let mut v = v;
    for p in path {
        v = match p.parse::<usize>() {
            Ok(i) => &v[i],
            Err(_) => &v[*p],
        };
    }
    v.as_f64()
        .unwrap_or_else(|| panic!("{path:?} in the reference"))
}

/// Fraction of a spectrum's power below `f0` (its cumulative power, linear between bins).
fn power_below(sp: &spectrum::Spectrum, f0: f64) -> f64 {
    let f = &sp.psd.freq_hz;
    let k = f.partition_point(|x| *x < f0);
    let w = (f0 - f[k - 1]) / (f[k] - f[k - 1]);
    sp.cumulative[k - 1] + w * (sp.cumulative[k] - sp.cumulative[k - 1])
}

/// Checks the knees and the shares of power below 3e-4 and 1e-3 1/m (the highway and city knees of
/// Myklebust & Eriksson (2012), §4) against the reference entry, to `rel` (knees) and `abs`
/// (shares); prints them.
fn check_spectrum(label: &str, sp: &spectrum::Spectrum, r: &serde_json::Value, rel: f64, abs: f64) {
    let (b3, b1) = (power_below(sp, 3e-4), power_below(sp, 1e-3));
    println!(
        "{label}, nperseg {}: 90 % below {:.3e} 1/m, 99 % below {:.3e} 1/m; {:.1} % of the power below 3e-4, {:.1} % below 1e-3 ({} segments, dof {:.1})",
        sp.psd.nperseg, sp.knee_90, sp.knee_99, 100.0 * b3, 100.0 * b1, sp.psd.n_segments, sp.psd.dof
    );
    let (k90, k99) = (num(r, &["knee_90_per_m"]), num(r, &["knee_99_per_m"]));
    assert!(
        (sp.knee_90 - k90).abs() < rel * k90,
        "{} vs {k90}",
        sp.knee_90
    );
    assert!(
        (sp.knee_99 - k99).abs() < rel * k99,
        "{} vs {k99}",
        sp.knee_99
    );
    assert!((b3 - num(r, &["power_below_3e-4"])).abs() < abs, "{b3}");
    assert!((b1 - num(r, &["power_below_1e-3"])).abs() < abs, "{b1}");
}

/// Deterministic normal deviates (xorshift64* and Box–Muller), so the noisy track is the same
/// on every run.
struct Normal(u64);

impl Normal {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn sample(&mut self, sigma: f64) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        sigma * (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// Meridian arc on WGS84 from `lat1` to `lat2` (deg) by composite Simpson on
/// M(φ) = a(1−e²)/(1−e² sin²φ)^{3/2}: the true along-track distance of a northbound track.
fn meridian_arc_m(lat1: f64, lat2: f64) -> f64 {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let m = |phi: f64| WGS84_A_M * (1.0 - e2) / (1.0 - e2 * phi.sin().powi(2)).powf(1.5);
    let (a, b) = (lat1.to_radians(), lat2.to_radians());
    let n = 20_000;
    let h = (b - a) / n as f64;
    let mut s = m(a) + m(b);
    for k in 1..n {
        s += m(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

/// Latitude reached after `x` m northbound from `lat0` along the meridian (Newton on the arc).
fn lat_after(lat0: f64, x: f64) -> f64 {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let mut lat = lat0 + x / 111_000.0;
    for _ in 0..4 {
        let phi = lat.to_radians();
        let m = WGS84_A_M * (1.0 - e2) / (1.0 - e2 * phi.sin().powi(2)).powf(1.5);
        lat -= (meridian_arc_m(lat0, lat) - x) / m * 180.0 / std::f64::consts::PI;
    }
    lat
}

const HILL_AMPLITUDE_M: f64 = 15.0;
const HILL_WAVELENGTH_M: f64 = 2000.0;

fn hill(x: f64) -> (f64, f64) {
    let k = 2.0 * std::f64::consts::PI / HILL_WAVELENGTH_M;
    (
        100.0 + HILL_AMPLITUDE_M * (k * x).sin(),
        HILL_AMPLITUDE_M * k * (k * x).cos(),
    )
}

/// A northbound track on the meridian 10° E from 56° N at 1 Hz: 150 s at 20 m/s, a 60 s stop
/// (GNSS speed reading 0.03 m/s, position wander σ = `stop_sigma_m`), 150 s at 20 m/s, position
/// noise σ = `pos_sigma_m` while moving; altitude on a sinusoidal hill (15 m, 2 km wavelength)
/// plus noise σ = `alt_sigma_m`.
fn synthetic_track(
    pos_sigma_m: f64,
    stop_sigma_m: f64,
    alt_sigma_m: f64,
    with_speed: bool,
) -> DriveLog {
    let mut rng = Normal(0x5eed_0005_0003);
    let (mut t, mut lat, mut lon, mut alt, mut v) = (vec![], vec![], vec![], vec![], vec![]);
    let m_per_deg_lat = 111_360.0; // near 56° N, to turn metres of noise into degrees
    let m_per_deg_lon = m_per_deg_lat * 56f64.to_radians().cos();
    for k in 0..=360i64 {
        let ts = k as f64;
        let (x, speed, sigma) = if ts <= 150.0 {
            (20.0 * ts, 20.0, pos_sigma_m)
        } else if ts < 210.0 {
            (3000.0, 0.03, stop_sigma_m)
        } else {
            (3000.0 + 20.0 * (ts - 210.0), 20.0, pos_sigma_m)
        };
        t.push(T0_NS + k * 1_000_000_000);
        lat.push(lat_after(56.0, x) + rng.sample(sigma) / m_per_deg_lat);
        lon.push(10.0 + rng.sample(sigma) / m_per_deg_lon);
        alt.push(hill(x).0 + rng.sample(alt_sigma_m));
        v.push(speed);
    }
    let sig = |name: &str, unit: &str, values: Vec<f64>| Signal {
        name: name.into(),
        unit: unit.into(),
        values,
    };
    let mut signals = vec![
        sig("latitude", "deg", lat),
        sig("longitude", "deg", lon),
        sig("altitude", "m", alt),
    ];
    if with_speed {
        signals.insert(0, sig("vehicle_speed", "m/s", v));
    }
    DriveLog {
        meta: DriveMeta {
            drive_id: "synthetic".into(),
            vehicle_id: None,
            source_file: "synthetic-track".into(),
            segment: None,
        },
        timestamp_ns: t,
        signals,
    }
}

/// (max |Δz| m, max |Δs|, rms Δs) against the hill, farther than `edge` grid points from the
/// ends, and within them.
fn hill_errors(p: &RoadProfile, edge: usize) -> ((f64, f64, f64), (f64, f64, f64)) {
    let z = p.elevation_smoothed_m.as_ref().unwrap();
    let n = p.distance_m.len();
    let mut acc = [(0.0f64, 0.0f64, 0.0f64, 0usize); 2];
    for (k, &x) in p.distance_m.iter().enumerate() {
        let (zt, st) = hill(x);
        let (dz, ds) = ((z[k] - zt).abs(), (p.slope[k] - st).abs());
        let a = &mut acc[usize::from(k < edge || k + edge >= n)];
        *a = (a.0.max(dz), a.1.max(ds), a.2 + ds * ds, a.3 + 1);
    }
    let f = |a: (f64, f64, f64, usize)| (a.0, a.1, (a.2 / a.3 as f64).sqrt());
    (f(acc[0]), f(acc[1]))
}

#[test]
fn synthetic_track_recovers_distance_elevation_and_slope() {
    let truth_m = meridian_arc_m(56.0, lat_after(56.0, 6000.0));
    assert!((truth_m - 6000.0).abs() < 1e-6, "{truth_m}");

    // Noise-free: the track length is the meridian arc to c³/(24R²) per 20 m chord (1e-12
    // relative) plus coordinate rounding (~1e-9 m per step): bound 1e-9 relative. The stop's
    // 59 fixes collapse into one point and add nothing.
    let log = synthetic_track(0.0, 0.0, 0.0, true);
    let p = gnss_profile(&log, &GnssProfileConfig::default()).unwrap();
    let ProfileSource::Gnss(g) = &p.source else {
        panic!()
    };
    assert_eq!((g.fixes, g.standstill_fixes), (361, 59));
    let rel = (g.distance_m - truth_m) / truth_m;
    println!(
        "synthetic track, noise-free: {:.9} m vs meridian arc {truth_m:.9} m ({rel:.1e})",
        g.distance_m
    );
    assert!(rel.abs() < 1e-9, "{rel}");
    assert_eq!(p.distance_m.len(), 6001);
    // The noise-free hill comes back but for the linear interpolation between 20 m fixes
    // ((20 m)²/8·z'' = 7e-3 m) and the filter's 1e-5 loss, farther than two cut-off
    // wavelengths (600 m) from the ends: bounds 1e-2 m and 1e-4 in slope (measured 5.1e-3 m,
    // 1.6e-5). Nearer the ends the zero-phase filter sees one side only and the matched edge
    // continues a straight line where the hill curves: a systematic error, measured 0.47 m and
    // 1.4e-2 at the very ends; bounds 0.6 m and 2e-2.
    let (interior, ends) = hill_errors(&p, 600);
    println!("  interior: {interior:?}; ends: {ends:?} (max |dz| m, max |ds|, rms ds)");
    assert!(interior.0 < 1e-2 && interior.1 < 1e-4, "{interior:?}");
    assert!(ends.0 < 0.6 && ends.1 < 2e-2, "{ends:?}");

    // Noisy: positions σ = 0.3 m while moving (1 m while standing), altitude σ = 0.5 m.
    // Position noise lengthens each 20 m step by about σ²/d = 4.5e-3 m: 1.35 m (2.3e-4) over
    // the 300 steps; bound 1e-3 relative. The stop's 1 m wander is gated by speed, and without
    // speed by the 10 m anchor radius (wander beyond 10 m at σ = 1 m: probability ~1e-22).
    for with_speed in [true, false] {
        let log = synthetic_track(0.3, 1.0, 0.5, with_speed);
        let p = gnss_profile(&log, &GnssProfileConfig::default()).unwrap();
        let ProfileSource::Gnss(g) = &p.source else {
            panic!()
        };
        let total = g.distance_m;
        let rel = (total - truth_m) / truth_m;
        println!(
            "synthetic track (speed {with_speed}): {total:.2} m vs {truth_m:.2} m ({rel:.2e}), {} standstill fixes",
            g.standstill_fixes
        );
        assert!(rel.abs() < 1e-3, "{rel}");
        // 59 fixes read 0.03 m/s; by radius, the fix at 210 s (speed 20 m/s, but still at the
        // stop's position) stands too
        assert_eq!(
            g.standstill_fixes,
            if with_speed { 59 } else { 60 },
            "{g:?}"
        );

        // Elevation and slope against the hill. Altitude noise σ = 0.5 m per 20 m fix through
        // the 300 m low-pass leaves σ_z ≈ σ·√(2Δ·B) ≈ 0.18 m (noise bandwidth B ≈ fc) and
        // σ_s ≈ σ·2π·√(2Δ·0.37·fc³) ≈ 2.3e-3 in slope. Interior: max |Δz| < 0.8 m (4σ), max
        // |Δs| < 1e-2, rms < 4e-3 (the slope amplitude is 4.7e-2). Ends (600 m): the
        // systematic edge error above plus one-sided noise; measured 0.81 m and 1.7e-2, bounds
        // 1.2 m and 2.5e-2.
        let (interior, ends) = hill_errors(&p, 600);
        println!("  interior: {interior:?}; ends: {ends:?} (max |dz| m, max |ds|, rms ds)");
        assert!(
            interior.0 < 0.8 && interior.1 < 1e-2 && interior.2 < 4e-3,
            "{interior:?}"
        );
        assert!(ends.0 < 1.2 && ends.1 < 2.5e-2, "{ends:?}");
        // positions on the grid follow the meridian
        let lat = p.latitude_deg.as_ref().unwrap();
        let mid = lat_after(56.0, 3000.0);
        assert!((lat[3000] - mid).abs() * 111_360.0 < 1.0, "{}", lat[3000]);
    }
}

#[test]
fn vecto_long_haul_profile_is_vectos_altitude() {
    let path = fixture("fixtures/real/vecto/LongHaul.vdri");
    let c = read_vdri(&path).unwrap();
    let p = cycle_profile(&c, 1.0).unwrap();
    let r = &reference()["vecto_long_haul"];
    assert_eq!(c.distance_m.len(), 2017);
    assert_eq!(p.distance_m.len(), 108_192);
    assert_eq!(p.length_m(), 108_191.0);
    // the integrated elevation's slope is the file's grade/100 at the rows: forward difference
    // over the metre after each row (rounding of elevations up to 183 m: ~1e-13)
    for (s, g) in c
        .distance_m
        .iter()
        .zip(&c.grade)
        .take(c.distance_m.len() - 1)
    {
        let k = *s as usize;
        let d = p.elevation_m[k + 1] - p.elevation_m[k];
        assert!((d - g).abs() < 1e-9, "row at {s} m: {d} vs {g}");
        assert_eq!(p.slope[k], *g);
    }
    let (lo, hi) = p
        .elevation_m
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), z| {
            (a.min(*z), b.max(*z))
        });
    assert!((lo - num(r, &["elevation_min_m"])).abs() < 1e-9, "{lo}");
    assert!((hi - num(r, &["elevation_max_m"])).abs() < 1e-9, "{hi}");

    // Spectrum: the same Welch as scipy on the same 1 m grid: knees to 1e-9 relative, shares
    // of power to 1e-9.
    for (i, nperseg) in [8192usize, 16384, 32768].into_iter().enumerate() {
        let sp = spectrum::of_grid("LongHaul", "slope", "1", &p.slope, 1.0, Some(nperseg), 0.95)
            .unwrap();
        check_spectrum("VECTO Long Haul slope", &sp, &r["held"][i], 1e-9, 1e-9);
    }
}

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
}

fn metadata(path: &Path) -> std::collections::HashMap<String, String> {
    let f = std::fs::File::open(path).unwrap();
    let b = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(f).unwrap();
    b.schema().metadata().clone().into()
}

/// The command sequence of a road study from a track: profile, then the spectrum of its slope.
#[test]
fn cli_profile_then_spectrum_from_profile() {
    let dir = tempfile::tempdir().unwrap();
    // detected by content: the cycle under a name without the .vdri extension
    let cycle = dir.path().join("long-haul-cycle.csv");
    std::fs::copy(fixture("fixtures/real/vecto/LongHaul.vdri"), &cycle).unwrap();
    let prof = dir.path().join("vecto.parquet");
    let out = bin()
        .args(["road", "profile"])
        .arg(&cycle)
        .arg("-o")
        .arg(&prof)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let col = read_profile_column(&prof, "slope").unwrap();
    assert_eq!((col.values.len(), col.step_m), (108_192, 1.0));
    assert_eq!(metadata(&prof)["profile_source"], "vecto-vdri");
    let psd = dir.path().join("psd.parquet");
    let out = bin()
        .arg("spectrum")
        .arg(&prof)
        .args(["--from-profile", "--nperseg", "16384", "-o"])
        .arg(&psd)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let k90: f64 = metadata(&psd)["knee_90"].parse().unwrap();
    let want = num(
        &reference()["vecto_long_haul"],
        &["held", "1", "knee_90_per_m"],
    );
    assert!((k90 - want).abs() < 1e-6 * want, "{k90} vs {want}");
    let out = bin().args(["road", "profile", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && help.contains("--smooth-m") && help.contains(".vdri"));
    // the time domain makes no sense for a profile
    let out = bin()
        .arg("spectrum")
        .arg(&prof)
        .args(["--from-profile", "--domain", "time", "-o"])
        .arg(dir.path().join("t.parquet"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn car_drive_profile_against_obd_distance_and_imu_pitch() {
    let r = &reference()["car_drive_164"];
    let opts = IngestOptions {
        stages: vec![],
        max_nan_run_s: f64::INFINITY,
        ..Default::default()
    };
    let ing = ingest_file(
        &fixture("fixtures/real/css-car-drive-164/gnss_wide.parquet"),
        &opts,
    )
    .unwrap();
    let cfg = GnssProfileConfig {
        pitch_column: Some("pitch_deg".into()),
        ..Default::default()
    };
    let p = gnss_profile_of(&ing, &cfg).unwrap();
    let ProfileSource::Gnss(g) = &p.source else {
        panic!()
    };
    // the same rules implemented independently with numpy: 1e-9 relative
    let geodesic = num(r, &["distance_m"]);
    assert!(
        (g.distance_m - geodesic).abs() < 1e-9 * geodesic,
        "{} vs {geodesic}",
        g.distance_m
    );
    assert_eq!((g.fixes, g.standstill_fixes), (2161, 36));
    assert_eq!(g.elevation_fixes_inaccurate, 47);

    // OBD wheel speed over the same span (first to last valid fix): the receiver had no fix for
    // the first 114 s, in which the car covered 832 m. Measured: OBD 40 817 m, GNSS Doppler
    // speed 40 530 m, chords 40 588 m. OBD speed is whole km/h and speedometers may read high,
    // not low; the bound is 1 %. Against the GNSS Doppler speed (same receiver, independent
    // of positions) 0.5 %.
    let obd = num(r, &["distance_obd_speed_same_span_m"]);
    let doppler = num(r, &["distance_gnss_speed_same_span_m"]);
    println!(
        "car drive: chords {geodesic:.0} m, OBD speed {obd:.0} m ({:+.2} %), GNSS speed {doppler:.0} m ({:+.2} %), haversine on a sphere {:.0} m",
        100.0 * (obd - geodesic) / geodesic,
        100.0 * (doppler - geodesic) / geodesic,
        num(r, &["distance_haversine_same_points_m"])
    );
    assert!((obd - geodesic).abs() < 0.01 * geodesic);
    assert!((doppler - geodesic).abs() < 0.005 * geodesic);
    // and the OBD figure itself, from the Rust ingest of the OBD log
    let obd_ing = ingest_file(
        &fixture("fixtures/real/css-car-drive-164/obd_long.parquet"),
        &IngestOptions::default(),
    )
    .unwrap();
    let (t0, t1) = (
        ing.log.timestamp_ns[ing
            .log
            .signal("latitude")
            .unwrap()
            .iter()
            .position(|v| v.is_finite())
            .unwrap()],
        ing.log.timestamp_ns[ing
            .log
            .signal("latitude")
            .unwrap()
            .iter()
            .rposition(|v| v.is_finite())
            .unwrap()],
    );
    let v = obd_ing.log.signal("vehicle_speed").unwrap();
    let t = &obd_ing.log.timestamp_ns;
    let obd_rust: f64 = (1..t.len())
        .filter(|&i| t[i - 1] >= t0 && t[i] <= t1)
        .map(|i| 0.5 * (v[i] + v[i - 1]) * (t[i] - t[i - 1]) as f64 * 1e-9)
        .sum();
    assert!((obd_rust - obd).abs() < 0.002 * obd, "{obd_rust} vs {obd}");

    // Slope against the IMU pitch. Measured r = 0.874 (the reference, with scipy's odd padding
    // instead of matched edges: 0.866). The bound 0.80 is what a 50 m misalignment of the
    // distance axis (2.5 fix steps) already fails (reference: r = 0.78); a sign error (r < 0)
    // or unconverged altitude let through (r = 0.72 without the accuracy limit) fail too.
    let pc = g.pitch.as_ref().unwrap();
    println!(
        "car drive: slope vs IMU pitch r = {:.3} (mean pitch offset {:.3} deg removed)",
        pc.r, pc.mean_offset_deg
    );
    assert!(pc.r > 0.80, "{}", pc.r);
    assert!((pc.r - num(r, &["r_slope_imu"])).abs() < 0.02, "{}", pc.r);
    assert!((pc.mean_offset_deg - num(r, &["pitch_mean_deg"])).abs() < 0.01);

    // Knees and shares of power of the slope and the IMU slope against the reference; the two
    // smoothings differ only near the ends, where Welch's Hann window weighs little: knees to
    // 1 % relative, shares to 0.01.
    for (column, values) in [
        ("slope", &p.slope),
        ("imu_slope", p.imu_slope.as_ref().unwrap()),
    ] {
        for (i, nperseg) in [8192usize, 16384].into_iter().enumerate() {
            let sp =
                spectrum::of_grid("car", column, "1", values, 1.0, Some(nperseg), 0.95).unwrap();
            check_spectrum(
                &format!("car drive {column}"),
                &sp,
                &r[column][i],
                0.01,
                0.01,
            );
        }
    }
}

/// Writes a canonical GNSS Parquet drive (1 Hz) with the given fixes (None = no fix).
fn write_gnss(path: &Path, fixes: &[Option<(f64, f64, f64)>]) {
    let n = fixes.len();
    let t: Vec<i64> = (0..n as i64).map(|k| T0_NS + k * 1_000_000_000).collect();
    let pick = |f: fn(&(f64, f64, f64)) -> f64| {
        fixes.iter().map(|x| x.as_ref().map(f)).collect::<Vec<_>>()
    };
    write_parquet(
        path,
        vec![
            ("timestamp", ts(&t)),
            ("vehicle_speed", f64s(&vec![20.0; n])),
            ("latitude", f64_opt(&pick(|x| x.0))),
            ("longitude", f64_opt(&pick(|x| x.1))),
            ("altitude", f64_opt(&pick(|x| x.2))),
        ],
    );
}

/// Runs `road profile` on `input`; asserts exit 1 (an input it cannot use), no file left, and
/// the message parts.
fn assert_refused(input: &Path, parts: &[&str]) {
    let dir = input.parent().unwrap().join("out");
    std::fs::create_dir_all(&dir).unwrap();
    let out = bin()
        .args(["road", "profile"])
        .arg(input)
        .arg("-o")
        .arg(dir.join("p.parquet"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    for p in parts {
        assert!(stderr.contains(p), "{p:?} not in {stderr}");
    }
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "left a file");
}

#[test]
fn bad_input_is_a_clear_error_with_exit_2_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    // a drive without GNSS columns
    let p = dir.path().join("no-gnss.parquet");
    Drive::new(100).write(&p);
    assert_refused(&p, &["no-gnss.parquet", "no GNSS track", "latitude"]);

    // a track with 2 fixes
    let p = dir.path().join("two-fixes.parquet");
    let mut fixes = vec![None; 50];
    fixes[10] = Some((56.0, 10.0, 100.0));
    fixes[40] = Some((56.01, 10.0, 101.0));
    write_gnss(&p, &fixes);
    assert_refused(
        &p,
        &[
            "two-fixes.parquet",
            "only 2 valid fixes",
            "latitude",
            "at least 3",
        ],
    );

    // a .vdri with a non-numeric cell
    let p = dir.path().join("bad.vdri");
    std::fs::write(
        &p,
        "<s>,<v>,<grad>,<stop>\n0,0,1.5,2\n10,60,1.2,0\n20,60,abc,0\n",
    )
    .unwrap();
    assert_refused(
        &p,
        &["bad.vdri", "line 4", "<grad>", "`abc`", "not a number"],
    );
    let e = read_vdri(&p).unwrap_err();
    assert!(
        matches!(&e, ProfileError::Vdri { line: 4, column, value, .. } if column == "<grad>" && value == "abc"),
        "{e}"
    );

    // more: a time-based cycle, a decreasing distance, a grade beyond ±30 %, a parked track
    let p = dir.path().join("time.vdri");
    std::fs::write(&p, "<t>,<v>,<grad>\n0,0,0\n1,10,0\n").unwrap();
    assert_refused(&p, &["time-based"]);
    let p = dir.path().join("back.vdri");
    std::fs::write(&p, "<s>,<v>,<grad>,<stop>\n0,0,1,0\n10,60,1,0\n5,60,1,0\n").unwrap();
    assert_refused(&p, &["line 4", "distance decreases"]);
    let p = dir.path().join("steep.vdri");
    std::fs::write(&p, "<s>,<v>,<grad>,<stop>\n0,0,1,0\n10,60,45,0\n").unwrap();
    assert_refused(&p, &["line 3", "45", "±30 %"]);
    let p = dir.path().join("parked.parquet");
    let parked: Vec<_> = (0..60)
        .map(|k| Some((56.0 + 1e-6 * (k % 3) as f64, 10.0, 100.0)))
        .collect();
    write_gnss(&p, &parked);
    let ing = ingest_file(
        &p,
        &IngestOptions {
            stages: vec![],
            ..Default::default()
        },
    )
    .unwrap();
    let mut log = ing.log;
    // the wheel speed says it stands
    log.signals
        .iter_mut()
        .find(|s| s.name == "vehicle_speed")
        .unwrap()
        .values = vec![0.0; 60];
    let e = gnss_profile(&log, &GnssProfileConfig::default()).unwrap_err();
    assert!(
        matches!(e, ProfileError::NeverMoves { fixes: 60, .. }),
        "{e}"
    );
    // a pitch column that is not there
    let mut cfg = GnssProfileConfig {
        pitch_column: Some("pitch_deg".into()),
        ..Default::default()
    };
    let log = synthetic_track(0.0, 0.0, 0.0, true);
    let e = gnss_profile(&log, &cfg).unwrap_err();
    assert!(
        matches!(&e, ProfileError::NoPitch { column, .. } if column == "pitch_deg"),
        "{e}"
    );
    cfg.pitch_column = None;
    cfg.elevation_column = "baro_altitude".into();
    let e = gnss_profile(&log, &cfg).unwrap_err();
    assert!(
        matches!(&e, ProfileError::NoGnss { column, .. } if column == "baro_altitude"),
        "{e}"
    );
    // a smoothing cut-off above the grid's Nyquist frequency is a usage error
    let out = bin()
        .args(["road", "profile"])
        .arg(fixture("fixtures/real/css-car-drive-164/gnss_wide.parquet"))
        .args(["--smooth-m", "1.5", "-o"])
        .arg(dir.path().join("out/x.parquet"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("smooth_m"));
}
