//! Spatial spectra of road slope and studies over many roads (Myklebust & Eriksson (2012), §4–§5):
//! thread-count independence, knees of analytic cases, the paper's qualitative claim (city roads
//! reach higher spatial frequencies than highways), the CLI outputs and bad input.

use arrow::array::{AsArray, Float64Array};
use arrow::datatypes::UInt64Type;
use fleetdyn::report::road_spectra::write_study;
use fleetdyn::road::road_table::read_distance_column;
use fleetdyn::road::rules::RoadRules;
use fleetdyn::road::study::{
    run_study, slope_spectrum, SpectrumSettings, Study, StudyConfig, PAPER_FREQS_PER_M,
};
use fleetdyn::road::synth::generate;
use fleetdyn::signal::knee_frequency;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::path::Path;
use std::process::{Command, Output};

fn cli(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .args(args)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn study_config(rules: &str, roads: usize, length_m: f64) -> StudyConfig {
    StudyConfig {
        rules: RoadRules::bundled(rules).unwrap(),
        n_roads: roads,
        length_m,
        step_m: 1.0,
        seed: 1,
        spectrum: SpectrumSettings {
            segment_length_m: 4096.0,
            confidence: 0.95,
        },
    }
}

fn on_threads(n: usize, cfg: &StudyConfig) -> Study {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .unwrap()
        .install(|| run_study(cfg))
        .unwrap()
}

/// A column of a Parquet file as f64 (u64 columns converted) with its `unit` metadata.
fn column(path: &Path, name: &str) -> (Vec<f64>, String) {
    let b = ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(path).unwrap()).unwrap();
    let unit = b
        .schema()
        .field_with_name(name)
        .unwrap()
        .metadata()
        .get("unit")
        .cloned()
        .unwrap_or_default();
    let mut out = Vec::new();
    for batch in b.build().unwrap() {
        let batch = batch.unwrap();
        let a = batch.column_by_name(name).unwrap();
        if let Some(f) = a.as_any().downcast_ref::<Float64Array>() {
            out.extend(f.values().iter().copied());
        } else {
            out.extend(
                a.as_primitive::<UInt64Type>()
                    .values()
                    .iter()
                    .map(|&v| v as f64),
            );
        }
    }
    (out, unit)
}

#[test]
fn road_study_is_identical_on_one_and_two_threads() {
    let cfg = study_config("highway-se", 12, 20_000.0);
    let (one, two) = (on_threads(1, &cfg), on_threads(2, &cfg));
    assert_eq!(one, two);
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("one"), dir.path().join("two"));
    let fa = write_study(&a, &one, "highway-se").unwrap();
    let fb = write_study(&b, &two, "highway-se").unwrap();
    assert_eq!(fa.len(), 3);
    for (x, y) in fa.iter().zip(&fb) {
        assert_eq!(
            std::fs::read(x).unwrap(),
            std::fs::read(y).unwrap(),
            "{} differs between 1 and 2 threads",
            x.display()
        );
    }
    // Per-road results are in seed order and each equals the road analysed on its own.
    assert_eq!(
        one.roads.iter().map(|r| r.seed).collect::<Vec<_>>(),
        (1..=12).collect::<Vec<u64>>()
    );
    let road = generate(&cfg.rules, cfg.length_m, 1.0, 7).unwrap();
    let sp = slope_spectrum(&road.profile.slope, 1.0, &cfg.spectrum).unwrap();
    assert_eq!(one.roads[6].knee_90, sp.knee_90);
}

#[test]
fn road_study_knee_of_an_analytic_lorentzian() {
    // S(f) = 1/(1 + (f/fc)²) on [0, fmax]: the cumulative power is atan(f/fc)/atan(fmax/fc), so
    // the p-knee is fc·tan(p·atan(fmax/fc)). On a grid of fc/1000 the trapezoid integral is
    // off by ~(Δf/fc)²/12 ≈ 1e-7 relative and the linear interpolation between bins by less:
    // tolerance 1e-5 relative.
    let (fc, fmax, df): (f64, f64, f64) = (1e-3, 0.5, 1e-6);
    let f: Vec<f64> = (0..=(fmax / df).round() as usize)
        .map(|k| k as f64 * df)
        .collect();
    let s: Vec<f64> = f.iter().map(|&x| 1.0 / (1.0 + (x / fc).powi(2))).collect();
    for p in [0.5, 0.9, 0.99] {
        let want = fc * (p * (fmax / fc).atan()).tan();
        let got = knee_frequency(&f, &s, p);
        assert!(
            (got - want).abs() <= 1e-5 * want,
            "p = {p}: {got} vs {want}"
        );
    }
    // The half-power knee of a wide band is the corner itself (fmax/fc = 500: within 0.2 %).
    let k50 = knee_frequency(&f, &s, 0.5);
    assert!((k50 - fc).abs() < 2e-3 * fc, "{k50}");
    // the share of the power below a frequency is the same atan ratio (tolerance as above)
    let c = fleetdyn::signal::cumulative_power(&f, &s);
    for (x, share) in PAPER_FREQS_PER_M
        .iter()
        .zip(fleetdyn::road::study::paper_shares(&f, &c))
    {
        let want = (x / fc).atan() / (fmax / fc).atan();
        assert!(
            (share - want).abs() <= 1e-5 * want,
            "{x}: {share} vs {want}"
        );
    }
}

