//! Which files make a series, and in which order: a shell pattern (`data/step_*.nrrd`), a
//! folder, or a list. Names are sorted naturally (`step_2` before `step_10`), and a numbered
//! sequence with a gap is refused, naming what is missing: a figure or an animation with a
//! silently skipped time step would be wrong without anyone seeing it.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::cmp::Ordering;
use std::path::{Path, PathBuf};

/// Where a series' frames come from, as a user gives them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum FrameSpec {
    /// A shell pattern (`*`, `?`, `[...]`) or a folder, relative to a base folder.
    Pattern(String),
    /// The files themselves, in this order.
    List(Vec<PathBuf>),
}

/// Volume files a folder given as frames is read for (the loaders' extensions).
const VOLUME_EXTENSIONS: [&str; 7] = ["nrrd", "nhdr", "nii", "gz", "vdb", "npy", "raw"];

/// Missing names listed in an error before "and N more".
const LISTED: usize = 5;

impl FrameSpec {
    /// The frames' files: relative paths resolved against `base`; a pattern's or a folder's
    /// matches in natural order, a list as given. Errors name a pattern that matches nothing,
    /// a listed file that does not exist, and the gaps of a numbered sequence.
    pub fn resolve(&self, base: &Path) -> Result<Vec<PathBuf>> {
        let files = match self {
            FrameSpec::Pattern(pattern) => {
                let full = base.join(pattern);
                let mut files = if full.is_dir() {
                    folder_volumes(&full)?
                } else {
                    matches(&full)?
                };
                files.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
                if files.is_empty() {
                    return Err(Error::param(
                        "frames",
                        format!("no volume file matches '{}'", full.display()),
                    ));
                }
                files
            }
            FrameSpec::List(list) => {
                if list.is_empty() {
                    return Err(Error::param("frames", "the list of frames is empty"));
                }
                let files: Vec<PathBuf> = list.iter().map(|p| base.join(p)).collect();
                if let Some(missing) = files.iter().find(|p| !p.is_file()) {
                    return Err(Error::param(
                        "frames",
                        format!("{} does not exist", missing.display()),
                    ));
                }
                files
            }
        };
        check_numbering(&files)?;
        Ok(files)
    }
}

/// The files matching a shell pattern.
fn matches(pattern: &Path) -> Result<Vec<PathBuf>> {
    let text = pattern.to_string_lossy();
    let paths = glob::glob(&text)
        .map_err(|e| Error::param("frames", format!("'{text}' is not a valid pattern: {e}")))?;
    let mut files = Vec::new();
    for entry in paths {
        let path = entry.map_err(|e| Error::io(e.path(), std::io::Error::other(e.to_string())))?;
        if path.is_file() {
            files.push(path);
        }
    }
    Ok(files)
}

/// The volume files directly inside `folder`.
fn folder_volumes(folder: &Path) -> Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(folder).map_err(|e| Error::io(folder, e))?;
    let mut files = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| Error::io(folder, e))?.path();
        let known = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| VOLUME_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()));
        if known && path.is_file() {
            files.push(path);
        }
    }
    Ok(files)
}

/// Orders names as people number them: runs of digits by their value, the rest by character.
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut a, mut b) = (a, b);
    loop {
        match (a.chars().next(), b.chars().next()) {
            (None, None) => return Ordering::Equal,
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let (da, ra) = split_digits(a);
                let (db, rb) = split_digits(b);
                let (ta, tb) = (da.trim_start_matches('0'), db.trim_start_matches('0'));
                let by_value = ta.len().cmp(&tb.len()).then_with(|| ta.cmp(tb));
                // Equal values: the shorter run (fewer leading zeros) first, so the order is total.
                match by_value.then_with(|| da.len().cmp(&db.len())) {
                    Ordering::Equal => (a, b) = (ra, rb),
                    other => return other,
                }
            }
            (Some(x), Some(y)) => match x.cmp(&y) {
                Ordering::Equal => (a, b) = (&a[x.len_utf8()..], &b[y.len_utf8()..]),
                other => return other,
            },
        }
    }
}

/// The leading run of ASCII digits and the rest.
fn split_digits(s: &str) -> (&str, &str) {
    let end = s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len());
    s.split_at(end)
}

