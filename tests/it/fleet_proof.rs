//! The fleet proof (src/proof/fleet.rs) reduced to run in the suite: two trucks of the
//! independent truth, ten drives of 2–3 km each, one losing its roof fairing (drag area × 1.25)
//! from a drive in the middle third on. Every drive must be simulated and diagnosed, neither
//! truck may raise a false alarm, and the outputs must be written. Whether the fairing is
//! flagged is printed, not asserted: on drives this short the per-drive drag estimates scatter
//! too much for a change at the 10⁻³ level within ten drives (measured: not flagged). Detection
//! is measured by the full proof (`fleetdyn prove --fleet`, docs/fleet.md), too long for the
//! suite, and its logic by the unit tests of `fleet::evidence` and `fleet::change`. The saved
//! proof scored again (`--rescore`) must give the same summary, byte for byte.

use crate::common::fixture;
use fleetdyn::proof::{
    rescore_fleet_proof, run_fleet_proof, FleetFault, FleetProofConfig, ProveError,
};

#[test]
fn two_trucks_are_diagnosed_without_false_alarms() {
    let cfg = FleetProofConfig {
        seed: 1,
        trucks: 2,
        drives_per_truck: 10,
        faulty: 1,
        length_km: (2.0, 3.0),
        ..FleetProofConfig::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let vehicle = fixture("fixtures/vehicles/truck-40t.toml");
    let run = run_fleet_proof(&cfg, &vehicle, dir.path(), 2, &|_, _| {}).unwrap();
    eprintln!("{}", run.to_markdown());
    assert_eq!(run.failed_drives, 0);
    let faulty = &run.trucks[0];
    assert_eq!(faulty.fault.map(|f| f.0), Some(FleetFault::LostFairing));
    eprintln!("lost fairing flagged after {:?} drives", faulty.delay);
    assert!(faulty.false_alarms.is_empty(), "{:?}", faulty.false_alarms);
    let clean = &run.trucks[1];
    assert!(clean.fault.is_none());
    assert!(clean.false_alarms.is_empty(), "{:?}", clean.false_alarms);
    // the outputs a person reads
    for f in [
        "fleet_proof.md",
        "fleet_proof.json",
        "fleet/fleet.html",
        "fleet/fleet_parameters.parquet",
    ] {
        assert!(dir.path().join(f).is_file(), "{f}");
    }
    // scored again from its saved drives: the same summary, the same evidence
    let again = tempfile::tempdir().unwrap();
    let re = rescore_fleet_proof(dir.path(), again.path()).unwrap();
    assert_eq!(re.to_markdown(), run.to_markdown());
    for f in ["fleet_proof.md", "fleet/fleet_parameters.parquet"] {
        assert_eq!(
            std::fs::read(dir.path().join(f)).unwrap(),
            std::fs::read(again.path().join(f)).unwrap(),
            "{f}"
        );
    }
    // a folder without a saved proof is refused, naming the file, and nothing is written
    let none = tempfile::tempdir().unwrap();
    let out = none.path().join("out");
    match rescore_fleet_proof(none.path(), &out) {
        Err(ProveError::Saved { path, .. }) => assert!(path.ends_with("fleet_proof.json")),
        other => panic!("{other:?}"),
    }
    assert!(!out.exists());
}