#[test]
fn road_study_sinusoidal_slope_has_its_knees_at_its_frequency() {
    // slope = a·sin(2π f0 x) with f0 on bin 64 of 4096-m segments: a periodic-Hann Welch
    // estimate puts its power in bins 63, 64, 65 (weights 1/4, 1, 1/4); the trapezoid
    // cumulative power spreads that over the intervals 62…66, so every knee lies within two
    // bins of f0 (the 99 % knee at 65.9 bins). Σ psd·Δf is the variance a²/2 (Parseval; the
    // Hann window's own spectrum does not reach 2·f0, so only rounding separates them: 1e-9
    // relative).
    let (a, df) = (0.02, 1.0 / 4096.0);
    let f0 = 64.0 * df;
    let x: Vec<f64> = (0..40_960)
        .map(|k| a * (2.0 * std::f64::consts::PI * f0 * k as f64).sin())
        .collect();
    let sp = slope_spectrum(
        &x,
        1.0,
        &SpectrumSettings {
            segment_length_m: 4096.0,
            confidence: 0.95,
        },
    )
    .unwrap();
    for k in [sp.knee_50, sp.knee_90, sp.knee_99] {
        assert!((k - f0).abs() <= 2.0 * df, "knee {k} vs f0 {f0}");
    }
    let var: f64 = sp.psd.psd.iter().sum::<f64>() * df;
    assert!((var - a * a / 2.0).abs() <= 1e-9 * a * a, "{var}");
    for k in 0..sp.psd.psd.len() {
        assert!(sp.psd.lower[k] <= sp.psd.psd[k] && sp.psd.psd[k] <= sp.psd.upper[k]);
    }
}