/// A file name as text around its last run of digits: `step_0012.nrrd` is `step_`, 12,
/// `.nrrd` (the last run, so a `.nii` after a number or a dataset's year before it do not
/// count). None when the name has no digits.
fn numbered(path: &Path) -> Option<Numbered> {
    let name = path.file_name()?.to_string_lossy().into_owned();
    let end = name.rfind(|c: char| c.is_ascii_digit())? + 1;
    let start = name[..end]
        .rfind(|c: char| !c.is_ascii_digit())
        .map_or(0, |i| i + 1);
    Some(Numbered {
        prefix: name[..start].to_owned(),
        number: name[start..end].parse().ok()?,
        width: end - start,
        suffix: name[end..].to_owned(),
    })
}

/// A file name split around its last number, `width` its digits (zero padding included).
struct Numbered {
    prefix: String,
    number: u64,
    width: usize,
    suffix: String,
}

/// A numbered sequence (every name the same but for its last number) must step evenly: the
/// step is the smallest difference, and every number between that is missing is named.
fn check_numbering(files: &[PathBuf]) -> Result<()> {
    let Some(first) = files.first().and_then(|f| numbered(f)) else {
        return Ok(());
    };
    let mut numbers = Vec::with_capacity(files.len());
    for file in files {
        match numbered(file) {
            Some(n) if n.prefix == first.prefix && n.suffix == first.suffix => {
                numbers.push((n.number, file))
            }
            // Not one numbered sequence: the natural order is all there is to check.
            _ => return Ok(()),
        }
    }
    numbers.sort_by_key(|(n, _)| *n);
    if let Some(pair) = numbers.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(Error::param(
            "frames",
            format!(
                "{} and {} carry the same number {}",
                pair[0].1.display(),
                pair[1].1.display(),
                pair[0].0
            ),
        ));
    }
    let Some(step) = numbers.windows(2).map(|w| w[1].0 - w[0].0).min() else {
        return Ok(());
    };
    let missing: Vec<u64> = numbers
        .windows(2)
        .flat_map(|w| (w[0].0 + step..w[1].0).step_by(step as usize))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    // Named as the files would be, with the first file's zero padding.
    let (prefix, width, suffix) = (&first.prefix, first.width, &first.suffix);
    let names: Vec<String> = missing
        .iter()
        .take(LISTED)
        .map(|n| format!("{prefix}{n:0width$}{suffix}"))
        .collect();
    let more = missing.len().saturating_sub(LISTED);
    Err(Error::param(
        "frames",
        format!(
            "the numbered sequence {}* ({} files, step {step}) misses {}{}",
            prefix,
            files.len(),
            names.join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_order_reads_numbers_by_value() {
        let mut names = vec!["s_10", "s_2", "s_1", "s_02", "a", "s_100"];
        names.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(names, ["a", "s_1", "s_2", "s_02", "s_10", "s_100"]);
    }

    #[test]
    fn gaps_in_a_numbered_sequence_are_named() {
        let dir = tempfile::tempdir().unwrap();
        for n in [1, 2, 3, 5, 6, 9] {
            std::fs::write(dir.path().join(format!("step_{n:03}.raw")), b"x").unwrap();
        }
        let spec = FrameSpec::Pattern("step_*.raw".into());
        let message = spec.resolve(dir.path()).unwrap_err().to_string();
        assert!(
            message.contains("misses step_004.raw, step_007.raw, step_008.raw"),
            "{message}"
        );
        std::fs::remove_file(dir.path().join("step_009.raw")).unwrap();
        std::fs::write(dir.path().join("step_004.raw"), b"x").unwrap();
        let files = spec.resolve(dir.path()).unwrap();
        let names: Vec<_> = files.iter().map(|f| f.file_name().unwrap()).collect();
        assert_eq!(
            names,
            [
                "step_001.raw",
                "step_002.raw",
                "step_003.raw",
                "step_004.raw",
                "step_005.raw",
                "step_006.raw"
            ]
        );
        // A step of ten is a sequence too: 10, 20, 40 misses 30.
        let tens = tempfile::tempdir().unwrap();
        for n in [10, 20, 40] {
            std::fs::write(tens.path().join(format!("t{n}.npy")), b"x").unwrap();
        }
        let message = FrameSpec::Pattern(".".into())
            .resolve(tens.path())
            .unwrap_err()
            .to_string();
        assert!(message.contains("step 10) misses t30.npy"), "{message}");
    }

    #[test]
    fn nothing_matched_and_missing_files_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let message = FrameSpec::Pattern("*.nrrd".into())
            .resolve(dir.path())
            .unwrap_err()
            .to_string();
        assert!(message.contains("no volume file matches"), "{message}");
        let message = FrameSpec::List(vec!["a.nrrd".into()])
            .resolve(dir.path())
            .unwrap_err()
            .to_string();
        assert!(message.contains("a.nrrd does not exist"), "{message}");
    }
}
