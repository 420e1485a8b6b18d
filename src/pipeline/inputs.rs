//! Inputs of a pipeline run: files, folders (searched recursively for `.mcap` and `.parquet`),
//! `*` globs in the last path component, and manifest files.
//!
//! A **manifest** is any input file whose extension is neither `.mcap` nor `.parquet`: one drive
//! per line, `path,vehicle_id` (the vehicle id may be left out: `path`), `#` starts a comment,
//! blank lines are ignored, and a first non-comment line `path,vehicle_id` is a header. Relative
//! paths are relative to the manifest's folder. A manifest's vehicle id overrides the one in the
//! drive's metadata, and is known before any drive is read, so a vehicle id without a vehicle
//! file is a plan error.
//!
//! The listing is sorted by path and free of duplicates, so the same inputs give the same plan
//! (and the same shards) wherever it is made.

use std::path::{Path, PathBuf};

/// One drive to process.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct InputItem {
    /// Source file (MCAP or Parquet).
    pub path: PathBuf,
    /// Vehicle id given by a manifest.
    pub vehicle_id: Option<String>,
}

/// What the listing found: the drives, and every problem (all of them, not only the first).
#[derive(Debug, Default)]
pub struct Listing {
    /// Drives, sorted by path.
    pub items: Vec<InputItem>,
    /// Inputs that do not exist, globs matching nothing, bad manifest lines.
    pub problems: Vec<String>,
}

fn is_drive_file(p: &Path) -> bool {
    matches!(
        p.extension().and_then(|e| e.to_str()),
        Some("mcap" | "parquet")
    )
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)?
        .map(|e| e.map(|e| e.path()))
        .collect::<Result<_, _>>()?;
    entries.sort();
    for p in entries {
        let hidden = p
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with('.') || n.starts_with('_'));
        if hidden {
            continue;
        }
        if p.is_dir() {
            walk(&p, out)?;
        } else if is_drive_file(&p) {
            out.push(p);
        }
    }
    Ok(())
}

/// Whether `name` matches `pat`, where `*` stands for any run of characters.
pub fn glob_match(pat: &str, name: &str) -> bool {
    let parts: Vec<&str> = pat.split('*').collect();
    if parts.len() == 1 {
        return pat == name;
    }
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if name.len() < first.len() + last.len()
        || !name.starts_with(first)
        || !name[first.len()..].ends_with(last)
    {
        return false;
    }
    let mut rest = &name[first.len()..name.len() - last.len()];
    for mid in &parts[1..parts.len() - 1] {
        match rest.find(mid) {
            Some(i) => rest = &rest[i + mid.len()..],
            None => return false,
        }
    }
    true
}

fn read_manifest(path: &Path, out: &mut Vec<InputItem>, problems: &mut Vec<String>) {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) => {
            problems.push(format!("manifest {}: {e}", path.display()));
            return;
        }
    };
    let base = path.parent().unwrap_or(Path::new(""));
    let mut first = true;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        if std::mem::take(&mut first) && line.replace(' ', "") == "path,vehicle_id" {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let at = || format!("manifest {} line {}", path.display(), i + 1);
        if fields.len() > 2 || fields[0].is_empty() {
            problems.push(format!(
                "{}: expected `path,vehicle_id`, found `{line}`",
                at()
            ));
            continue;
        }
        let p = base.join(fields[0]);
        if !p.is_file() {
            problems.push(format!("{}: {} does not exist", at(), p.display()));
            continue;
        }
        if !is_drive_file(&p) {
            problems.push(format!(
                "{}: {} is neither .mcap nor .parquet",
                at(),
                p.display()
            ));
            continue;
        }
        let vehicle_id = fields
            .get(1)
            .filter(|v| !v.is_empty())
            .map(|v| v.to_string());
        out.push(InputItem {
            path: p,
            vehicle_id,
        });
    }
}

/// Lists the drives of `patterns` (see the module doc).
///
/// # Errors
/// Never fails as a whole: problems are collected in [`Listing::problems`]. The `Result` is
/// kept for callers that treat an unreadable folder as fatal.
pub fn list_inputs(patterns: &[PathBuf]) -> Result<Listing, String> {
    let mut l = Listing::default();
    let mut files = Vec::new();
    for p in patterns {
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if name.contains('*') {
            let dir = p
                .parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(Path::new("."));
            let entries = match std::fs::read_dir(dir) {
                Ok(e) => e,
                Err(e) => {
                    l.problems.push(format!("input {}: {e}", p.display()));
                    continue;
                }
            };
            let before = files.len();
            for e in entries.flatten() {
                let path = e.path();
                let n = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
                if path.is_file() && !n.starts_with('.') && glob_match(name, n) {
                    files.push(path);
                }
            }
            if files.len() == before {
                l.problems
                    .push(format!("input {} matches no file", p.display()));
            }
        } else if p.is_dir() {
            if let Err(e) = walk(p, &mut files) {
                l.problems.push(format!("input {}: {e}", p.display()));
            }
        } else if p.is_file() {
            if is_drive_file(p) {
                files.push(p.clone());
            } else {
                read_manifest(p, &mut l.items, &mut l.problems);
            }
        } else {
            l.problems
                .push(format!("input {} does not exist", p.display()));
        }
    }
    l.items.extend(files.into_iter().map(|path| InputItem {
        path,
        vehicle_id: None,
    }));
    l.items.sort();
    l.items.dedup();
    // one path listed twice with different vehicle ids
    for w in l.items.windows(2) {
        if w[0].path == w[1].path {
            l.problems.push(format!(
                "input {} is listed with vehicle ids {} and {}",
                w[0].path.display(),
                w[0].vehicle_id.as_deref().unwrap_or("(none)"),
                w[1].vehicle_id.as_deref().unwrap_or("(none)")
            ));
        }
    }
    Ok(l)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glob_matches_like_a_shell() {
        assert!(glob_match("*.mcap", "a.mcap"));
        assert!(glob_match("truck-*-x.parquet", "truck-1-x.parquet"));
        assert!(!glob_match("*.mcap", "a.parquet"));
        assert!(!glob_match("ab*ba", "aba"));
    }

    #[test]
    fn manifest_lines_are_read_and_bad_ones_reported_together() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("a.mcap"), b"x").unwrap();
        std::fs::write(d.path().join("b.parquet"), b"x").unwrap();
        let m = d.path().join("drives.csv");
        std::fs::write(
            &m,
            "path,vehicle_id\na.mcap, TRK-1  # morning\n\nb.parquet\nmissing.mcap,TRK-2\na.mcap,TRK-1,extra\n",
        )
        .unwrap();
        let l = list_inputs(&[m]).unwrap();
        assert_eq!(l.items.len(), 2);
        assert_eq!(l.items[0].vehicle_id.as_deref(), Some("TRK-1"));
        assert_eq!(l.items[1].vehicle_id, None);
        assert_eq!(l.problems.len(), 2, "{:?}", l.problems);
        assert!(l.problems[0].contains("line 5"));
        assert!(l.problems[1].contains("line 6"));
    }
}
