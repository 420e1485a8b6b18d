//! How the paths of a pipeline file resolve (docs/pipelines.md, "How paths resolve"): a relative
//! path in the file is relative to the file's own folder, so a pipeline and its configuration
//! travel together (a repository checkout, a Kubernetes config map mounted under `/config`, a
//! Slurm job started from any folder). Paths given on the command line resolve against the
//! current directory, as a shell user expects.

use std::path::{Component, Path, PathBuf};

/// `p` resolved against the folder `base` when relative, with `.` and `..` components removed
/// lexically: the file system is not consulted, so a path that does not exist yet (an output
/// root) and a glob resolve alike. `..` above a relative `base` is kept (`../data`).
pub fn resolve(base: &Path, p: &Path) -> PathBuf {
    let joined = if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    };
    let mut out: Vec<Component<'_>> = Vec::new();
    for c in joined.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => match out.last() {
                Some(Component::Normal(_)) => {
                    out.pop();
                }
                // `/..` is `/`
                Some(Component::RootDir) | Some(Component::Prefix(_)) => {}
                _ => out.push(c),
            },
            _ => out.push(c),
        }
    }
    if out.is_empty() {
        return PathBuf::from(".");
    }
    out.iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_resolve_against_the_file_folder_lexically() {
        let r = |b: &str, p: &str| resolve(Path::new(b), Path::new(p));
        assert_eq!(
            r("pipelines", "../fixtures/drives/*.mcap"),
            Path::new("fixtures/drives/*.mcap")
        );
        assert_eq!(r("", "in/a.mcap"), Path::new("in/a.mcap"));
        assert_eq!(r("/config", "../data/out"), Path::new("/data/out"));
        assert_eq!(r("/config", "/data/in"), Path::new("/data/in"));
        assert_eq!(r("a/./b", "./c/../d"), Path::new("a/b/d"));
        assert_eq!(r("cfg", "../../up"), Path::new("../up"));
        assert_eq!(r("/", "../x"), Path::new("/x"));
        assert_eq!(r("a", ".."), Path::new("."));
    }
}
