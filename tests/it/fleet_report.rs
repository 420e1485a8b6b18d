//! The fleet page (src/report/fleet_html.rs) opened in a real headless browser: a fleet of two
//! vehicles, one that lost a fairing after twelve drives and one clean, rendered to
//! `fleet.html`, loaded by Chromium from the distribution's packages, which must draw it (a
//! screenshot, kept as `target/tmp/fleet_report/fleet.png`) and whose DOM must hold the plot,
//! the sentence and both vehicles, with no console error. The page must need nothing from the
//! network: no scripts, no stylesheets or images by URL.
//!
//! Without a `chromium` (or `chromium-browser`) on the PATH the browser part is skipped with a
//! printed reason, unless `FLEETDYN_REQUIRE_BROWSER=1` (as CI sets it), which makes it fail.

use fleetdyn::fleet::series::{DriveEstimates, EstimateRow};
use fleetdyn::fleet::vehicle_evidence;
use fleetdyn::report::fleet_html::{fleet_html, PageInfo};
use std::path::{Path, PathBuf};
use std::process::Command;

fn drive(vehicle: &str, i: usize, drag: f64) -> DriveEstimates {
    DriveEstimates {
        vehicle_id: vehicle.into(),
        drive_id: format!("{vehicle}-d{i:02}"),
        start_ns: 1_777_000_000_000_000_000 + i as i64 * 86_400_000_000_000,
        verdict: if i.is_multiple_of(5) {
            "unexplained".into()
        } else {
            "no_significant_mismatch".into()
        },
        source: String::new(),
        rows: vec![
            EstimateRow {
                effect: "aero_drag".into(),
                unit: "m^2".into(),
                value: drag,
                ci_low: drag - 0.4,
                ci_high: drag + 0.4,
                nominal: 5.6,
                tolerance_low: 5.32,
                tolerance_high: 5.88,
                method: "linearised".into(),
            },
            // the payload from trip to trip: 30 to 39 t
            EstimateRow {
                effect: "vehicle_mass".into(),
                unit: "kg".into(),
                value: 30_000.0 + 1_000.0 * (i % 10) as f64,
                ci_low: 29_500.0 + 1_000.0 * (i % 10) as f64,
                ci_high: 30_500.0 + 1_000.0 * (i % 10) as f64,
                nominal: 40_000.0,
                tolerance_low: 38_800.0,
                tolerance_high: 41_200.0,
                method: "linearised".into(),
            },
        ],
    }
}

fn chromium() -> Option<PathBuf> {
    ["chromium", "chromium-browser"].iter().find_map(|name| {
        std::env::var_os("PATH").and_then(|paths| {
            std::env::split_paths(&paths)
                .map(|d| d.join(name))
                .find(|p| p.is_file())
        })
    })
}

fn headless(browser: &Path, args: &[&str], page: &Path) -> std::process::Output {
    Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--hide-scrollbars",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .args(args)
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("chromium runs")
}

#[test]
fn fleet_page_renders_in_a_headless_browser() {
    // a drag area 79 % above the file after 12 drives: outside the pooled band (the drives'
    // band widened to the linearised estimates' allowance, 3.75–9.24 m²)
    let changed = (0..30).map(|i| {
        let level = if i < 12 { 5.6 } else { 10.0 };
        drive(
            "TRK-0100",
            i,
            level + if i.is_multiple_of(2) { 0.1 } else { -0.1 },
        )
    });
    let clean = (0..20).map(|i| {
        drive(
            "TRK-0200",
            i,
            5.6 + if i.is_multiple_of(3) { 0.15 } else { -0.05 },
        )
    });
    let vehicles = vec![
        vehicle_evidence("TRK-0100", changed.collect()),
        vehicle_evidence("TRK-0200", clean.collect()),
    ];
    let html = fleet_html(
        &PageInfo {
            pipeline: "nightly",
            model_version: "2026.1",
        },
        &vehicles,
        &|v, d| format!("../drives/{v}/{d}/report.md"),
    );
    // self-contained: nothing to fetch
    for needle in ["<script", "<link", "<img", " src=", "url("] {
        assert!(!html.contains(needle), "{needle} in the page");
    }
    assert_eq!(
        html.matches("<svg").count(),
        1,
        "one plot: the flagged parameter"
    );
    assert_eq!(
        html.matches("vehicle_mass: ").count(),
        2,
        "each vehicle's trips summarised once"
    );
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fleet_report");
    std::fs::create_dir_all(&dir).unwrap();
    let page = dir.join("fleet.html");
    std::fs::write(&page, &html).unwrap();

    let Some(browser) = chromium() else {
        let required = std::env::var("FLEETDYN_REQUIRE_BROWSER").is_ok_and(|v| v == "1");
        assert!(
            !required,
            "FLEETDYN_REQUIRE_BROWSER=1 and no chromium on the PATH"
        );
        eprintln!(
            "fleet_report: no chromium on the PATH, browser check skipped ({})",
            page.display()
        );
        return;
    };
    // the DOM as the browser built it
    let o = headless(&browser, &["--dump-dom"], &page);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let dom = String::from_utf8_lossy(&o.stdout);
    assert!(dom.contains("<svg"), "no plot in the DOM");
    assert!(
        dom.contains("aero_drag: 10.0 m^2"),
        "no sentence in the DOM"
    );
    assert!(dom.contains("TRK-0100") && dom.contains("TRK-0200"));
    // the mass stays per trip: summarised in the vehicle table, never plotted or flagged
    assert!(
        dom.contains("vehicle_mass: 30000 to 39000 kg over 30 trips, median 34500 kg"),
        "no per-trip mass in the DOM"
    );
    assert_eq!(dom.matches("<circle").count(), 30, "one mark per drive");
    assert!(!dom.contains("parsererror"));
    let log = String::from_utf8_lossy(&o.stderr);
    let console: Vec<&str> = log.lines().filter(|l| l.contains("CONSOLE")).collect();
    assert!(console.is_empty(), "console messages: {console:?}");
    // drawn: a PNG of the page
    let png = dir.join("fleet.png");
    let _ = std::fs::remove_file(&png);
    let o = headless(
        &browser,
        &[
            &format!("--screenshot={}", png.display()),
            "--window-size=1200,1400",
        ],
        &page,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let bytes = std::fs::read(&png).expect("a screenshot");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert!(
        bytes.len() > 20_000,
        "{} bytes: an empty page?",
        bytes.len()
    );
    eprintln!(
        "fleet_report: screenshot {} ({} bytes)",
        png.display(),
        bytes.len()
    );
}
