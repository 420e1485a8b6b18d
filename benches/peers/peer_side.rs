//! fleetdyn's side of the peer benchmark (`benches/peers/run.sh`, issue 8): runs one kernel on
//! an input file written by `benches/peers/peers.py`, repeats it, writes the result for the
//! comparison and prints the timings as one JSON line.
//!
//! ```text
//! peer_side OP INPUT.f64 OUTPUT.f64 REPEATS
//! ```
//! Files are raw little-endian f64. Operations (the same parameters as the Python side):
//! - `sosfiltfilt`: 3rd-order Butterworth low-pass at 0.004 of the sampling rate (the seed
//!   000 §5 slope filter on a 1 m grid), zero-phase with scipy's edge handling (odd extension,
//!   padlen = 3·(2·sections + 1 − …) as scipy computes it) — fleetdyn's `EdgeMode::Scipy`;
//! - `welch`: Welch PSD, fs = 1, Hann window, nperseg 4096, 50 % overlap, density scaling,
//!   constant detrend; written as the PSD values (fleetdyn also computes the χ² interval,
//!   which scipy does not — included in its time);
//! - `floor_copy`: read the input and write it to a new buffer (one pass each way: the memory
//!   traffic a filter that reads and writes every sample once cannot go below);
//! - `floor_sum`: read the input once (a reduction: what a PSD that reads every sample once
//!   cannot go below).
//!
//! Timing: wall clock of the kernel only (input already in memory), each repeat on a fresh
//! output; the median is reported with every run.

use fleetdyn::signal::{butter, sosfiltfilt, welch, BandType, EdgeMode, WelchConfig};
use std::hint::black_box;
use std::time::Instant;

fn read_f64(path: &str) -> Vec<f64> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    assert!(
        bytes.len().is_multiple_of(8),
        "{path}: not a whole number of f64"
    );
    bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect()
}

fn write_f64(path: &str, v: &[f64]) {
    let mut out = Vec::with_capacity(v.len() * 8);
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
    std::fs::write(path, out).unwrap_or_else(|e| panic!("{path}: {e}"));
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() != 5 {
        eprintln!("usage: peer_side OP INPUT.f64 OUTPUT.f64 REPEATS");
        std::process::exit(2);
    }
    let (op, input, output) = (a[1].as_str(), a[2].as_str(), a[3].as_str());
    let repeats: usize = a[4].parse().expect("REPEATS is a count");
    let x = read_f64(input);
    let sos = butter(3, 4e-3, 1.0, BandType::Lowpass).expect("valid design");
    let edge = EdgeMode::Scipy { padlen: None };
    let wcfg = WelchConfig {
        fs_hz: 1.0,
        nperseg: Some(4096),
        noverlap: None,
        confidence: 0.95,
    };
    let run = |x: &[f64]| -> Vec<f64> {
        match op {
            "sosfiltfilt" => sosfiltfilt(&sos, x, &edge).expect("finite input"),
            "welch" => welch(x, &wcfg).expect("finite input").psd,
            "floor_copy" => x.to_vec(),
            "floor_sum" => vec![x.iter().sum::<f64>()],
            other => {
                eprintln!("unknown OP {other}");
                std::process::exit(2);
            }
        }
    };
    let mut times = Vec::with_capacity(repeats);
    let mut last = Vec::new();
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        let y = run(black_box(&x));
        times.push(t.elapsed().as_secs_f64());
        last = black_box(y);
    }
    write_f64(output, &last);
    let mut sorted = times.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let runs: Vec<String> = times.iter().map(|t| format!("{t:.6}")).collect();
    println!(
        "{{\"op\": \"{op}\", \"n\": {}, \"median_s\": {median:.6}, \"runs_s\": [{}]}}",
        x.len(),
        runs.join(", ")
    );
}
