//! Atomic writes: every output goes to a temporary file beside the destination and is renamed
//! over it only when complete, so a failed or interrupted write never leaves a half-written file
//! (and an existing destination keeps its old content). Files that belong together (a render's
//! EXR and PNG, an export's VDB, USD stage and images) go through an [`OutputSet`]: all are
//! written first, and moved into place only when every one succeeded.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// An error about `path` that Occlux found itself, before the system was asked.
fn refusal(path: &Path, kind: std::io::ErrorKind, message: String) -> Error {
    Error::io(path, std::io::Error::new(kind, message))
}

/// Fails, naming `out_dir`, when files cannot be made there: what callers check before they
/// compute. Leaves nothing behind: a folder that does not exist yet is not made, its nearest
/// existing ancestor is tried instead.
pub fn check_writable(out_dir: &Path) -> Result<()> {
    let mut existing = out_dir;
    while !existing.exists() {
        match existing.parent() {
            Some(parent) if !parent.as_os_str().is_empty() => existing = parent,
            _ => {
                existing = Path::new(".");
                break;
            }
        }
    }
    if !existing.is_dir() {
        return Err(refusal(
            out_dir,
            std::io::ErrorKind::NotADirectory,
            format!("{} is a file, not a folder", existing.display()),
        ));
    }
    tempfile::Builder::new()
        .prefix(".occlux-probe-")
        .tempfile_in(existing)
        .map(drop)
        .map_err(|e| Error::io(out_dir, e))
}

/// Files written together into one folder: each is written into a hidden staging folder inside
/// it, and [`OutputSet::commit`] moves them all into place once every one is complete. Dropped
/// without a commit (an error on the way), the staging folder and all in it are removed, and
/// the folder holds what it held before.
pub struct OutputSet {
    staging: tempfile::TempDir,
    out_dir: PathBuf,
    names: Vec<String>,
}

impl OutputSet {
    /// Creates `out_dir` if needed and the staging folder in it: this fails, naming the folder,
    /// when it cannot be written, so callers make the set before computing anything.
    pub fn new(out_dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
        let staging = tempfile::Builder::new()
            .prefix(".occlux-staging-")
            .tempdir_in(out_dir)
            .map_err(|e| Error::io(out_dir, e))?;
        Ok(Self {
            staging,
            out_dir: out_dir.to_path_buf(),
            names: Vec::new(),
        })
    }

    /// Where to write the file `name` of the set (in the staging folder). A folder already in
    /// its place could not be replaced at the commit, so it is refused here, before the set
    /// writes anything there.
    pub fn path(&mut self, name: &str) -> Result<PathBuf> {
        let destination = self.out_dir.join(name);
        if destination.is_dir() {
            return Err(refusal(
                &destination,
                std::io::ErrorKind::IsADirectory,
                "a folder is in the place of this output".into(),
            ));
        }
        self.names.push(name.to_owned());
        Ok(self.staging.path().join(name))
    }

    /// Moves every file into `out_dir` (renames within one folder: they do not fail for want
    /// of space) and returns their final paths.
    pub fn commit(self) -> Result<Vec<PathBuf>> {
        let mut written = Vec::with_capacity(self.names.len());
        for name in &self.names {
            let (from, to) = (self.staging.path().join(name), self.out_dir.join(name));
            std::fs::rename(&from, &to).map_err(|e| Error::io(&to, e))?;
            written.push(to);
        }
        Ok(written)
    }
}

/// Writes `path` through `write`, atomically.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(refusal(
            path,
            std::io::ErrorKind::NotFound,
            format!("folder {} does not exist", dir.display()),
        ));
    }
    let mut builder = tempfile::Builder::new();
    builder.prefix(".occlux-").suffix(".partial");
    // Temporary files are private (0600); outputs are ordinary files others may read.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let temp = builder.tempfile_in(dir).map_err(|e| Error::io(path, e))?;
    // On any error below, dropping `temp` deletes the temporary file.
    let mut writer = BufWriter::new(temp.reopen().map_err(|e| Error::io(path, e))?);
    write(&mut writer)?;
    let file = writer
        .into_inner()
        .map_err(|e| Error::io(path, e.into_error()))?;
    file.sync_all().map_err(|e| Error::io(path, e))?;
    temp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| w.write_all(bytes).map_err(|e| Error::io(path, e)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_writes_leave_the_old_file_and_no_temporaries() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        write_bytes_atomic(&path, b"first").unwrap();
        let err = write_atomic(&path, |w| {
            w.write_all(b"half").unwrap();
            Err(Error::param("test", "stopped half way"))
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"first");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "temporary file left behind");
        write_bytes_atomic(&path, b"second").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&path).unwrap().permissions().mode();
            assert_eq!(
                mode & 0o044,
                0o044,
                "outputs are readable by others: {mode:o}"
            );
        }
    }

    #[test]
    fn a_set_lands_whole_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let mut set = OutputSet::new(&out).unwrap();
        write_bytes_atomic(&set.path("a.txt").unwrap(), b"a").unwrap();
        write_bytes_atomic(&set.path("b.txt").unwrap(), b"b").unwrap();
        // Nothing in place before the commit.
        assert!(!out.join("a.txt").exists());
        let written = set.commit().unwrap();
        assert_eq!(written, vec![out.join("a.txt"), out.join("b.txt")]);
        assert_eq!(std::fs::read(out.join("b.txt")).unwrap(), b"b");
        // A set whose second file fails leaves the first file's old content, and no staging.
        let mut set = OutputSet::new(&out).unwrap();
        write_bytes_atomic(&set.path("a.txt").unwrap(), b"new").unwrap();
        let failed = write_atomic(&set.path("b.txt").unwrap(), |_| {
            Err(Error::param("test", "failed"))
        });
        assert!(failed.is_err());
        drop(set);
        assert_eq!(std::fs::read(out.join("a.txt")).unwrap(), b"a");
        let names: Vec<_> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
    }

    #[test]
    fn a_folder_that_cannot_be_made_is_named_before_anything_is_written() {
        // A file where the output folder should be: no folder can be made there (for root
        // too, unlike a read-only folder).
        let dir = tempfile::tempdir().unwrap();
        let blocked = dir.path().join("blocked");
        std::fs::write(&blocked, b"a file").unwrap();
        let err = OutputSet::new(&blocked.join("out"))
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("blocked"), "{err}");
        assert_eq!(std::fs::read(&blocked).unwrap(), b"a file");
    }

    #[test]
    fn a_missing_folder_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("nope").join("out.txt");
        let err = write_bytes_atomic(&path, b"x").unwrap_err().to_string();
        assert!(
            err.contains("nope") && err.contains("does not exist"),
            "{err}"
        );
    }
}
