//! `fleetdyn road compare` and `fleetdyn road fit` (docs/models/road.md): rule sets, measured
//! profiles and a driveline's resonances on one grid; a rule set's segment lengths fitted to a
//! measured road.

use arrow::array::{Array, AsArray, Float64Array, StringArray};
use arrow::datatypes::UInt64Type;
use fleetdyn::model::resonance::{resonance, Path as TfPath};
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::road::rules::RoadRules;
use fleetdyn::road::study::{slope_spectrum, SpectrumSettings};
use fleetdyn::road::vdri::{cycle_profile, read_vdri};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Output};

use crate::common::fixture;

fn cli(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .args(args)
        .output()
        .unwrap()
}

/// Every column of a Parquet file: floats (nulls as NaN, u64 as f64) and strings.
#[derive(Default)]
struct Table {
    f: BTreeMap<String, Vec<f64>>,
    s: BTreeMap<String, Vec<String>>,
    units: BTreeMap<String, String>,
}

fn table(path: &Path) -> Table {
    let b = ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(path).unwrap()).unwrap();
    let mut t = Table::default();
    for f in b.schema().fields() {
        t.units.insert(
            f.name().clone(),
            f.metadata().get("unit").cloned().unwrap_or_default(),
        );
    }
    for batch in b.build().unwrap() {
        let batch = batch.unwrap();
        for (field, a) in batch.schema().fields().iter().zip(batch.columns()) {
            let name = field.name().clone();
            if let Some(x) = a.as_any().downcast_ref::<Float64Array>() {
                let v = t.f.entry(name).or_default();
                v.extend((0..x.len()).map(|i| if x.is_null(i) { f64::NAN } else { x.value(i) }));
            } else if let Some(x) = a.as_any().downcast_ref::<StringArray>() {
                let v = t.s.entry(name).or_default();
                v.extend((0..x.len()).map(|i| x.value(i).to_string()));
            } else {
                let v = t.f.entry(name).or_default();
                v.extend(
                    a.as_primitive::<UInt64Type>()
                        .values()
                        .iter()
                        .map(|&u| u as f64),
                );
            }
        }
    }
    t
}

fn vdri_slope(rel: &str) -> Vec<f64> {
    cycle_profile(&read_vdri(&fixture(rel)).unwrap(), 1.0)
        .unwrap()
        .slope
}

#[test]
fn road_compare_puts_rule_sets_profiles_and_resonances_on_one_grid() {
    let dir = tempfile::tempdir().unwrap();
    let (ud, lh, truck) = (
        fixture("fixtures/real/vecto/UrbanDelivery.vdri"),
        fixture("fixtures/real/vecto/LongHaul.vdri"),
        fixture("fixtures/vehicles/truck-40t.toml"),
    );
    let run = |jobs: &str, out: &Path| {
        cli(&[
            "road",
            "compare",
            "--rules",
            "city=city-se-fitted",
            "--rules",
            "highway=highway-se-fitted",
            "--profile",
            &format!("city={}", ud.display()),
            "--profile",
            &format!("highway={}@10..40", lh.display()),
            "--vehicle",
            truck.to_str().unwrap(),
            "--roads",
            "8",
            "--length-km",
            "28",
            "--segment-length-m",
            "8192",
            "--jobs",
            jobs,
            "-o",
            out.to_str().unwrap(),
        ])
    };
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let o = run("1", &a);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("city-se-fitted") && stdout.contains("UrbanDelivery"),
        "{stdout}"
    );
    assert!(stdout.contains("gear  1: resonance"), "{stdout}");

    let items = table(&a.join("road_compare.parquet"));
    assert_eq!(
        items.s["item"],
        [
            "city-se-fitted",
            "highway-se-fitted",
            "UrbanDelivery",
            "LongHaul@10..40"
        ]
    );
    assert_eq!(items.s["kind"], ["rules", "rules", "profile", "profile"]);
    assert_eq!(
        items.s["road_class"],
        ["city", "highway", "city", "highway"]
    );
    assert_eq!(items.units["knee_50"], "1/m");
    for row in 0..4 {
        for pct in ["50", "90", "99"] {
            let (v, lo, hi) = (
                items.f[&format!("knee_{pct}")][row],
                items.f[&format!("knee_{pct}_lo")][row],
                items.f[&format!("knee_{pct}_hi")][row],
            );
            assert!(
                lo <= v && v <= hi && lo > 0.0,
                "row {row} knee {pct}: {lo} {v} {hi}"
            );
        }
        let (s3, s10) = (
            items.f["share_below_3e-4"][row],
            items.f["share_below_1e-3"][row],
        );
        assert!((0.0..=1.0).contains(&s3) && s3 <= s10 && s10 <= 1.0);
        let margin = items.f["cutoff_margin"][row];
        assert!((margin - 4e-3 / items.f["knee_99"][row]).abs() < 1e-9 * margin);
    }
    // A profile's knees are those of `road spectrum` on the same slope and settings.
    let settings = SpectrumSettings {
        segment_length_m: 8192.0,
        ..Default::default()
    };
    let ud_sp = slope_spectrum(
        &vdri_slope("fixtures/real/vecto/UrbanDelivery.vdri"),
        1.0,
        &settings,
    )
    .unwrap();
    assert_eq!(items.f["knee_50"][2], ud_sp.knee_50);
    assert_eq!(items.f["knee_90"][2], ud_sp.knee_90);
    let lh = vdri_slope("fixtures/real/vecto/LongHaul.vdri");
    let lh_sp = slope_spectrum(&lh[10_000..=40_000], 1.0, &settings).unwrap();
    assert_eq!(items.f["knee_50"][3], lh_sp.knee_50);
    assert_eq!(items.f["length"][3], 30_000.0);
    // The city roads and the city profile put their power higher than the highway ones: the
    // ordering the paper reports, on the measured and the fitted synthetic roads alike.
    assert!(items.f["knee_50"][0] > 2.0 * items.f["knee_50"][1]);
    assert!(items.f["knee_50"][2] > 2.0 * items.f["knee_50"][3]);

    // Every item on the same bins; each item's cumulative power runs to 1.
    let psd = table(&a.join("road_compare_psd.parquet"));
    let bins = 8192 / 2 + 1;
    assert_eq!(psd.s["item"].len(), 4 * bins);
    for k in 0..4 {
        let c = &psd.f["cumulative_power"][k * bins..(k + 1) * bins];
        assert!((c[bins - 1] - 1.0).abs() < 1e-12);
        assert_eq!(
            &psd.f["frequency"][k * bins..(k + 1) * bins],
            &psd.f["frequency"][..bins]
        );
    }
    assert_eq!(psd.units["psd_normalised"], "m");

    // One row per gear; the peaks are `bode`'s F_dr -> v open-loop resonances at top speed, and
    // the filter attenuates each by far more than the 30 dB it is designed for at f_lo.
    let v = VehicleFile::load(&truck).unwrap();
    let p = v.driveline("truck").unwrap();
    let res = table(&a.join("road_compare_resonances.parquet"));
    assert_eq!(res.f["gear"].len(), v.gearbox.ratios.len());
    for (k, g) in res.f["gear"].iter().enumerate() {
        let r = resonance(p, &v.gearbox.ratios, *g as usize, TfPath::ResistanceOpen);
        match r.peak_per_m {
            Some(f) => {
                assert_eq!(res.f["peak_spatial_frequency"][k], f);
                assert!(res.f["filter_causal_gain"][k] < -30.0);
                assert!(res.f["filter_zero_phase_gain"][k] < 2.0 * -30.0);
                assert!(res.f["ratio_to_f_lo"][k] > 1.0);
            }
            None => assert!(res.f["peak_spatial_frequency"][k].is_nan()),
        }
    }
    let svg = std::fs::read_to_string(a.join("road_compare.svg")).unwrap();
    assert!(svg.contains("driveline resonance") && svg.contains("UrbanDelivery"));

    // The same bytes on one thread and on two.
    let o = run("2", &b);
    assert!(o.status.success());
    for f in [
        "road_compare.parquet",
        "road_compare_psd.parquet",
        "road_compare_resonances.parquet",
        "road_compare.svg",
    ] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f}"
        );
    }
}

