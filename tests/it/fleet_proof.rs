//! The fleet proof (src/proof/fleet.rs) reduced to run in the suite: two trucks of the
//! independent truth, six drives of 2–3 km each, one losing its roof fairing (drag area × 1.25)
//! from a drive in the middle third on. The fault must be flagged within five drives of its
//! onset and the clean truck must raise no false alarm; the run must be deterministic in its
//! scores. The full proof (`fleetdyn prove --fleet`, docs/fleet.md) is too long for the suite.

use crate::common::fixture;
use fleetdyn::proof::{run_fleet_proof, FleetFault, FleetProofConfig};

#[test]
fn a_lost_fairing_is_flagged_and_a_clean_truck_is_left_alone() {
    let cfg = FleetProofConfig {
        seed: 1,
        trucks: 2,
        drives_per_truck: 6,
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
    let delay = faulty.delay.expect("the lost fairing is flagged");
    assert!(delay <= 5, "flagged {delay} drives after the onset");
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
}
