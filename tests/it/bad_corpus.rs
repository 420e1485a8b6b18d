//! The bad-input corpus: every file of `fixtures/bad/` through the real CLI, with the exit code and
//! message `fixtures/bad/manifest.toml` states for it, no panic, and no output left behind; then
//! the bad drives inside one `fleetdyn run` batch beside good fixture drives, which must still
//! complete. The files come from `bad_corpus_gen.rs`.

use crate::bad_corpus_gen::generate;
use crate::batch_pipeline::{nightly_with_default_vehicle, walk};
use crate::common::{fixture, fleetdyn_at_top};
use serde::Deserialize;
use std::process::Output;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    case: Vec<Case>,
}

/// One corpus file and what it must give.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Case {
    /// File in `fixtures/bad/`.
    file: String,
    /// CLI arguments; `{file}` is the corpus file (relative to the repository top, the working
    /// folder), `{out}` an empty output folder.
    args: Vec<String>,
    /// Expected exit code (0 for the controls).
    exit: i32,
    /// Substrings the error message (stderr) must contain.
    #[serde(default)]
    message: Vec<String>,
    /// For drive inputs: the stage the drive must fail at inside a `fleetdyn run` batch
    /// (`"ok"` for the controls, `"split"` for a recording that must become several drives, all
    /// ok); the run report's error must contain `message` as well, or `batch_message` when given
    /// (the pipeline's ingest settings differ from the case's flags).
    batch: Option<String>,
    /// What the batch error must contain instead of `message`.
    batch_message: Option<Vec<String>>,
}

fn manifest() -> Manifest {
    let text = std::fs::read_to_string(fixture("fixtures/bad/manifest.toml")).unwrap();
    toml::from_str(&text).unwrap()
}

fn fleetdyn(args: &[String]) -> Output {
    fleetdyn_at_top(args)
}

#[test]
fn bad_corpus_matches_its_generator() {
    let committed = fixture("fixtures/bad");
    if std::env::var_os("FLEETDYN_WRITE_BAD_CORPUS").is_some() {
        generate(&committed);
    }
    let dir = tempfile::tempdir().unwrap();
    generate(dir.path());
    let made = walk(dir.path());
    assert!(made.len() >= 30, "{} files", made.len());
    for p in &made {
        let name = p.file_name().unwrap();
        let c = committed.join(name);
        assert!(
            std::fs::read(&c).ok() == Some(std::fs::read(p).unwrap()),
            "fixtures/bad/{} differs from its generator (see bad_corpus_gen.rs to regenerate)",
            name.to_string_lossy()
        );
    }
    // every committed corpus file is generated and has exactly one manifest case
    let m = manifest();
    for c in walk(&committed) {
        let name = c
            .strip_prefix(&committed)
            .unwrap()
            .to_string_lossy()
            .into_owned();
        if name == "manifest.toml" {
            continue;
        }
        if name.starts_with("fuzz/") {
            // inputs found by the fuzzers (docs/validation/robustness.md), committed as found
            assert_eq!(
                m.case.iter().filter(|k| k.file == name).count(),
                1,
                "{name}"
            );
            continue;
        }
        assert!(dir.path().join(&name).is_file(), "{name} is not generated");
        assert_eq!(
            m.case.iter().filter(|k| k.file == name).count(),
            1,
            "{name}: cases in the manifest"
        );
    }
}

/// Rust debug formatting in a user-facing message: `Some(…)`, `None`, or a `"…"`-quoted value as
/// `{:?}` prints strings (messages quote values with backticks).
fn debug_formatting(text: &str) -> Option<&'static str> {
    if text.contains("Some(") {
        Some("Some(")
    } else if text
        .split(|c: char| !c.is_alphanumeric())
        .any(|w| w == "None")
    {
        Some("None")
    } else if text.contains('"') {
        Some("a \"quoted\" value")
    } else {
        None
    }
}

#[test]
fn debug_formatting_is_found() {
    assert_eq!(debug_formatting("vehicle_id Some(\"TRK\")"), Some("Some("));
    assert_eq!(debug_formatting("table None, expected"), Some("None"));
    assert_eq!(
        debug_formatting("unit \"km/h\""),
        Some("a \"quoted\" value")
    );
    assert_eq!(debug_formatting("unit `km/h`; Nonesuch"), None);
}

fn assert_no_panic(what: &str, o: &Output) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.code().is_some() && o.status.code() != Some(101) && !stderr.contains("panicked"),
        "{what}: panic or signal ({:?}): {stderr}",
        o.status
    );
}

