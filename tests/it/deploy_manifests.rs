//! The deploy files as written: the Kubernetes manifests validate against the Kubernetes API
//! schema (`kubernetes-validate` from PyPI, pinned in deploy/test/requirements.txt, strict: no
//! unknown fields), and the Slurm script and the container files name what the repository has.
//!
//! The validator is found from `FLEETDYN_K8S_VALIDATE` (its path) or on the PATH; without it
//! the schema check is skipped with a printed reason, unless `FLEETDYN_REQUIRE_K8S_VALIDATE=1`
//! (as `.ci/run` sets after installing it).

use crate::common::fixture;
use std::path::{Path, PathBuf};
use std::process::Command;

fn validator() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("FLEETDYN_K8S_VALIDATE") {
        return Some(PathBuf::from(p));
    }
    let found = Command::new("kubernetes-validate")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    found.then(|| PathBuf::from("kubernetes-validate"))
}

fn validate(tool: &Path, file: &Path) -> (bool, String) {
    let o = Command::new(tool)
        .args(["--strict", "-k", "1.30.0"])
        .arg(file)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), text)
}

#[test]
fn kubernetes_manifests_validate_against_the_api_schema() {
    let manifests: Vec<PathBuf> = std::fs::read_dir(fixture("deploy"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml" || e == "yml"))
        .collect();
    assert!(!manifests.is_empty());
    for m in &manifests {
        let text = std::fs::read_to_string(m).unwrap();
        // the image the repository builds
        assert!(text.contains("image: fleetdyn:0.1.0"), "{}", m.display());
    }
    let Some(tool) = validator() else {
        let required = std::env::var("FLEETDYN_REQUIRE_K8S_VALIDATE").is_ok_and(|v| v == "1");
        assert!(
            !required,
            "FLEETDYN_REQUIRE_K8S_VALIDATE=1 and no kubernetes-validate"
        );
        eprintln!(
            "deploy_manifests: no kubernetes-validate (pip install -r deploy/test/requirements.txt), schema check skipped"
        );
        return;
    };
    for m in &manifests {
        let (ok, text) = validate(&tool, m);
        assert!(ok && text.contains("passed"), "{}: {text}", m.display());
    }
    // the validator does validate: a wrong type and an unknown field are refused
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(&manifests[0]).unwrap();
    for (from, to) in [
        ("completions: 8", "completions: \"eight\""),
        (
            "restartPolicy: Never",
            "restartPolicy: Never\n      restartPolicyy: Never",
        ),
    ] {
        assert!(text.contains(from));
        let bad = dir.path().join("bad.yaml");
        std::fs::write(&bad, text.replacen(from, to, 1)).unwrap();
        let (ok, out) = validate(&tool, &bad);
        assert!(!ok, "accepted with {to}: {out}");
    }
}

#[test]
fn the_container_files_and_the_slurm_script_name_what_the_repository_has() {
    let cf = std::fs::read_to_string(fixture("deploy/Containerfile")).unwrap();
    // multi-stage: built with the Rust image of the crate's minimum version, run as non-root
    let manifest = std::fs::read_to_string(fixture("Cargo.toml")).unwrap();
    let msrv = manifest
        .lines()
        .find_map(|l| l.strip_prefix("rust-version = "))
        .unwrap()
        .trim_matches('"');
    assert!(cf.contains(&format!("rust:{msrv}-slim")), "{msrv}");
    assert_eq!(
        cf.matches("\nFROM ").count() + usize::from(cf.starts_with("FROM")),
        2
    );
    assert!(cf.contains("USER 10001"));
    for copied in cf.lines().filter_map(|l| l.strip_prefix("COPY ")) {
        if copied.starts_with("--from") {
            continue;
        }
        let parts: Vec<&str> = copied.split_whitespace().collect();
        for src in &parts[..parts.len() - 1] {
            assert!(
                fixture(src).exists(),
                "Containerfile copies {src}, not in the repository"
            );
        }
    }
    let local = std::fs::read_to_string(fixture("deploy/Containerfile.local")).unwrap();
    assert!(local.contains("FROM scratch") && local.contains("USER 10001"));
    // the Slurm script passes the array to --shard and reads its paths from the environment
    let s = std::fs::read_to_string(fixture("deploy/slurm-nightly-array.sh")).unwrap();
    for needle in [
        "--shard \"${SLURM_ARRAY_TASK_ID}/${SHARDS}\"",
        "FLEETDYN_PIPELINE",
        "FLEETDYN_OUTPUT",
        "#SBATCH --requeue",
    ] {
        assert!(s.contains(needle), "{needle}");
    }
}
