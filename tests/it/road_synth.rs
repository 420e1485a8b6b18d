//! Synthetic roads (Myklebust & Eriksson (2012), §4, eqs. (34)–(36); docs/models/road.md):
//! determinism, rule compliance on long roads, elevation as the integral of slope, the analytic
//! parabola of a single grade change, curves that do not fit, and bad input through the CLI.

use fleetdyn::road::rules::{bundled_names, RoadRules, RulesError};
use fleetdyn::road::synth::{generate, half_length, Alignment, SynthError};
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

/// Files in a folder (temporary leftovers included).
fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

#[test]
fn road_synth_same_seed_gives_identical_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, seed: &str| {
        let p = dir.path().join(name);
        let o = cli(&[
            "road",
            "synth",
            "--rules",
            "highway-se",
            "--length-km",
            "30",
            "--seed",
            seed,
            "-o",
            p.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(p).unwrap()
    };
    let (a, b, c) = (
        run("a.parquet", "7"),
        run("b.parquet", "7"),
        run("c.parquet", "8"),
    );
    assert_eq!(a, b, "same rules and seed must give the same bytes");
    assert_ne!(a, c, "another seed gives another road");
}

/// Checks every rule a generated road must obey; returns the number of grid intervals checked.
fn check_compliance(rules: &RoadRules, length_m: f64, step_m: f64, seed: u64) -> usize {
    let road = generate(rules, length_m, step_m, seed).unwrap();
    let a = &road.alignment;
    let s = &road.profile.slope;
    // Grades and radii as drawn: |g| <= max_grade, R in [R_min(crest/sag), R_min + band].
    for w in a.grades.windows(2).zip(&a.radii_m) {
        let ((g0, g1), r) = ((w.0[0], w.0[1]), *w.1);
        let r_min = rules.min_radius(g1 < g0);
        assert!(r >= r_min && r <= r_min + rules.radius_band_m, "R = {r}");
    }
    assert!(a.grades.iter().all(|g| g.abs() <= rules.max_grade));
    // Segment lengths: at least the minimum; at most the range at their grade unless they were
    // lengthened to hold their curves exactly.
    for (i, &l) in a.lengths_m.iter().enumerate() {
        let before = if i > 0 {
            half_length(a.radii_m[i - 1], a.grades[i - 1], a.grades[i])
        } else {
            0.0
        };
        let after = half_length(a.radii_m[i], a.grades[i], a.grades[i + 1]);
        assert!(l >= rules.min_length_m, "segment {i}: {l} m");
        assert!(
            l <= rules.max_length_at(a.grades[i]) || l == before + after || l == before,
            "segment {i}: {l} m at grade {}",
            a.grades[i]
        );
        assert!(before + after <= l, "segment {i}: curves do not fit");
    }
    // On the grid: |slope| <= max_grade everywhere. Slopes on a curve lie between its two
    // grades, so only rounding (~1e-17) can exceed the bound: tolerance 1e-15.
    let max_abs = s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(max_abs <= rules.max_grade + 1e-15, "{max_abs}");
    // Slope change rate: falling (crest) at most 1/R_crest, rising (sag) at most 1/R_sag per
    // metre. The slope is piecewise linear with |k| = |Δg|/(R|Δg|) = 1/R up to rounding, so a
    // difference quotient can exceed 1/R only by rounding: 1e-12 1/m (1e-9 of 1/R) covers it.
    let (crest, sag) = (1.0 / rules.min_radius(true), 1.0 / rules.min_radius(false));
    let (mut worst_fall, mut worst_rise, mut worst_jump) = (0.0f64, 0.0f64, 0.0f64);
    for w in s.windows(2) {
        let d = w[1] - w[0];
        worst_jump = worst_jump.max(d.abs());
        if d < 0.0 {
            worst_fall = worst_fall.max(-d / step_m);
        } else {
            worst_rise = worst_rise.max(d / step_m);
        }
    }
    assert!(worst_fall <= crest + 1e-12, "fall {worst_fall} > {crest}");
    assert!(worst_rise <= sag + 1e-12, "rise {worst_rise} > {sag}");
    // Continuity: no jump between grid samples beyond step/R_min (+ rounding, 1e-12).
    assert!(worst_jump <= step_m / rules.smallest_radius() + 1e-12);
    // Not vacuous: every curve bends at >= 1/(R_min + band), and curves span whole grid
    // intervals, so the steepest rates found are at least that (less rounding, 1e-12).
    let band = rules.radius_band_m;
    assert!(
        worst_fall >= 1.0 / (rules.min_radius(true) + band) - 1e-12
            && worst_rise >= 1.0 / (rules.min_radius(false) + band) - 1e-12,
        "{}: fall {worst_fall} vs {crest}, rise {worst_rise} vs {sag}",
        rules.name
    );
    s.len() - 1
}

#[test]
fn road_synth_long_roads_obey_every_bundled_rule_set() {
    for name in bundled_names() {
        let rules = RoadRules::bundled(name).unwrap();
        let n = check_compliance(&rules, 200_000.0, 1.0, 3);
        assert_eq!(n, 200_000);
    }
}

#[test]
fn road_synth_curves_that_do_not_fit_lengthen_their_segments() {
    // Segments far shorter than the curves: nearly every curve needs its segment lengthened.
    let rules = RoadRules::parse(
        r#"
        name = "short"
        source = "test: segments shorter than their curves"
        max_grade = 0.12
        min_radius_m = 300.0
        min_sag_radius_m = 500.0
        radius_band_m = 60.0
        min_length_m = 5.0
        max_length_flat_m = 20.0
        length_e_folding_grade = 0.06
        "#,
        "short.toml",
    )
    .unwrap();
    let road = generate(&rules, 50_000.0, 0.5, 11).unwrap();
    assert!(
        road.lengthened_segments > road.alignment.lengths_m.len() / 2,
        "{} of {}",
        road.lengthened_segments,
        road.alignment.lengths_m.len()
    );
    road.alignment.pieces().unwrap();
    check_compliance(&rules, 50_000.0, 0.5, 11);

    // A hand-made alignment whose curve is longer than its segment is refused.
    let a = Alignment {
        grades: vec![0.0, 0.08, 0.0],
        lengths_m: vec![100.0, 90.0],
        radii_m: vec![1250.0, 1250.0],
    };
    match a.pieces() {
        Err(SynthError::CurveDoesNotFit {
            index: 1,
            length_m,
            before_m,
            after_m,
        }) => {
            assert_eq!(length_m, 90.0);
            assert!((before_m - 50.0).abs() < 1e-12 && (after_m - 50.0).abs() < 1e-12);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn road_synth_elevation_is_the_integral_of_slope() {
    for name in ["highway-se", "city-se"] {
        let rules = RoadRules::bundled(name).unwrap();
        let step = 1.0;
        let road = generate(&rules, 100_000.0, step, 5).unwrap();
        let (s, z) = (&road.profile.slope, &road.profile.elevation_m);
        assert_eq!(z[0], 0.0);
        // Trapezoid rule: exact on a grid interval where the slope is linear; an interval with
        // a kink (piece boundary) where the slope's rate jumps by Δk is off by at most
        // Δk·step²/8, and Δk <= 2/R_min (crest straight into sag). Plus summation rounding,
        // ~n·ε·|z| < 1e-7 m here: tolerance kinks·step²/(4·R_min) + 1e-6 m.
        let kinks = 2 * road.alignment.radii_m.len();
        let tol = kinks as f64 * step * step / (4.0 * rules.smallest_radius()) + 1e-6;
        let mut acc = 0.0;
        let mut worst = 0.0f64;
        for k in 1..s.len() {
            acc += 0.5 * (s[k - 1] + s[k]) * step;
            worst = worst.max((acc - z[k]).abs());
        }
        assert!(
            worst <= tol,
            "{name}: trapezoid vs elevation {worst} m > {tol} m"
        );
        // and the elevation is not trivially flat
        let range = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(range > 10.0, "{name}: {range}");
    }
}

#[test]
fn road_synth_single_grade_change_is_the_analytic_parabola() {
    // Sag: 0 -> +4 % at the PVI x = 1000 m with R = 1250 m: the curve spans
    // 1000 ± R·0.04/2 = 975 … 1025 m, z = (x − 975)²/(2R) (eq. (34)), slope (x − 975)/R (eq. (35)).
    let a = Alignment {
        grades: vec![0.0, 0.04],
        lengths_m: vec![1000.0],
        radii_m: vec![1250.0],
    };
    let p = a.profile(2000.0, 0.5).unwrap();
    // Tolerance 1e-12: both sides are closed-form evaluations; only rounding separates them.
    for ((&x, &z), &s) in p.distance_m.iter().zip(&p.elevation_m).zip(&p.slope) {
        let (zw, sw) = if x < 975.0 {
            (0.0, 0.0)
        } else if x <= 1025.0 {
            ((x - 975.0).powi(2) / 2500.0, (x - 975.0) / 1250.0)
        } else {
            (1.0 + 0.04 * (x - 1025.0), 0.04)
        };
        assert!((z - zw).abs() < 1e-12, "z({x}) = {z}, want {zw}");
        assert!((s - sw).abs() < 1e-12, "slope({x}) = {s}, want {sw}");
    }
    assert_eq!(p.distance_m.len(), 4001);
    // Crest: +3 % -> −2 % at x = 500 m with R = 2000 m (span 450 … 550 m); the elevation follows
    // the grade line z = 0.03·x before and z = 0.03·x − (x − 450)²/(2R) on the curve.
    let c = Alignment {
        grades: vec![0.03, -0.02],
        lengths_m: vec![500.0],
        radii_m: vec![2000.0],
    };
    let p = c.profile(1000.0, 1.0).unwrap();
    for (&x, &z) in p.distance_m.iter().zip(&p.elevation_m) {
        let zw = if x < 450.0 {
            0.03 * x
        } else if x <= 550.0 {
            0.03 * x - (x - 450.0).powi(2) / 4000.0
        } else {
            0.03 * 550.0 - 2.5 - 0.02 * (x - 550.0)
        };
        assert!((z - zw).abs() < 1e-11, "z({x}) = {z}, want {zw}");
    }
}

#[test]
fn road_synth_bad_rules_and_lengths_are_clear_errors() {
    // Library level: the error names the key and the value.
    let base =
        std::fs::read_to_string(crate::common::fixture("schemas/roads/city-se.toml")).unwrap();
    let with = |key: &str, value: &str| {
        let line = base
            .lines()
            .find(|l| l.starts_with(&format!("{key} =")))
            .unwrap();
        base.replace(line, &format!("{key} = {value}"))
    };
    for (key, value) in [
        ("max_grade", "0.0"),
        ("max_grade", "-0.05"),
        ("max_grade", "12.0"),
        ("min_radius_m", "0.0"),
        ("min_radius_m", "-300.0"),
        ("radius_band_m", "-1.0"),
        ("max_length_flat_m", "10.0"),
    ] {
        match RoadRules::parse(&with(key, value), "bad.toml") {
            Err(RulesError::Invalid { key: k, file, .. }) => {
                assert_eq!((k, file.as_str()), (key, "bad.toml"))
            }
            other => panic!("{key} = {value}: {other:?}"),
        }
    }
    let e = RoadRules::parse(&format!("{base}\nmax_grade_percent = 8\n"), "x.toml").unwrap_err();
    assert!(
        matches!(e, RulesError::Parse { .. }) && e.to_string().contains("max_grade_percent"),
        "{e}"
    );
    assert!(matches!(
        RoadRules::resolve("highway-xx"),
        Err(RulesError::UnknownRuleSet { .. })
    ));
    let rules = RoadRules::bundled("city-se").unwrap();
    assert!(matches!(
        generate(&rules, -5000.0, 1.0, 1),
        Err(SynthError::InvalidLength { .. })
    ));
    assert!(matches!(
        generate(&rules, f64::NAN, 1.0, 1),
        Err(SynthError::InvalidLength { .. })
    ));
    assert!(matches!(
        generate(&rules, 1000.0, 0.0, 1),
        Err(SynthError::InvalidStep { .. })
    ));
    assert!(matches!(
        generate(&rules, 1e12, 1.0, 1),
        Err(SynthError::TooManySamples { .. })
    ));
}

#[test]
fn road_synth_cli_bad_input_exits_2_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let target = out.join("road.parquet");
    let t = target.to_str().unwrap();
    let bad_rules = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let base =
        std::fs::read_to_string(crate::common::fixture("schemas/roads/highway-se.toml")).unwrap();
    let zero_grade = bad_rules(
        "zero-grade.toml",
        &base.replace("max_grade = 0.08", "max_grade = 0"),
    );
    let neg_radius = bad_rules(
        "neg-radius.toml",
        &base.replace("min_radius_m = 1250.0", "min_radius_m = -1250.0"),
    );
    let unknown_key = bad_rules("unknown.toml", &format!("{base}\nspeed_limit = 90\n"));
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["--rules", "motorway-de", "--length-km", "10"],
            "unknown rule set",
        ),
        (
            vec!["--rules", "highway-se", "--length-km", "-5"],
            "road length -5000 m",
        ),
        (
            vec![
                "--rules",
                "highway-se",
                "--length-km",
                "10",
                "--step-m",
                "0",
            ],
            "grid step 0 m",
        ),
        (
            vec!["--rules", &zero_grade, "--length-km", "10"],
            "max_grade = 0 must be finite and > 0",
        ),
        (
            vec!["--rules", &neg_radius, "--length-km", "10"],
            "min_radius_m = -1250",
        ),
        (
            vec!["--rules", &unknown_key, "--length-km", "10"],
            "unknown field `speed_limit`",
        ),
    ];
    for (args, want) in cases {
        let mut all = vec!["road", "synth", "-o", t];
        all.extend(&args);
        let o = cli(&all);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
        assert!(
            entries(&out).is_empty(),
            "{args:?} left {:?}",
            entries(&out)
        );
    }
}
