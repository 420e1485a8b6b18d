use fleetdyn::diagnose::run::{diagnose, DiagnoseConfig};
use fleetdyn::model::vehicle::VehicleFile;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let dir = std::path::Path::new(&a[1]);
    let sig = &a[2];
    let vf = VehicleFile::load(&dir.join("vehicle.toml")).unwrap();
    let opts = fleetdyn::pipeline::ingest_stage::IngestConfig::default()
        .options(&[], Some(&vf))
        .unwrap();
    let log = fleetdyn::ingest::ingest_file(&dir.join(&a[3]), &opts)
        .unwrap()
        .log;
    let d = diagnose(&log, &vf, &DiagnoseConfig::default()).unwrap();
    let r = d.residuals.iter().find(|r| &r.signal == sig).unwrap();
    let g = |n: &str| log.signal(n).map(|v| v.to_vec()).unwrap_or_default();
    let (v, br, cl, ge, tq, sl) = (
        g("vehicle_speed"),
        g("brake_force"),
        g("clutch_position"),
        g("gear"),
        g("engine_torque"),
        g("road_slope"),
    );
    let t0 = a.get(4).map_or(0.0, |x| x.parse().unwrap());
    let t1 = a.get(5).map_or(60.0, |x| x.parse().unwrap());
    let step: usize = a.get(6).map_or(25, |x| x.parse().unwrap());
    let last = |x: &[f64], i: usize| {
        let mut k = i;
        while k > 0 && !x.get(k).is_some_and(|y| y.is_finite()) {
            k -= 1;
        }
        x.get(k).copied().unwrap_or(f64::NAN)
    };
    for i in (0..log.len()).step_by(step) {
        let t = d.t_s[i];
        if t < t0 || t > t1 {
            continue;
        }
        println!("{t:7.2} res {:9.1} v {:6.2} brake {:8.0} clutch {:5.2} gear {:3} tq {:7.0} slope {:6.3}", r.before[i], last(&v,i), last(&br,i), last(&cl,i), last(&ge,i), last(&tq,i), last(&sl,i));
    }
}
