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

/// Prefix of a set's hidden staging folder inside its output folder, and of its owner file.
const STAGING_PREFIX: &str = ".occlux-staging-";

/// The owner file of staging folder `F` is `F.owner`, beside it. Its process holds it locked
/// for as long as the set lives, and the system drops the lock when the process ends, however
/// it ends (SIGKILL included), so a later run that can take the lock knows the folder is left
/// over, even if the process id has been reused since. The owner is made and locked before its
/// folder, so a folder without an owner is always left over (its process was killed while
/// removing it); were the lock inside the folder, a folder killed before its lock was made
/// would look like one whose process is about to make it.
const OWNER_SUFFIX: &str = ".owner";

/// Tries at claiming an owner file that a concurrent run's cleanup keeps removing between its
/// creation and its lock (each such try is a window of two system calls).
const CLAIM_TRIES: usize = 8;

/// The staging folders of this process's live sets, for [`remove_live_staging`].
static LIVE_STAGING: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

fn live_staging() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A panic elsewhere while the list was held leaves it usable.
    LIVE_STAGING.lock().unwrap_or_else(|e| e.into_inner())
}

/// The owner file of staging folder `folder`.
fn owner_of(folder: &Path) -> PathBuf {
    let mut name = folder.as_os_str().to_owned();
    name.push(OWNER_SUFFIX);
    PathBuf::from(name)
}

/// Removes staging folder `folder`, then its owner file (in that order, so that a process
/// killed between leaves an owner whose lock the next run can take). Best effort.
fn remove_staging(folder: &Path) {
    let _ = std::fs::remove_dir_all(folder);
    let _ = std::fs::remove_file(owner_of(folder));
}

/// Removes the staging folders of every set of this process that is not committed yet: what
/// a program calls when it is interrupted (SIGINT, SIGTERM) before it exits, so no partial
/// files stay. A set being committed finishes first (the commit holds the same lock), so an
/// interrupted commit never leaves half a set in place.
pub fn remove_live_staging() {
    let mut live = live_staging();
    for staging in live.drain(..) {
        remove_staging(&staging);
    }
}

/// Removes the staging folders in `out_dir` that no live process owns: those of runs that
/// were killed (or lost power) before they could clean up. Best effort: what cannot be
/// removed stays for the next run, and never stops this one.
fn remove_stale_staging(out_dir: &Path) {
    let Ok(entries) = std::fs::read_dir(out_dir) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if !name.starts_with(STAGING_PREFIX) {
            continue;
        }
        let path = entry.path();
        if let Some(folder) = name.strip_suffix(OWNER_SUFFIX) {
            let unowned = File::open(&path).is_ok_and(|owner| owner.try_lock().is_ok());
            if unowned {
                remove_staging(&out_dir.join(folder));
            }
        } else if path.is_dir() && !owner_of(&path).exists() {
            // Its owner was made first and is removed last: this folder's process is gone.
            let _ = std::fs::remove_dir_all(&path);
        }
    }
}

/// An owner file in `out_dir`, locked, and still at its path: a concurrent run's cleanup that
/// found it between its creation and its lock removed it, and a new name is taken.
fn claim_owner(out_dir: &Path) -> Result<tempfile::NamedTempFile> {
    for _ in 0..CLAIM_TRIES {
        let owner = tempfile::Builder::new()
            .prefix(STAGING_PREFIX)
            .suffix(OWNER_SUFFIX)
            .tempfile_in(out_dir)
            .map_err(|e| Error::io(out_dir, e))?;
        owner
            .as_file()
            .lock()
            .map_err(|e| Error::io(owner.path(), e))?;
        if still_at_path(&owner) {
            return Ok(owner);
        }
        // Removed by the other run: forget the path rather than delete whatever holds it now.
        drop(owner.into_temp_path().keep());
    }
    Err(Error::io(
        out_dir,
        std::io::Error::other(format!(
            "another run removed this run's staging owner file {CLAIM_TRIES} times over"
        )),
    ))
}

/// Whether the file `owner` holds open is still the one at its path.
fn still_at_path(owner: &tempfile::NamedTempFile) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let (Ok(held), Ok(named)) = (owner.as_file().metadata(), owner.path().metadata()) else {
            return false;
        };
        held.dev() == named.dev() && held.ino() == named.ino()
    }
    // Elsewhere an open file cannot be removed.
    #[cfg(not(unix))]
    {
        owner.path().exists()
    }
}

