//! The book's reference tables stay equal to the schema files they are generated from
//! (`fleetdyn::schema::reference`): the vehicle-file keys in docs/vehicle-files.md, the canonical
//! drive log and the bundled mappings in docs/inputs.md, and every table of
//! `schemas/outputs/*.toml` in docs/outputs.md. Run with `FLEETDYN_WRITE_DOCS=1` to rewrite the
//! pages' generated sections from the schemas:
//!
//! `FLEETDYN_WRITE_DOCS=1 cargo test --release --test it docs_`

use fleetdyn::schema::reference::{
    begin_marker, drive_log_markdown, mappings_markdown, output_markdown, output_name, section,
    splice, vehicle_section_markdown, VEHICLE_SECTIONS,
};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(rel: &str) -> String {
    let p = root().join(rel);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// `(file name, text)` of every `*.toml` in a folder, sorted by file name.
fn toml_files(dir: &Path) -> Vec<(String, String)> {
    let mut files: Vec<(String, String)> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    files.sort();
    files
}

/// Checks (or, with `FLEETDYN_WRITE_DOCS`, rewrites) the generated sections of one page.
fn check_page(page_rel: &str, sections: &[(String, String)]) {
    let path = root().join(page_rel);
    let page = read(page_rel);
    let write = std::env::var_os("FLEETDYN_WRITE_DOCS").is_some();
    let mut new = page.clone();
    let mut stale = Vec::new();
    for (name, body) in sections {
        match section(&new, name) {
            None => panic!(
                "{page_rel}: section {name} needs exactly one {} and one matching end marker",
                begin_marker(name)
            ),
            Some(old) if old == body => {}
            Some(_) => {
                stale.push(name.clone());
                new = splice(&new, name, body).unwrap();
            }
        }
    }
    if write {
        if new != page {
            std::fs::write(&path, new).unwrap();
        }
        return;
    }
    assert!(
        stale.is_empty(),
        "{page_rel}: generated sections {stale:?} differ from the schemas; rewrite them with \
         FLEETDYN_WRITE_DOCS=1 cargo test --release --test it docs_"
    );
}

#[test]
fn the_vehicle_file_reference_is_the_schemas() {
    let schema = read("schemas/vehicle.toml");
    let sections: Vec<(String, String)> = VEHICLE_SECTIONS
        .iter()
        .map(|s| {
            (
                format!("vehicle-{s}"),
                vehicle_section_markdown(&schema, s).unwrap(),
            )
        })
        .collect();
    check_page("docs/vehicle-files.md", &sections);
}

#[test]
fn the_drive_log_and_mapping_reference_is_the_schemas() {
    let mappings = toml_files(&root().join("schemas/mappings"));
    assert!(!mappings.is_empty());
    let refs: Vec<(&str, &str)> = mappings
        .iter()
        .map(|(n, t)| (n.as_str(), t.as_str()))
        .collect();
    let sections = vec![
        (
            "drive-log".to_string(),
            drive_log_markdown(&read("schemas/drive-log.toml")).unwrap(),
        ),
        ("mappings".to_string(), mappings_markdown(&refs).unwrap()),
    ];
    check_page("docs/inputs.md", &sections);
}

#[test]
fn every_output_table_is_documented_as_its_schema_says() {
    let files = toml_files(&root().join("schemas/outputs"));
    assert!(!files.is_empty());
    let sections: Vec<(String, String)> = files
        .iter()
        .map(|(file, text)| {
            let name = output_name(text).unwrap_or_else(|e| panic!("{file}: {e}"));
            (format!("output-{name}"), output_markdown(text).unwrap())
        })
        .collect();
    check_page("docs/outputs.md", &sections);
    // no section for a table that has no schema any more
    let page = read("docs/outputs.md");
    for (i, _) in page.match_indices("<!-- generated:output-") {
        let rest = &page[i + "<!-- generated:".len()..];
        let name = &rest[..rest.find(':').unwrap()];
        assert!(
            sections.iter().any(|(n, _)| n == name),
            "docs/outputs.md: section {name} has no schema in schemas/outputs/"
        );
    }
}