#[test]
fn road_study_city_roads_reach_higher_frequencies_than_highways() {
    // Myklebust & Eriksson (2012), §4: the city rules (steeper grades, R >= 300 m) give "a road
    // with higher frequency content" than the highway rules (R >= 1250 m). Fixed seeds, so
    // deterministic.
    let hw = on_threads(2, &study_config("highway-se", 16, 30_000.0));
    let city = on_threads(2, &study_config("city-se", 16, 30_000.0));
    assert!(city.knee_50.p50 > 1.5 * hw.knee_50.p50);
    assert!(city.knee_90.p50 > 1.5 * hw.knee_90.p50);
    assert!(city.knee_99.p50 > 1.5 * hw.knee_99.p50);
    // and less of their power at the paper's low frequencies
    for k in 0..2 {
        assert!(city.share_below_paper[k] < hw.share_below_paper[k]);
    }
    for s in [&hw, &city] {
        for b in 0..s.freq_per_m.len() {
            assert!(s.psd_p05[b] <= s.psd_p50[b] && s.psd_p50[b] <= s.psd_p95[b]);
        }
        for r in &s.roads {
            assert!(r.knee_50 < r.knee_90 && r.knee_90 < r.knee_99, "{r:?}");
        }
        assert!((s.cumulative_mean.last().unwrap() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn road_study_cli_writes_tables_with_units_and_a_plot() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    let o = cli(&[
        "road",
        "study",
        "--rules",
        "urban-us",
        "--roads",
        "4",
        "--length-km",
        "20",
        "--seed",
        "5",
        "--segment-length-m",
        "4096",
        "--threads",
        "2",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("90 % knee across roads"), "{stdout}");
    let psd = out.join("road_study_psd.parquet");
    let (f, fu) = column(&psd, "frequency");
    let (p50, pu) = column(&psd, "psd_p50");
    let (_, gu) = column(&psd, "filter_zero_phase_gain");
    assert_eq!(
        (fu.as_str(), pu.as_str(), gu.as_str()),
        ("1/m", "(1)^2/(1/m)", "dB")
    );
    assert_eq!(f.len(), 2049);
    assert!((f[1] - 1.0 / 4096.0).abs() < 1e-15 && p50.iter().all(|v| *v >= 0.0));
    let knees = out.join("road_study_knees.parquet");
    let (seeds, su) = column(&knees, "seed");
    let (k90, ku) = column(&knees, "knee_90");
    assert_eq!(seeds, vec![5.0, 6.0, 7.0, 8.0]);
    assert_eq!((su.as_str(), ku.as_str()), ("1", "1/m"));
    assert!(k90.iter().all(|k| *k > 0.0 && *k < 0.5));
    let svg = std::fs::read_to_string(out.join("road_study.svg")).unwrap();
    assert!(
        svg.starts_with("<svg") && svg.contains("99 % knee"),
        "{}",
        &svg[..80]
    );

    // road spectrum of one synthetic road: the table equals the library's analysis.
    let road = dir.path().join("road.parquet");
    let o = cli(&[
        "road",
        "synth",
        "--rules",
        "city-se",
        "--length-km",
        "25",
        "--seed",
        "9",
        "-o",
        road.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let sp_dir = dir.path().join("sp");
    let o = cli(&[
        "road",
        "spectrum",
        road.to_str().unwrap(),
        "--segment-length-m",
        "4096",
        "-o",
        sp_dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let col = read_distance_column(&road, "slope").unwrap();
    assert_eq!(col.step_m, 1.0);
    let settings = SpectrumSettings {
        segment_length_m: 4096.0,
        confidence: 0.95,
    };
    let sp = slope_spectrum(&col.values, col.step_m, &settings).unwrap();
    let (psd, _) = column(&sp_dir.join("road_spectrum.parquet"), "psd");
    assert_eq!(psd, sp.psd.psd);
    assert!(sp_dir.join("road_spectrum.svg").exists());
}

#[test]
fn road_study_bad_input_is_a_clear_error_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o_str = out.to_str().unwrap().to_string();
    for (args, want) in [
        (vec!["--roads", "0"], "a study needs 1 to"),
        (vec!["--segment-length-m", "40000"], "longer than the road"),
        (vec!["--segment-length-m", "4"], "at least 16 steps"),
        (
            vec!["--rules", "nowhere/x.toml"],
            "rule file nowhere/x.toml",
        ),
        (vec!["--length-km", "-1"], "road length -1000 m"),
        (vec!["--jobs", "0"], "--jobs must be at least 1"),
        (vec!["--threads", "0"], "--jobs must be at least 1"),
    ] {
        // defaults for the options this case does not set
        let mut all = vec!["road", "study", "-o", &o_str];
        for (flag, value) in [
            ("--rules", "city-se"),
            ("--roads", "2"),
            ("--length-km", "20"),
        ] {
            if !args.contains(&flag) {
                all.extend([flag, value]);
            }
        }
        all.extend(&args);
        let o = cli(&all);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
        assert!(!out.exists(), "{args:?} left output behind");
    }
    // A Parquet file without a distance grid is refused by road spectrum, naming what is missing.
    let drive = dir.path().join("drive.parquet");
    crate::common::Drive::new(50).write(&drive);
    let o = cli(&["road", "spectrum", drive.to_str().unwrap(), "-o", &o_str]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("no column distance"), "{}", stderr(&o));
    assert!(!out.exists());
}

#[test]
fn road_study_spectrum_reads_a_recorded_slope_on_its_distance_grid() {
    // `road spectrum` also takes slope_distance.parquet of `fleetdyn slope`. The fixture drive's
    // sensor is quantised in 1 % steps (Myklebust & Eriksson (2012), §3): each step is a
    // discontinuity whose f⁻² tail runs to the Nyquist frequency, so the 99 % knee lies far above
    // the filter's f_lo = 2e-2 1/m while half of the power stays below its cut-off 4e-3 1/m.
    let dir = tempfile::tempdir().unwrap();
    let slope_dir = dir.path().join("slope");
    let drive = crate::common::fixture("fixtures/drives/truck-0001.mcap");
    let o = cli(&[
        "slope",
        drive.to_str().unwrap(),
        "-o",
        slope_dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = slope_dir.join("slope_distance.parquet");
    let sp_dir = dir.path().join("sp");
    let o = cli(&[
        "road",
        "spectrum",
        table.to_str().unwrap(),
        "--column",
        "road_slope",
        "--segment-length-m",
        "2048",
        "-o",
        sp_dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(sp_dir.join("road_spectrum.parquet").exists());
    let col = read_distance_column(&table, "road_slope").unwrap();
    let sp = slope_spectrum(
        &col.values,
        col.step_m,
        &SpectrumSettings {
            segment_length_m: 2048.0,
            confidence: 0.95,
        },
    )
    .unwrap();
    assert!(sp.knee_50 < 4e-3, "{}", sp.knee_50);
    assert!(sp.knee_99 > 2e-2, "{}", sp.knee_99);
}

#[test]
fn the_fitted_highway_rules_match_the_measured_highway_knees() {
    // The measured reference: the VECTO Long Haul profile (fixtures/real/vecto), its slope on a
    // 1 m grid, Welch segments of 16 384 m, as `road profile` + `road spectrum` compute it.
    let c = fleetdyn::road::vdri::read_vdri(&crate::common::fixture(
        "fixtures/real/vecto/LongHaul.vdri",
    ))
    .unwrap();
    let p = fleetdyn::road::vdri::cycle_profile(&c, 1.0).unwrap();
    let settings = SpectrumSettings::default();
    let whole = slope_spectrum(&p.slope, 1.0, &settings).unwrap();
    let half = p.slope.len() / 2;
    let held_out = slope_spectrum(&p.slope[half..], 1.0, &settings).unwrap();
    // The synthetic side: 64 roads of 50 km, seeds 1-64, the same Welch settings; the median
    // knee across roads.
    let cfg = StudyConfig {
        spectrum: settings,
        ..study_config("highway-se-fitted", 64, 50_000.0)
    };
    let fitted = on_threads(2, &cfg);
    let recipe = on_threads(
        2,
        &StudyConfig {
            spectrum: settings,
            ..study_config("highway-se", 64, 50_000.0)
        },
    );
    let ratio = |synthetic: f64, measured: f64| synthetic / measured;
    // the band the fit promises (docs/models/road.md): within ±30 % at the 50 % and 90 % knees of
    // the whole profile, whose first half the segment lengths were fitted to
    for (s, m) in [
        (fitted.knee_50.p50, whole.knee_50),
        (fitted.knee_90.p50, whole.knee_90),
    ] {
        let r = ratio(s, m);
        assert!((0.7..=1.3).contains(&r), "{s:e} vs measured {m:e}: {r}");
    }
    // the held-out second half: its 50 % knee within the band as well (the synthetic median 90 %
    // knee lies 30.3 % above the half's, just outside; docs/models/road.md)
    let r = ratio(fitted.knee_50.p50, held_out.knee_50);
    assert!((0.7..=1.3).contains(&r), "held-out 50 % knee: {r}");
    // the recipe the fit replaces misses both by far (3.5 and 2.3 times)
    assert!(ratio(recipe.knee_50.p50, whole.knee_50) > 3.0);
    assert!(ratio(recipe.knee_90.p50, whole.knee_90) > 2.0);
}

#[test]
fn the_fitted_city_and_us_rules_match_the_measured_knees_of_their_class() {
    // Each `*-fitted` rule set was fitted by `fleetdyn road fit` to the first half of a measured
    // profile of its class (schemas/roads/*-fitted.toml record the command and grid); here its
    // fixed-seed study is checked against the whole profile and the held-out second half, within
    // the ±30 % band of docs/models/road.md at the 50 % and 90 % knees.
    let slope = |rel: &str| {
        let c = fleetdyn::road::vdri::read_vdri(&crate::common::fixture(rel)).unwrap();
        fleetdyn::road::vdri::cycle_profile(&c, 1.0).unwrap().slope
    };
    let knees = |s: &[f64], seg: f64| {
        let sp = slope_spectrum(
            s,
            1.0,
            &SpectrumSettings {
                segment_length_m: seg,
                ..Default::default()
            },
        )
        .unwrap();
        (sp.knee_50, sp.knee_90)
    };
    let city = slope("fixtures/real/vecto/UrbanDelivery.vdri");
    let highway = slope("fixtures/real/vecto/LongHaul.vdri");
    // (rule set, road length, Welch segment, measured slope, row where the held-out half starts)
    let cases: [(&str, f64, f64, &[f64], usize); 3] = [
        ("city-se-fitted", 14_000.0, 4096.0, &city, 13_908),
        ("urban-us-fitted", 14_000.0, 4096.0, &city, 13_908),
        ("freeway-us-fitted", 50_000.0, 16_384.0, &highway, 54_096),
    ];
    for (name, length_m, seg, measured, half) in cases {
        let cfg = StudyConfig {
            spectrum: SpectrumSettings {
                segment_length_m: seg,
                confidence: 0.95,
            },
            ..study_config(name, 64, length_m)
        };
        let s = on_threads(2, &cfg);
        for (what, (k50, k90)) in [
            ("whole", knees(measured, seg)),
            ("held-out half", knees(&measured[half..], seg)),
        ] {
            for (syn, meas) in [(s.knee_50.p50, k50), (s.knee_90.p50, k90)] {
                let r = syn / meas;
                assert!(
                    (0.7..=1.3).contains(&r),
                    "{name} vs the {what}: {syn:e} against {meas:e} ({r})"
                );
            }
        }
    }
    // The recipe the city fit replaces misses the measured 90 % knee by more than the band.
    let recipe = on_threads(
        2,
        &StudyConfig {
            spectrum: SpectrumSettings {
                segment_length_m: 4096.0,
                confidence: 0.95,
            },
            ..study_config("city-se", 64, 14_000.0)
        },
    );
    assert!(recipe.knee_90.p50 / knees(&city, 4096.0).1 > 1.3);
}
