//! Faults around a batch run: `kill -9` in the middle of a drive's commit and again later, then a
//! re-run that gives a clean run's bytes with no temporary file visible at any time; a read-only
//! output folder refused before any drive is read; a full disk failing the drives that hit it,
//! naming the file, leaving nothing half-written; the staging folders and temporaries of killed
//! report writers removed by the next run.
//!
//! The full disk is simulated without root: the child runs under `RLIMIT_FSIZE` (`ulimit -f`)
//! with `SIGXFSZ` ignored, so a write past the limit returns `EFBIG` ("File too large") where a
//! full file system returns `ENOSPC` — the same `io::Error` path in fleetdyn. The read-only
//! folder is a `chmod 555` folder; as root (who ignores permissions) the child is started as
//! user `nobody` so the permission bits apply.

use crate::batch_pipeline::{
    assert_only_whole_files, assert_same_bytes, deterministic_files, fleet_pipeline, markers,
    nightly_with_default_vehicle, report, synthetic_fleet, walk,
};
use crate::common::*;
use std::os::unix::fs::PermissionsExt;
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_fleetdyn"));
    c.current_dir(fixture(""));
    c
}

fn text(o: &Output) -> String {
    format!(
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Runs `cmd`, checks that it did not panic and exited with `code`; its stdout and stderr.
fn run_expecting(cmd: &mut Command, code: i32) -> String {
    let o = cmd.output().unwrap();
    assert_no_panic(&o);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(code), "{t}");
    t
}

fn assert_no_panic(o: &Output) {
    let t = text(o);
    assert!(
        o.status.code().is_some() && o.status.code() != Some(101) && !t.contains("panicked"),
        "{:?}: {t}",
        o.status
    );
}

/// Dataset files (not markers or reports) under `root`.
fn dataset_files(root: &Path) -> usize {
    walk(root)
        .iter()
        .filter(|p| {
            let rel = p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
            !rel.starts_with('_') && rel.ends_with(".parquet")
        })
        .count()
}

/// Starts a run and kills it (SIGKILL) as soon as `ready` holds for the output root; returns
/// whether the run was still going when killed.
fn kill_when(pipeline: &str, out: &Path, ready: impl Fn(&Path) -> bool) -> bool {
    let mut child = bin()
        .args(["run", pipeline, "--jobs", "1", "--out"])
        .arg(out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    loop {
        if ready(out) {
            break;
        }
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    true
}

#[test]
fn killed_mid_commit_twice_then_resumed_gives_the_clean_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let n = 8;
    let manifest = synthetic_fleet(dir.path(), n, 20_000);
    let pipeline = fleet_pipeline(dir.path(), &manifest);
    let p = pipeline.to_str().unwrap();
    let (clean, killed) = (dir.path().join("clean"), dir.path().join("killed"));
    let o = bin()
        .args(["run", p, "--jobs", "1", "--out"])
        .arg(&clean)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));

    // 1: the moment the first dataset file appears, i.e. inside the first drive's commit (its
    // other tables and its marker not yet written)
    assert!(
        kill_when(p, &killed, |r| dataset_files(r) >= 1),
        "the run ended before its first file appeared"
    );
    assert_only_whole_files(&killed);
    assert!(markers(&killed) < n);
    // 2: a later run, killed once a few drives are committed
    assert!(
        kill_when(p, &killed, |r| markers(r) >= 3),
        "the second run ended before it could be killed"
    );
    assert_only_whole_files(&killed);
    let done = markers(&killed);
    assert!(done < n, "{done} of {n} drives done: not killed mid-run");

    let o = bin()
        .args(["run", p, "--jobs", "2", "--out"])
        .arg(&killed)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let r = report(&killed, "fleet", "t1");
    assert_eq!(r["reused"].as_u64(), Some(done as u64), "{r}");
    let files = deterministic_files(&clean);
    assert_eq!(files, deterministic_files(&killed), "no file more or less");
    assert_same_bytes(&clean, &killed, &files);
    assert!(walk(&killed)
        .iter()
        .all(|f| !f.to_string_lossy().contains(".tmp-")));
}

/// A folder made read-only, and a command that runs the binary where its permission bits apply
/// (as `nobody` when this test runs as root).
fn read_only_folder(dir: &Path) -> (std::path::PathBuf, Command) {
    std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o755)).unwrap();
    let ro = dir.join("out");
    std::fs::create_dir(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    let mut cmd = bin();
    if std::fs::write(ro.join("probe"), b"").is_ok() {
        std::fs::remove_file(ro.join("probe")).unwrap();
        cmd.uid(65534).gid(65534); // root writes anywhere: drop to nobody
    }
    (ro, cmd)
}

#[test]
fn a_read_only_output_folder_is_refused_before_any_drive_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let (ro, mut cmd) = read_only_folder(dir.path());
    let pipeline = nightly_with_default_vehicle(dir.path(), "p.toml");
    std::fs::set_permissions(&pipeline, std::fs::Permissions::from_mode(0o644)).unwrap();
    let t = run_expecting(
        cmd.args(["run", pipeline.to_str().unwrap(), "--out"])
            .arg(&ro)
            .args(["--input", "fixtures/bad/good-small.parquet"]),
        3,
    );
    assert!(
        t.contains(&format!("output folder {} is not writable", ro.display()))
            && t.contains("Permission denied"),
        "{t}"
    );
    // refused before reading: no drive was processed
    assert!(!t.contains("good-small at"), "{t}");
    assert_eq!(walk(&ro).len(), 0);

    // a single-file command names the file it could not write, exit 3 (io), nothing left
    let single = dir.path().join("single");
    std::fs::create_dir(&single).unwrap();
    let (ro2, mut cmd) = read_only_folder(&single);
    let target = ro2.join("drive.parquet");
    let t = run_expecting(
        cmd.args(["ingest", "fixtures/bad/good-small.parquet", "-o"])
            .arg(&target),
        3,
    );
    assert!(
        t.contains(&target.display().to_string()) && t.contains("Permission denied"),
        "{t}"
    );
    assert_eq!(walk(&ro2).len(), 0);
}

