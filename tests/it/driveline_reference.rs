//! The linear driveline model against an independent python-control implementation
//! (fixtures/gen/make_driveline_reference.py, control 0.10.2, built from docs/models/driveline.md
//! and the same vehicle file): matrices, eigenvalues, frequency responses and DC gains.

use crate::common::*;
use fleetdyn::model::linear::{linearize, StateSpace};
use fleetdyn::model::vehicle::VehicleFile;
use num_complex::Complex64;
use serde_json::Value;

fn matrix(v: &Value) -> Vec<Vec<f64>> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|r| {
            r.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        })
        .collect()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn assert_matrix(name: &str, ours: &nalgebra::DMatrix<f64>, reference: &[Vec<f64>]) {
    // Same formulas, different operation order: 1e-12 of the matrix's largest entry.
    let scale = reference
        .iter()
        .flatten()
        .fold(0.0f64, |m, x| m.max(x.abs()));
    for (i, row) in reference.iter().enumerate() {
        for (j, &r) in row.iter().enumerate() {
            assert!(
                (ours[(i, j)] - r).abs() <= 1e-12 * scale,
                "{name}[{i},{j}]: {} vs {r}",
                ours[(i, j)]
            );
        }
    }
}

fn assert_eigs(name: &str, ss: &StateSpace, reference: &Value) {
    let mut r: Vec<Complex64> = matrix(reference)
        .iter()
        .map(|p| Complex64::new(p[0], p[1]))
        .collect();
    let mut o = ss.eigenvalues();
    let key = |z: &Complex64| (z.im, z.re);
    r.sort_by(|a, b| key(a).partial_cmp(&key(b)).unwrap());
    o.sort_by(|a, b| key(a).partial_cmp(&key(b)).unwrap());
    assert_eq!(o.len(), r.len());
    // Eigenvalues of a non-symmetric matrix from two LAPACK-free/LAPACK paths: 1e-8 relative to
    // |λ| (conditioning of the stiff 9000 rad/s clutch mode next to the 0.5 rad/s vehicle mode).
    for (a, b) in o.iter().zip(&r) {
        assert!(
            (a - b).norm() <= 1e-8 * b.norm().max(1.0),
            "{name}: {a} vs {b}"
        );
    }
}

#[test]
fn linear_model_matches_python_control() {
    let v = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p = v.driveline.as_ref().unwrap();
    let text =
        std::fs::read_to_string(fixture("fixtures/reference/driveline_linear.json")).unwrap();
    let doc: Value = serde_json::from_str(&text).unwrap();
    let cases = doc["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 15);
    let mut worst_h: f64 = 0.0;
    for c in cases {
        let gear = c["gear"].as_u64().unwrap() as usize;
        let v0 = c["v0_mps"].as_f64().unwrap();
        let lin = linearize(p, &v.gearbox.ratios, gear, v0);
        let tag = format!("gear {gear} v0 {v0:.3}");
        assert_matrix(&format!("{tag} A"), &lin.open.a, &matrix(&c["A"]));
        assert_matrix(&format!("{tag} B"), &lin.open.b, &matrix(&c["B"]));
        assert_matrix(&format!("{tag} C"), &lin.open.c, &matrix(&c["C"]));
        assert_matrix(&format!("{tag} A_cl"), &lin.closed.a, &matrix(&c["A_cl"]));
        assert_matrix(&format!("{tag} B_cl"), &lin.closed.b, &matrix(&c["B_cl"]));
        assert_eigs(&format!("{tag} open"), &lin.open, &c["eig_open"]);
        assert_eigs(&format!("{tag} closed"), &lin.closed, &c["eig_closed"]);
        let f = floats(&c["f_hz"]);
        for (key, ss, input) in [
            ("me_to_v", &lin.open, 0),
            ("fdr_to_v", &lin.open, 1),
            ("fdr_to_v_closed", &lin.closed, 1),
            ("wref_to_v_closed", &lin.closed, 0),
        ] {
            let mag = floats(&c[key]["mag"]);
            for (fk, mk) in f.iter().zip(&mag) {
                let h = ss.freq_response(input, *fk).norm();
                let rel = (h - mk).abs() / mk;
                worst_h = worst_h.max(rel);
                // LU solve of an 8x8 complex system vs python-control's evaluation: 1e-9
                // relative (both ~1e-13; margin for the stiff clutch mode's conditioning).
                assert!(rel <= 1e-9, "{tag} {key} at {fk} Hz: {h} vs {mk}");
            }
            let dc = c["dcgain"][key].as_f64().unwrap();
            let ours = ss.dc_gain(input);
            // 1e-9 relative; the closed-loop F_dr -> v gain is exactly 0 (integral action), where
            // round-off of ~1e-20 m/s/N is accepted (gains here are 1e-2 … 1).
            assert!(
                (ours - dc).abs() <= 1e-9 * dc.abs() + 1e-15,
                "{tag} {key} dc {ours} vs {dc}"
            );
        }
    }
    println!("worst |H| relative difference vs python-control: {worst_h:e}");
}
