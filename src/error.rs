//! One error type for the whole library: every message names the file, field or parameter at fault.

use std::path::PathBuf;

/// Everything that can go wrong in Occlux. Messages are written for the user: they name the
/// file, the field and the expected form.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or writing a file failed at the operating-system level.
    #[error("{}: {source}", located(path, source))]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file exists but its content is not what its format requires.
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    /// A parameter, scene key or argument is out of range or malformed. `key` names it.
    #[error("invalid `{key}`: {message}")]
    Param { key: String, message: String },
    /// Volume data that cannot be used (NaN, zero dims, too large, ...).
    #[error("invalid volume: {0}")]
    Volume(String),
    /// The GPU could not be opened or a GPU operation failed.
    #[error("GPU: {0}")]
    Gpu(String),

    /// The caller cancelled the work through its [`crate::progress::Progress`].
    #[error("cancelled")]
    Cancelled,
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The path as given and, when it is relative and the system found no file there, where it
/// was looked for (a scene's paths are relative to the scene file, the CLI's to the working
/// directory). Errors Occlux words itself (no OS error code) say what they mean already.
fn located(path: &std::path::Path, source: &std::io::Error) -> String {
    let not_found =
        source.kind() == std::io::ErrorKind::NotFound && source.raw_os_error().is_some();
    match std::path::absolute(path) {
        Ok(full) if not_found && path.is_relative() => {
            format!("{} (looked for at {})", path.display(), full.display())
        }
        _ => path.display().to_string(),
    }
}

impl Error {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    pub fn format(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::Format {
            path: path.into(),
            message: message.into(),
        }
    }

    pub fn param(key: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Param {
            key: key.into(),
            message: message.into(),
        }
    }
}