#[test]
fn road_compare_refuses_what_it_cannot_compare() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let ud = fixture("fixtures/real/vecto/UrbanDelivery.vdri");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec![], "at least one --rules or --profile"),
        (
            vec!["--profile".into(), format!("{}@20..40", ud.display())],
            "reaches beyond the profile's 27.816 km",
        ),
        (
            vec!["--profile".into(), format!("{}@5..2", ud.display())],
            "FROM_KM..TO_KM",
        ),
        (
            vec![
                "--profile".into(),
                ud.display().to_string(),
                "--segment-length-m".into(),
                "65536".into(),
            ],
            "longer than the road",
        ),
        (
            vec!["--rules".into(), "no-such-rules".into()],
            "unknown rule set",
        ),
    ];
    for (args, message) in cases {
        let mut all = vec!["road", "compare", "-o", out.to_str().unwrap()];
        all.extend(args.iter().map(String::as_str));
        let o = cli(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(message), "{args:?}: {err}");
        assert!(!out.exists(), "{args:?} left output");
    }
    // a file that holds no road profile (a drive log without `distance`) is an input error
    let drive = fixture("fixtures/drives/truck-0003-export.parquet");
    let o = cli(&[
        "road",
        "compare",
        "--profile",
        drive.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("truck-0003-export.parquet"), "{err}");
    assert!(!out.exists());
}

#[test]
fn road_fit_writes_a_rule_file_that_loads_with_the_regulation_values_kept() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("city-fit.toml");
    let ud = fixture("fixtures/real/vecto/UrbanDelivery.vdri");
    let o = cli(&[
        "road",
        "fit",
        "--rules",
        "city-se",
        "--profile",
        &format!("city={}@0..13.908", ud.display()),
        "--scales",
        "1,1.5,2.5",
        "--roads",
        "16",
        "--length-km",
        "14",
        "--segment-length-m",
        "4096",
        "--name",
        "my-city",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("<- best"), "{stdout}");
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("# Command: fleetdyn road fit --rules city-se"));
    assert!(text.contains("<- fitted"));
    let fitted = RoadRules::load(&out).unwrap();
    let base = RoadRules::bundled("city-se").unwrap();
    assert_eq!(fitted.name, "my-city");
    let k = fitted.min_length_m / base.min_length_m;
    assert!([1.0, 1.5, 2.5].iter().any(|s| (k - s).abs() < 1e-12), "{k}");
    assert!((fitted.max_length_flat_m / base.max_length_flat_m - k).abs() < 1e-12);
    // the recipe's 90 % knee lies 40 % above the target's, so the fit moves off k = 1
    assert!(k > 1.0, "{k}");
    for (a, b) in [
        (fitted.max_grade, base.max_grade),
        (fitted.min_radius_m, base.min_radius_m),
        (fitted.radius_band_m, base.radius_band_m),
        (fitted.length_e_folding_grade, base.length_e_folding_grade),
    ] {
        assert_eq!(a, b);
    }
    // bad scales are refused before any study runs
    let o = cli(&[
        "road",
        "fit",
        "--rules",
        "city-se",
        "--profile",
        ud.to_str().unwrap(),
        "--scales",
        "1,0",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--scales"));
}