/// Files written together into one folder: each is written into a hidden staging folder inside
/// it, and [`OutputSet::commit`] moves them all into place once every one is complete. Dropped
/// without a commit (an error on the way), the staging folder and all in it are removed, and
/// the folder holds what it held before; a process killed on the way leaves the staging folder,
/// which the next set made in that folder removes.
///
/// A set may name one file its **marker** ([`OutputSet::marker`]: an export's USD stage, an AO
/// volume's JSON record): the commit removes the marker's old version before it moves anything
/// and moves the new one last, so a reader that finds the marker finds the whole set, and a
/// folder without it holds an incomplete one.
pub struct OutputSet {
    /// The staging folder, removed when the set is dropped (committed or not).
    staging: PathBuf,
    /// Its owner file beside it (see [`OWNER_SUFFIX`]), held locked while the set lives and
    /// removed after the folder.
    _owner: tempfile::NamedTempFile,
    out_dir: PathBuf,
    names: Vec<String>,
    marker: Option<String>,
}

impl OutputSet {
    /// Creates `out_dir` if needed and the staging folder in it: this fails, naming the folder,
    /// when it cannot be written, so callers make the set before computing anything. Staging
    /// folders that killed runs left in `out_dir` are removed first.
    pub fn new(out_dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
        remove_stale_staging(out_dir);
        let owner = claim_owner(out_dir)?;
        // The owner's name is the folder's with OWNER_SUFFIX (tempfile's random part has no dot).
        let staging = owner.path().with_extension("");
        // The owner's name is this run's alone, so the folder's is too: one there already was
        // left by a run that lost its owner file, and goes.
        if staging.exists() {
            let _ = std::fs::remove_dir_all(&staging);
        }
        std::fs::create_dir(&staging).map_err(|e| Error::io(&staging, e))?;
        live_staging().push(staging.clone());
        Ok(Self {
            staging,
            _owner: owner,
            out_dir: out_dir.to_path_buf(),
            names: Vec::new(),
            marker: None,
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
        Ok(self.staging.join(name))
    }

    /// As [`OutputSet::path`], for the set's marker: the file that says the set is whole.
    pub fn marker(&mut self, name: &str) -> Result<PathBuf> {
        let path = self.path(name)?;
        self.names.pop();
        self.marker = Some(name.to_owned());
        Ok(path)
    }

    /// Moves every file into `out_dir` (renames within one folder: they do not fail for want
    /// of space), the marker last, and returns their final paths in the order they were asked
    /// for, the marker last.
    pub fn commit(self) -> Result<Vec<PathBuf>> {
        // Not interrupted half way: a signal handler's removal waits for this lock.
        let mut live = live_staging();
        if let Some(marker) = &self.marker {
            match std::fs::remove_file(self.out_dir.join(marker)) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(Error::io(self.out_dir.join(marker), e));
                }
                _ => {}
            }
        }
        let mut written = Vec::with_capacity(self.names.len() + 1);
        for name in self.names.iter().chain(&self.marker) {
            let (from, to) = (self.staging.join(name), self.out_dir.join(name));
            std::fs::rename(&from, &to).map_err(|e| Error::io(&to, e))?;
            written.push(to);
        }
        live.retain(|p| p != &self.staging);
        Ok(written)
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        // The owner file goes after the folder, when the field drops.
        let _ = std::fs::remove_dir_all(&self.staging);
        live_staging().retain(|p| p != &self.staging);
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
    fn a_new_set_removes_staging_that_no_live_process_owns_and_commits_its_marker_last() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        // Left by a killed run: its owner file is there, and nobody holds its lock.
        let dead = out.join(".occlux-staging-dead");
        std::fs::create_dir(&dead).unwrap();
        std::fs::write(owner_of(&dead), b"").unwrap();
        std::fs::write(dead.join("engine.vdb"), b"half").unwrap();
        // Killed as it removed its folder (the owner goes last), or before its folder was made.
        let orphan = out.join(".occlux-staging-orphan");
        std::fs::create_dir(&orphan).unwrap();
        let lone_owner = owner_of(&out.join(".occlux-staging-early"));
        std::fs::write(&lone_owner, b"").unwrap();
        // Owned by a live set (this process's: a second open file cannot take its lock).
        let live = OutputSet::new(out).unwrap();
        let mut set = OutputSet::new(out).unwrap();
        assert!(!dead.exists() && !owner_of(&dead).exists());
        assert!(!orphan.exists() && !lone_owner.exists());
        assert!(live.staging.is_dir() && owner_of(&live.staging).is_file());
        write_bytes_atomic(&set.marker("a.json").unwrap(), b"marker").unwrap();
        write_bytes_atomic(&set.path("a.vdb").unwrap(), b"grid").unwrap();
        let written = set.commit().unwrap();
        assert_eq!(written, [out.join("a.vdb"), out.join("a.json")]);
        assert_eq!(std::fs::read(out.join("a.json")).unwrap(), b"marker");
        // (remove_live_staging, what a signal runs, would also take the staging of the other
        // tests of this process: the command line's interrupt test checks it.)
        drop(live);
        let mut left: Vec<_> = std::fs::read_dir(out)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        left.sort();
        assert_eq!(left, ["a.json", "a.vdb"]);
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
