//! The generator of `fixtures/bad/`: every malformed input of the bad-input corpus, made from small
//! valid drives by one clear edit each, so the corpus is reproducible. `fixtures/bad/manifest.toml`
//! says what each file must give; `bad_corpus.rs` runs them.
//!
//! Regenerate (after changing this file) with
//! `FLEETDYN_WRITE_BAD_CORPUS=1 cargo test --release --test it bad_corpus_matches_its_generator`;
//! without the variable that test checks the committed files equal this generator's output.

use crate::common::*;
use arrow::array::{ArrayRef, Float64Array, Int64Array, TimestampMillisecondArray};
use arrow::datatypes::{Field, Schema};
use arrow::record_batch::RecordBatch;
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

/// The small valid drives the edits start from: `Drive::new(600)` (60 s at 10 Hz, 15 m/s,
/// 2 % slope, gear 10) and `mcap_messages()` (the same drive as three J1939 JSON topics).
const ROWS: usize = 600;

fn write(dir: &Path, name: &str, bytes: &[u8]) {
    std::fs::write(dir.join(name), bytes).unwrap();
}

fn drive_file(dir: &Path, name: &str, edit: impl FnOnce(&mut Drive)) {
    let mut d = Drive::new(ROWS);
    edit(&mut d);
    d.write(&dir.join(name));
}

/// A canonical wide Parquet file whose columns carry `unit` field metadata.
fn write_with_units(path: &Path, cols: Vec<(&str, &str, ArrayRef)>) {
    let fields: Vec<Field> = cols
        .iter()
        .map(|(n, u, a)| {
            Field::new(*n, a.data_type().clone(), true)
                .with_metadata(HashMap::from([("unit".to_string(), u.to_string())]))
        })
        .collect();
    let schema = Arc::new(Schema::new(fields));
    let batch =
        RecordBatch::try_new(schema.clone(), cols.into_iter().map(|c| c.2).collect()).unwrap();
    let f = std::fs::File::create(path).unwrap();
    let mut w = parquet::arrow::ArrowWriter::try_new(f, schema, None).unwrap();
    w.write(&batch).unwrap();
    w.close().unwrap();
}