#[test]
fn a_device_as_output_file_is_refused_not_replaced() {
    // /dev/full would give ENOSPC if written in place; the atomic writer writes beside the
    // target and renames, which would replace the device, so it refuses any target that is
    // not a regular file.
    let dev = Path::new("/dev/full");
    if !dev.exists() {
        return;
    }
    let t = run_expecting(
        bin().args([
            "ingest",
            "fixtures/bad/good-small.parquet",
            "-o",
            "/dev/full",
        ]),
        3,
    );
    assert!(
        t.contains("/dev/full") && t.contains("not a regular file"),
        "{t}"
    );
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::metadata(dev).unwrap().file_type().is_char_device());
    assert!(!std::fs::read_dir("/dev").unwrap().any(|e| e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .contains(".tmp-")));
}

#[test]
fn a_full_disk_fails_the_drives_it_hits_naming_the_file_and_leaves_nothing_half_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let pipeline = nightly_with_default_vehicle(dir.path(), "p.toml");
    // `ulimit -f` counts 512-byte blocks in POSIX sh (dash) and 1024-byte blocks in bash: 64
    // blocks is 32 or 64 KB, above every output of the small drive and below the fixture
    // drive's drive_log (hundreds of KB).
    let t = run_expecting(
        Command::new("sh")
            .current_dir(fixture(""))
            .args(["-c", "trap '' XFSZ; ulimit -f 64; exec \"$0\" \"$@\""])
            .arg(env!("CARGO_BIN_EXE_fleetdyn"))
            .args(["run", pipeline.to_str().unwrap(), "--jobs", "1", "--out"])
            .arg(&out)
            .args([
                "--input",
                "fixtures/drives/truck-0001.mcap",
                "--input",
                "fixtures/bad/good-small.parquet",
            ]),
        1,
    );
    assert!(
        t.contains("FAILED")
            && t.contains(&format!("truck-0001 at write: writing {}", out.display()))
            && t.contains("File too large"),
        "{t}"
    );
    assert_only_whole_files(&out);
    let files = walk(&out);
    assert!(
        files
            .iter()
            .all(|f| !f.to_string_lossy().contains("truck-0001")),
        "the failed drive left {files:?}"
    );
    // the small drive beside it completed
    let r = report(&out, "nightly", "2026.1");
    assert_eq!((r["ok"].as_u64(), r["failed"].as_u64()), (Some(1), Some(1)));
    assert!(files
        .iter()
        .any(|f| f.ends_with("good-small.parquet") && f.starts_with(out.join("drive_summary"))));
}

/// Every folder under `root` (recursively) whose name starts with `prefix`.
fn folders_named(root: &Path, prefix: &str) -> Vec<std::path::PathBuf> {
    let mut found = Vec::new();
    let mut todo = vec![root.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            if e.file_type().unwrap().is_dir() {
                if e.file_name().to_string_lossy().starts_with(prefix) {
                    found.push(e.path());
                }
                todo.push(e.path());
            }
        }
    }
    found
}

#[test]
fn leftovers_of_killed_report_writers_are_gone_after_the_next_run() {
    // A process killed while writing a drive's diagnosis leaves its staging folder (named with
    // its process id) in the drive's report folder; the task that takes the drive over has
    // another id. Here every diagnosed drive's folder holds such a leftover, one with a finished
    // file and a temporary, one empty, before the run; and the report folders a temporary file.
    let dir = tempfile::tempdir().unwrap();
    let (clean, resumed) = (dir.path().join("clean"), dir.path().join("resumed"));
    let run = |out: &Path| {
        run_expecting(
            bin()
                .args(["run", "pipelines/nightly.toml", "--out"])
                .arg(out),
            0,
        )
    };
    run(&clean);
    let drives: Vec<String> = (1..=4)
        .map(|n| {
            format!("_reports/diagnose/model_version=2026.1/vehicle_id=TRK-000{n}/truck-000{n}")
        })
        .collect();
    for d in &drives {
        let left = resumed.join(d).join(".diagnose-partial-4194301");
        std::fs::create_dir_all(&left).unwrap();
        std::fs::copy(
            clean.join(d).join("mismatch.parquet"),
            left.join("mismatch.parquet"),
        )
        .unwrap();
        std::fs::write(left.join(".findings.parquet.tmp-4194301-7"), b"half").unwrap();
        std::fs::create_dir_all(resumed.join(d).join(".diagnose-partial-4194302")).unwrap();
    }
    // and the run report's and the fleet step's folders a killed writer's temporaries
    let rep = resumed.join("_reports/nightly/model_version=2026.1");
    std::fs::create_dir_all(rep.join("fleet")).unwrap();
    std::fs::write(rep.join(".summary.md.tmp-4194301-3"), b"half").unwrap();
    std::fs::write(rep.join("fleet/.fleet.html.tmp-4194301-9"), b"half").unwrap();
    run(&resumed);
    assert_eq!(
        folders_named(&resumed, ".diagnose-partial-"),
        Vec::<std::path::PathBuf>::new()
    );
    let files = deterministic_files(&clean);
    assert_eq!(files, deterministic_files(&resumed), "no file more or less");
    assert_same_bytes(&clean, &resumed, &files);
}