#[test]
fn every_bad_input_fails_clearly_through_the_cli() {
    let m = manifest();
    assert!(
        m.case.iter().filter(|c| c.exit != 0).count() >= 30,
        "the corpus has fewer than 30 bad inputs"
    );
    let root = tempfile::tempdir().unwrap();
    let mut problems = Vec::new();
    for (k, c) in m.case.iter().enumerate() {
        let out = root.path().join(format!("out-{k}"));
        std::fs::create_dir(&out).unwrap();
        let args: Vec<String> = c
            .args
            .iter()
            .map(|a| {
                a.replace("{file}", &format!("fixtures/bad/{}", c.file))
                    .replace("{out}", &out.display().to_string())
            })
            .collect();
        let o = fleetdyn(&args);
        assert_no_panic(&c.file, &o);
        let stderr = String::from_utf8_lossy(&o.stderr);
        let said = format!("{stderr}{}", String::from_utf8_lossy(&o.stdout));
        if o.status.code() != Some(c.exit) {
            problems.push(format!(
                "{}: exit {:?}, expected {}: {stderr}",
                c.file,
                o.status.code(),
                c.exit
            ));
            continue;
        }
        for s in &c.message {
            if !said.contains(s.as_str()) {
                problems.push(format!("{}: message lacks {s:?}: {said}", c.file));
            }
        }
        if let Some(d) = debug_formatting(&stderr) {
            problems.push(format!("{}: debug formatting ({d}) in: {stderr}", c.file));
        }
        if c.exit != 0 {
            // the message names the file it is about (the corpus file, or the input it was
            // applied to)
            let left = walk(&out);
            if !left.is_empty() {
                problems.push(format!("{}: left output behind: {left:?}", c.file));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n\n"));
}

#[test]
fn bad_drives_fail_alone_inside_a_batch() {
    let m = manifest();
    let dir = tempfile::tempdir().unwrap();
    // nightly with a default vehicle file, so drives without a vehicle id reach their own error
    let pipeline = nightly_with_default_vehicle(dir.path(), "nightly-default-vehicle.toml");
    let good = ["truck-0001.mcap", "truck-0003-export.parquet"];
    let drives: Vec<&Case> = m.case.iter().filter(|c| c.batch.is_some()).collect();
    assert!(drives.len() >= 25, "{} drive inputs", drives.len());
    let out = dir.path().join("out");
    let mut args = vec![
        "run".to_string(),
        pipeline.display().to_string(),
        "--jobs".into(),
        "2".into(),
        "--out".into(),
        out.display().to_string(),
    ];
    for g in good {
        args.extend(["--input".into(), format!("fixtures/drives/{g}")]);
    }
    for c in &drives {
        args.extend(["--input".into(), format!("fixtures/bad/{}", c.file)]);
    }
    let o = fleetdyn(&args);
    assert_no_panic("batch", &o);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(
        &std::fs::read(out.join("_reports/nightly/model_version=2026.1/run_report.json")).unwrap(),
    )
    .unwrap();
    let rows = report["drives"].as_array().unwrap();
    let by_input = |name: &str| {
        rows.iter()
            .find(|r| r["input"].as_str().is_some_and(|s| s.ends_with(name)))
            .unwrap_or_else(|| panic!("{name} not in the run report: {report}"))
    };
    let mut problems = Vec::new();
    // the good fixture drives completed with all their tables
    let written: Vec<String> = walk(&out).iter().map(|p| p.display().to_string()).collect();
    for g in good {
        let r = by_input(g);
        if r["status"] == "failed" {
            problems.push(format!("good drive {g} failed: {r}"));
        }
        let id = r["drive_id"].as_str().unwrap();
        let n = written
            .iter()
            .filter(|f| f.ends_with(&format!("/{id}.parquet")))
            .count();
        if n < 5 {
            problems.push(format!("good drive {g}: {n} tables written"));
        }
    }
    for c in &drives {
        let r = by_input(&c.file);
        let stage = c.batch.as_deref().unwrap();
        if stage == "split" {
            let mine: Vec<&serde_json::Value> = rows
                .iter()
                .filter(|r| r["input"].as_str().is_some_and(|s| s.ends_with(&c.file)))
                .collect();
            let stem = c.file.rsplit_once('.').map_or(c.file.as_str(), |p| p.0);
            if mine.len() < 2 {
                problems.push(format!("{}: not split: {mine:?}", c.file));
            }
            for (k, d) in mine.iter().enumerate() {
                let id = format!("{stem}-s{}", k + 1);
                if d["status"] == "failed" || d["drive_id"] != id.as_str() {
                    problems.push(format!(
                        "{}: segment {k} is not drive {id}, ok: {d}",
                        c.file
                    ));
                }
                let n = written
                    .iter()
                    .filter(|f| f.ends_with(&format!("/{id}.parquet")))
                    .count();
                if n < 5 {
                    problems.push(format!("{}: drive {id}: {n} tables written", c.file));
                }
            }
            continue;
        }
        let id = r["drive_id"].as_str().unwrap();
        if stage == "ok" {
            if r["status"] == "failed" {
                problems.push(format!("control {} failed: {r}", c.file));
            }
            // a glitch went through masked, and the run report counts it
            let m = &r["record"]["metrics"];
            if c.file.starts_with("glitch-")
                && m["masked_samples"].as_object().is_none_or(|o| o.is_empty())
                && m["conflicts_resolved"].as_u64().unwrap_or(0) == 0
            {
                problems.push(format!("{}: nothing counted as masked: {r}", c.file));
            }
            continue;
        }
        if r["failed_stage"] != stage {
            problems.push(format!("{}: expected to fail at {stage}: {r}", c.file));
            continue;
        }
        let err = r["error"].as_str().unwrap_or_default();
        for s in c.batch_message.as_ref().unwrap_or(&c.message) {
            if !err.contains(s.as_str()) {
                problems.push(format!("{}: batch error lacks {s:?}: {err}", c.file));
            }
        }
        if let Some(d) = debug_formatting(err) {
            problems.push(format!("{}: debug formatting ({d}) in: {err}", c.file));
        }
        // a failed drive writes no dataset file
        if let Some(f) = written
            .iter()
            .find(|f| !f.contains("/_reports/") && f.contains(&format!("/{id}.")))
        {
            problems.push(format!("{}: failed but wrote {f}", c.file));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n\n"));
}