fn mcap_file(dir: &Path, name: &str, edit: impl FnOnce(&mut Vec<(&'static str, i64, String)>)) {
    let mut m = mcap_messages();
    edit(&mut m);
    write_mcap(&dir.join(name), &m, None);
}

/// Replaces every occurrence of `from` by `to` (same length).
fn replace_all(b: &mut [u8], from: &[u8], to: &[u8]) -> usize {
    assert_eq!(from.len(), to.len());
    let mut n = 0;
    let mut i = 0;
    while i + from.len() <= b.len() {
        if &b[i..i + from.len()] == from {
            b[i..i + from.len()].copy_from_slice(to);
            n += 1;
            i += from.len();
        } else {
            i += 1;
        }
    }
    n
}

/// `text` with its first `from` replaced by `to` (which must be there).
fn edited(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from}");
    text.replacen(from, to, 1)
}

/// Writes every corpus file into `dir`.
pub fn generate(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let tmp = tempfile::tempdir().unwrap();

    // ---- MCAP -----------------------------------------------------------------------------
    mcap_file(dir, "good-small-mcap.mcap", |_| {});
    let good = std::fs::read(dir.join("good-small-mcap.mcap")).unwrap();
    write(dir, "mcap-empty.mcap", b"");
    write(dir, "mcap-truncated.mcap", &good[..good.len() / 3]);
    let mut b = good.clone();
    b[1] = b'X';
    write(dir, "mcap-bad-magic.mcap", &b);
    let mut b = good.clone();
    let n = b.len();
    b[n - 2] = b'X';
    write(dir, "mcap-bad-end-magic.mcap", &b);
    // one speed digit changed inside an uncompressed chunk: valid JSON, only the CRC can tell
    let mut b = good.clone();
    let needle = b"\"WheelBasedVehicleSpeed\": 54";
    let at = b.windows(needle.len()).position(|w| w == needle).unwrap();
    b[at + needle.len() - 1] = b'5';
    write(dir, "mcap-chunk-crc.mcap", &b);
    // zstd chunks whose compression field then names an algorithm MCAP does not know
    let z = tmp.path().join("z.mcap");
    write_mcap(&z, &mcap_messages(), Some(mcap::Compression::Zstd));
    let mut b = std::fs::read(&z).unwrap();
    assert!(replace_all(&mut b, b"\x04\x00\x00\x00zstd", b"\x04\x00\x00\x00brot") > 0);
    write(dir, "mcap-unknown-compression.mcap", &b);
    // zstd chunks with one byte of the second chunk's compressed records flipped
    let mut b = std::fs::read(&z).unwrap();
    let (off, len) = crate::ingest_errors::chunk_payload_offsets(&b)[1];
    b[off + len / 2] ^= 0x55;
    write(dir, "mcap-zstd-corrupt.mcap", &b);
    mcap_file(dir, "mcap-no-messages.mcap", |m| m.clear());
    // message 100 of /can/ccvs1 is not JSON
    mcap_file(dir, "mcap-json-garbage.mcap", |m| {
        m[300].2 = "{\"WheelBasedVehicleSpeed\": 54,".into()
    });
    // message 250 of /can/ccvs1 carries the speed as a string
    mcap_file(dir, "mcap-json-string-speed.mcap", |m| {
        m[750].2 = "{\"WheelBasedVehicleSpeed\": \"54 km/h\"}".into()
    });
    // the right topics, but the speed under another field name than the mapping's
    mcap_file(dir, "mcap-json-wrong-field.mcap", |m| {
        for x in m.iter_mut().filter(|x| x.0 == "/can/ccvs1") {
            x.2 = "{\"VehicleSpeed\": 54}".into();
        }
    });
    // topics the mapping does not know
    mcap_file(dir, "mcap-unmapped-topics.mcap", |m| {
        for x in m.iter_mut() {
            x.0 = "/vendor/blob";
        }
    });
    // speed message 201 logged 5 s before message 200
    mcap_file(dir, "mcap-time-backwards.mcap", |m| {
        m[603].1 -= 5_000_000_000
    });
    // one speed message a year after the drive: a gap no alignment may bridge or allocate
    mcap_file(dir, "mcap-year-gap.mcap", |m| {
        let last = m.iter().rposition(|x| x.0 == "/can/ccvs1").unwrap();
        m[last].1 += 365 * 86_400 * 1_000_000_000;
    });

    // speed and slope at 1 Hz for 700 s, and three gear messages 0.1 ms apart: the fastest
    // channel's rate would make a 10 kHz grid of 7 M rows from 700 samples
    let mut m = Vec::new();
    for k in 0..700i64 {
        let t = T0_NS + k * 1_000_000_000;
        m.push((
            "/can/ccvs1",
            t,
            "{\"WheelBasedVehicleSpeed\": 54}".to_string(),
        ));
        m.push((
            "/can/slope",
            t + 1_000_000,
            "{\"RoadSlope\": 2}".to_string(),
        ));
    }
    for k in 0..3i64 {
        let t = T0_NS + 10_000_000_000 + k * 100_000;
        m.push((
            "/can/etc2",
            t,
            "{\"TransmissionCurrentGear\": 10}".to_string(),
        ));
    }
    m.sort_by_key(|x| x.1);
    write_mcap(&dir.join("mcap-grid-bomb.mcap"), &m, None);

    // ---- Parquet ----------------------------------------------------------------------------
    drive_file(dir, "good-small.parquet", |_| {});
    let good = std::fs::read(dir.join("good-small.parquet")).unwrap();
    write(dir, "parquet-empty.parquet", b"");
    write(
        dir,
        "parquet-is-csv.parquet",
        b"timestamp,vehicle_speed,road_slope\n0,15,0.02\n",
    );
    write(
        dir,
        "parquet-magic-garbage.parquet",
        b"PAR1 this is not a parquet body PAR1",
    );
    write(dir, "parquet-truncated.parquet", &good[..good.len() / 2]);
    let d = Drive::new(ROWS);
    write_parquet(
        &dir.join("parquet-zero-rows.parquet"),
        vec![
            ("timestamp", ts(&[])),
            ("vehicle_speed", f64s(&[])),
            ("road_slope", f64s(&[])),
        ],
    );
    drive_file(dir, "parquet-one-row.parquet", |d| {
        d.t_ns.truncate(1);
        d.speed.truncate(1);
        d.slope.truncate(1);
        d.gear.truncate(1);
    });
    let n = ROWS;
    let words: Vec<&str> = (0..n).map(|_| "fast").collect();
    write_parquet(
        &dir.join("speed-as-string.parquet"),
        vec![
            ("timestamp", ts(&d.t_ns)),
            ("vehicle_speed", strs(&words)),
            ("road_slope", f64_opt(&d.slope)),
        ],
    );
    let stamps: Vec<String> = d.t_ns.iter().map(|t| t.to_string()).collect();
    let stamps: Vec<&str> = stamps.iter().map(String::as_str).collect();
    write_parquet(
        &dir.join("timestamp-as-string.parquet"),
        vec![
            ("timestamp", strs(&stamps)),
            ("vehicle_speed", f64_opt(&d.speed)),
            ("road_slope", f64_opt(&d.slope)),
        ],
    );
    write_parquet(
        &dir.join("no-timestamp.parquet"),
        vec![
            ("vehicle_speed", f64_opt(&d.speed)),
            ("road_slope", f64_opt(&d.slope)),
        ],
    );
    write_parquet(
        &dir.join("no-slope.parquet"),
        vec![
            ("timestamp", ts(&d.t_ns)),
            ("vehicle_speed", f64_opt(&d.speed)),
        ],
    );
    drive_file(dir, "time-backwards.parquet", |d| d.t_ns.swap(20, 21));
    drive_file(dir, "duplicate-timestamp.parquet", |d| {
        d.t_ns[31] = d.t_ns[30];
        d.speed[31] = Some(16.0);
    });
    drive_file(dir, "nan-burst-slope.parquet", |d| {
        for k in 100..130 {
            d.slope[k] = None; // 3 s at 10 Hz, over the 2 s limit
        }
    });
    drive_file(dir, "nan-speed-all.parquet", |d| d.speed = vec![None; ROWS]);
    drive_file(dir, "speed-infinite.parquet", |d| {
        d.speed[42] = Some(f64::INFINITY)
    });
    drive_file(dir, "speed-constant-zero.parquet", |d| {
        d.speed = vec![Some(0.0); ROWS]
    });
    // backing up at 1.5 m/s (inside the plausible range, beyond the 0.5 m/s reverse threshold)
    drive_file(dir, "reverse-driving.parquet", |d| {
        for k in 300..340 {
            d.speed[k] = Some(-1.5);
        }
    });
    // a year between rows 300 and 301: distance must not be integrated across it
    drive_file(dir, "parquet-year-gap.parquet", |d| {
        for t in &mut d.t_ns[300..] {
            *t += 365 * 86_400 * 1_000_000_000;
        }
    });
    drive_file(dir, "absurd-slope.parquet", |d| d.slope[17] = Some(0.45));
    drive_file(dir, "absurd-speed.parquet", |d| d.speed[9] = Some(250.0));
    drive_file(dir, "gear-beyond-gearbox.parquet", |d| d.gear[40] = 14);
    // isolated glitches a real logger produces, masked by default
    drive_file(dir, "glitch-inf-speed.parquet", |d| {
        d.speed[25] = Some(f64::INFINITY)
    });
    drive_file(dir, "glitch-speed-spike.parquet", |d| {
        d.speed[33] = Some(41.0)
    });
    // a gateway repeating a message unchanged: the exact duplicate row is dropped and counted
    drive_file(dir, "duplicate-rows-agreeing.parquet", |d| {
        d.t_ns[51] = d.t_ns[50];
        d.speed[51] = d.speed[50];
        d.slope[51] = d.slope[50];
        d.gear[51] = d.gear[50];
    });
    drive_file(dir, "glitch-repeated-timestamp.parquet", |d| {
        d.t_ns[44] = d.t_ns[43];
        d.speed[44] = Some(15.2);
    });
    // a driver's rest with the logger asleep: two hours without a row between two 2-minute
    // stretches (1.8 km each); split into two drives
    const HOUR_NS: i64 = 3_600_000_000_000;
    let mut r = Drive::new(4 * ROWS);
    for t in &mut r.t_ns[2 * ROWS..] {
        *t += 2 * HOUR_NS;
    }
    r.write(&dir.join("rest-stop-pause.parquet"));
    // the same, then half an hour later a 30 s wake-up: a third segment too short to keep
    let mut r = Drive::new(4 * ROWS);
    for t in &mut r.t_ns[2 * ROWS..] {
        *t += 2 * HOUR_NS;
    }
    for t in &mut r.t_ns[3 * ROWS + ROWS / 2..] {
        *t += HOUR_NS / 2;
    }
    r.write(&dir.join("rest-stop-short-wake.parquet"));
    // the slope sensor silent for five minutes while the truck drives on (its other signals
    // continue): the drive is split around the hole
    let mut r = Drive::new(12 * ROWS);
    for s in &mut r.slope[3 * ROWS..8 * ROWS] {
        *s = None;
    }
    r.write(&dir.join("slope-sensor-silent.parquet"));
    // a rest stop in a multi-rate MCAP recording: every topic stops for two hours
    let half = 3 * ROWS as i64 / 2;
    let m = mcap_messages_at(
        (0..2 * half).map(|k| T0_NS + k * 100_000_000 + if k >= half { 2 * HOUR_NS } else { 0 }),
    );
    write_mcap(&dir.join("mcap-rest-stop-pause.mcap"), &m, None);
    // times near the end of i64 nanoseconds (year 2262): grid arithmetic must not overflow
    drive_file(dir, "timestamps-at-i64-max.parquet", |d| {
        for (k, t) in d.t_ns.iter_mut().enumerate() {
            *t = i64::MAX - (ROWS - k) as i64 * 100_000_000;
        }
    });
    let speed: ArrayRef = Arc::new(Float64Array::from(vec![54.0; n]));
    let slope: ArrayRef = Arc::new(Float64Array::from(vec![2.0; n]));
    write_with_units(
        &dir.join("unit-unknown.parquet"),
        vec![
            ("timestamp", "ns", ts(&d.t_ns)),
            ("vehicle_speed", "furlong/fortnight", speed.clone()),
            ("road_slope", "%", slope.clone()),
        ],
    );
    write_with_units(
        &dir.join("unit-wrong-dimension.parquet"),
        vec![
            ("timestamp", "ns", ts(&d.t_ns)),
            ("vehicle_speed", "kPa", speed),
            ("road_slope", "%", slope),
        ],
    );
    // long (ts, signal, value) exports: integer times without a unit, and only a signal no
    // mapping knows
    let t_ms: Vec<i64> = d.t_ns.iter().map(|t| t / 1_000_000).collect();
    let long = |ts: ArrayRef, path: &Path| {
        write_parquet(
            path,
            vec![
                ("ts", ts),
                ("signal", strs(&vec!["SPN9999"; n])),
                ("value", f64s(&vec![1.0; n])),
            ],
        )
    };
    long(
        Arc::new(Int64Array::from(t_ms.clone())),
        &dir.join("long-export-ts-no-unit.parquet"),
    );
    long(
        Arc::new(TimestampMillisecondArray::from(t_ms).with_timezone("UTC")),
        &dir.join("long-export-no-known-signal.parquet"),
    );
    // a canonical-looking table without vehicle_speed: the message names that column
    let d = Drive::new(ROWS);
    write_with_units(
        &dir.join("canonical-no-speed.parquet"),
        vec![
            ("timestamp", "ns", ts(&d.t_ns)),
            ("road_slope", "1", f64_opt(&d.slope)),
        ],
    );

    // ---- raw CAN: MDF4 logs and DBC files, from the parked J1939 truck's recording -----------
    let mdf = std::fs::read(fixture(
        "fixtures/real/css-j1939-parked/00000001-head80k.MF4",
    ))
    .unwrap();
    let flipped = |at: usize| {
        let mut b = mdf.clone();
        for x in &mut b[at..at + 8] {
            *x ^= 0xFF;
        }
        b
    };
    // eight bytes flipped inside one frame record (its payload offset names no data): that frame
    // is skipped and counted, the log goes on
    write(dir, "mdf4-flipped-record.MF4", &flipped(60_000));
    // eight bytes flipped in the header block: nothing can be read, a clear error
    write(dir, "mdf4-flipped-header.MF4", &flipped(64));
    let dbc = std::fs::read_to_string(fixture(
        "fixtures/real/css-j1939-parked/CSS-Electronics-SAE-J1939-DEMO.dbc",
    ))
    .unwrap();
    // cut in the middle of a signal line
    let cut = dbc.find("\"km/h\"").expect("the speed signal's unit");
    write(dir, "dbc-truncated.dbc", &dbc.as_bytes()[..cut]);
    // a 16-bit signal from bit 60 of an 8-byte message
    write(
        dir,
        "dbc-signal-beyond-message.dbc",
        edited(
            &dbc,
            "WheelBasedVehicleSpeed : 8|16@1+",
            "WheelBasedVehicleSpeed : 60|16@1+",
        )
        .as_bytes(),
    );

    // ---- vehicle files ------------------------------------------------------------------------
    let truck = std::fs::read_to_string(fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let edit = |from: &str, to: &str| edited(&truck, from, to);
    write(
        dir,
        "vehicle-nan-mass.toml",
        edit("mass_kg = 40000.0", "mass_kg = nan").as_bytes(),
    );
    write(
        dir,
        "vehicle-negative-mass.toml",
        edit("mass_kg = 40000.0", "mass_kg = -40000.0").as_bytes(),
    );
    write(
        dir,
        "vehicle-zero-gears.toml",
        edit("forward_gears = 12", "forward_gears = 0").as_bytes(),
    );
    write(
        dir,
        "vehicle-ratios-count.toml",
        edit(", 1.28, 1.00]", "]").as_bytes(),
    );
    write(
        dir,
        "vehicle-unknown-key.toml",
        edit(
            "wheel_radius_m = 0.5",
            "wheel_radius_m = 0.5\nwheel_radius_in = 19.7",
        )
        .as_bytes(),
    );
    write(
        dir,
        "vehicle-not-toml.toml",
        b"mass_kg: 40000\n[driveline\n",
    );

    // ---- pipeline files -----------------------------------------------------------------------
    // its paths, relative to pipelines/, made relative to fixtures/bad/
    let nightly = std::fs::read_to_string(fixture("pipelines/nightly.toml"))
        .unwrap()
        .replace("\"../", "\"../../");
    let edit = |from: &str, to: &str| edited(&nightly, from, to);
    write(
        dir,
        "pipeline-unknown-key.toml",
        edit("step_m = 1.0", "step_m = 1.0\nstep_km = 0.001").as_bytes(),
    );
    write(
        dir,
        "pipeline-stage-order.toml",
        edit(
            "stages = [\"ingest\", \"resample\"",
            "stages = [\"resample\", \"ingest\"",
        )
        .as_bytes(),
    );
    write(
        dir,
        "pipeline-cutoff-beyond-nyquist.toml",
        edit("cutoff_per_m = 0.004", "cutoff_per_m = 0.8").as_bytes(),
    );
    write(
        dir,
        "pipeline-not-toml.toml",
        b"name = nightly\nstages = [ingest\n",
    );

    // ---- mapping files ------------------------------------------------------------------------
    let portal =
        std::fs::read_to_string(fixture("schemas/mappings/fleet-portal-export.toml")).unwrap();
    assert!(portal.contains("unit = \"bar\""));
    write(
        dir,
        "mapping-unknown-unit.toml",
        portal
            .replacen("unit = \"bar\"", "unit = \"atm-ish\"", 1)
            .as_bytes(),
    );
}
