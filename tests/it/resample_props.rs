//! Invariants of distance resampling on random drives (proptest).

use fleetdyn::signal::distance::{resample_to_distance, ResampleConfig};
use fleetdyn::table::{DriveLog, DriveMeta, Signal};
use proptest::prelude::*;

fn drive(speeds: &[f64], dt_ms: i64) -> DriveLog {
    let n = speeds.len();
    DriveLog {
        meta: DriveMeta {
            drive_id: "p".into(),
            vehicle_id: None,
            source_file: "prop".into(),
            segment: None,
        },
        timestamp_ns: (0..n as i64).map(|k| k * dt_ms * 1_000_000).collect(),
        signals: vec![
            Signal {
                name: "vehicle_speed".into(),
                unit: "m/s".into(),
                values: speeds.to_vec(),
            },
            Signal {
                name: "gear".into(),
                unit: "1".into(),
                values: (0..n).map(|k| (k / 7 % 12) as f64).collect(),
            },
        ],
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Speeds 0…30 m/s with stretches of standstill: the grid is uniform, its times never go
    /// back, time_at and distance_at invert each other, and hold columns only take values the
    /// drive had.
    #[test]
    fn grid_is_monotone_and_maps_invert(
        speeds in prop::collection::vec(prop_oneof![Just(0.0), 0.0f64..30.0], 20..400),
        dt_ms in 10i64..200,
        step_m in prop_oneof![Just(1.0), 0.5f64..5.0],
    ) {
        let log = drive(&speeds, dt_ms);
        let cfg = ResampleConfig { step_m, min_distance_m: 0.0, ..Default::default() };
        let Ok(d) = resample_to_distance(&log, &cfg) else {
            // only a drive shorter than one step may fail
            let total: f64 = speeds.windows(2).map(|w| 0.5 * (w[0] + w[1]) * dt_ms as f64 * 1e-3).sum();
            prop_assert!(total < step_m + 1e-6);
            return Ok(());
        };
        prop_assert!(d.timestamp_ns.windows(2).all(|w| w[1] >= w[0]));
        for (k, &x) in d.distance_m.iter().enumerate() {
            prop_assert!((x - k as f64 * step_m).abs() < 1e-9);
            let t = d.map.time_at(x).unwrap();
            prop_assert_eq!(t, d.timestamp_ns[k]);
            // distance_at(time_at(x)) = x, to the ns rounding of time (< 30 m/s · 1 ns)
            prop_assert!((d.map.distance_at(t) - x).abs() < 1e-6, "x {} back {}", x, d.map.distance_at(t));
        }
        let gears = d.signal("gear").unwrap();
        prop_assert!(gears.iter().all(|g| g.fract() == 0.0 && (0.0..12.0).contains(g)));
        prop_assert!(d.map.x_m.windows(2).all(|w| w[1] >= w[0]));
    }
}
