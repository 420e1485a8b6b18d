//! Atomic file creation: write to a hidden temporary name in the target folder, then rename.
//!
//! A reader (or a resumed nightly job) therefore sees either no file or a complete one. The
//! temporary file is removed when the writer is dropped without [`AtomicFile::commit`], so an
//! error anywhere in between leaves nothing behind.

use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Removes the temporary files that interrupted writers (a killed process) left in `dir`: the
/// hidden `.<name>.tmp-<pid>-<n>` names of [`AtomicFile::create`], whatever process made them.
/// Only for a folder the caller owns, where no other process writes at the same time.
///
/// # Errors
/// An I/O error reading the folder (a missing folder is not one) or removing a file.
pub fn remove_stale_temps(dir: &Path) -> io::Result<()> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e),
    };
    for e in entries {
        let e = e?;
        let name = e.file_name();
        let name = name.to_string_lossy();
        if name.starts_with('.') && name.contains(".tmp-") && e.file_type()?.is_file() {
            std::fs::remove_file(e.path())?;
        }
    }
    Ok(())
}

/// A file being written under a temporary name next to its final path.
#[derive(Debug)]
pub struct AtomicFile {
    file: Option<File>,
    tmp: PathBuf,
    target: PathBuf,
}

impl AtomicFile {
    /// Writes `bytes` to `target` atomically: the whole file appears, or nothing.
    ///
    /// # Errors
    /// Any I/O error; nothing is then left at `target`.
    pub fn write_all(target: &Path, bytes: &[u8]) -> io::Result<()> {
        use std::io::Write as _;
        let mut f = Self::create(target)?;
        f.file().write_all(bytes)?;
        f.commit()
    }

    /// Creates `.<name>.tmp-<pid>-<n>` in the target's folder (creating the folder if needed).
    ///
    /// # Errors
    /// Any I/O error creating the folder or the file; [`io::ErrorKind::InvalidInput`] when the
    /// target exists and is not a regular file (a folder, or a device such as `/dev/full`,
    /// which the final rename would otherwise replace).
    pub fn create(target: &Path) -> io::Result<Self> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        if let Ok(m) = std::fs::metadata(target) {
            if !m.is_file() {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!(
                        "{} exists and is not a regular file; not replaced",
                        target.display()
                    ),
                ));
            }
        }
        let dir = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&dir)?;
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!(".{name}.tmp-{}-{n}", std::process::id()));
        let file = File::create(&tmp)?;
        Ok(Self {
            file: Some(file),
            tmp,
            target: target.to_path_buf(),
        })
    }

    /// The open temporary file.
    pub fn file(&mut self) -> &mut File {
        self.file.as_mut().expect("file is open until commit")
    }

    /// A second handle to the temporary file (for writers that take ownership).
    ///
    /// # Errors
    /// I/O error from `try_clone`.
    pub fn try_clone_file(&self) -> io::Result<File> {
        self.file
            .as_ref()
            .expect("file is open until commit")
            .try_clone()
    }

    /// Flushes to disk and renames to the final path.
    ///
    /// # Errors
    /// I/O error from sync or rename; the temporary file is then removed.
    pub fn commit(mut self) -> io::Result<()> {
        let file = self.file.take().expect("commit once");
        file.sync_all()?;
        drop(file);
        std::fs::rename(&self.tmp, &self.target)
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.is_some() || self.tmp.exists() {
            self.file.take();
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn dropped_writer_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("x.parquet");
        {
            let mut f = AtomicFile::create(&target).unwrap();
            f.file().write_all(b"partial").unwrap();
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let mut f = AtomicFile::create(&target).unwrap();
        f.file().write_all(b"whole").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"whole");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_target_that_is_not_a_regular_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let e = AtomicFile::create(dir.path()).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        assert!(e.to_string().contains("not a regular file"), "{e}");
        if Path::new("/dev/null").exists() {
            let e = AtomicFile::write_all(Path::new("/dev/null"), b"x").unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn stale_temps_of_any_process_are_removed_and_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for n in [".a.parquet.tmp-4194301-0", ".summary.md.tmp-7-12"] {
            std::fs::write(d.join(n), b"half").unwrap();
        }
        for n in ["a.parquet", ".hidden", "b.tmp-3-1"] {
            std::fs::write(d.join(n), b"whole").unwrap();
        }
        std::fs::create_dir(d.join(".c.tmp-1-1")).unwrap();
        remove_stale_temps(d).unwrap();
        let mut left: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, [".c.tmp-1-1", ".hidden", "a.parquet", "b.tmp-3-1"]);
        // a folder that does not exist holds nothing stale
        remove_stale_temps(&d.join("missing")).unwrap();
    }
}
