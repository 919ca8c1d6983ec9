//! The simulator's error: what stopped a `tactile` command, and the exit code it means.

use std::path::PathBuf;

use crate::record::RecordError;
use crate::scenario::ScenarioError;

/// Why a command stopped. [`Error::exit_code`]: 2 for bad usage, 1 for a run that failed.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The command line asked for something that cannot be (exit 2).
    #[error("{0}")]
    Usage(String),
    /// A record that cannot be used, with its file, line and column.
    #[error(transparent)]
    Record(#[from] RecordError),
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// A file that could not be written or read.
    #[error("{}: {source}", .path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// JSON that could not be encoded or decoded.
    #[error("{}: {source}", .path.display())]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    /// A calibration table that cannot be written or read.
    #[error("{}: {source}", .path.display())]
    Table {
        path: PathBuf,
        #[source]
        source: tactile_core::calibration::TableError,
    },
    /// An applicator file that cannot be read (TOML's message names the line and column) or
    /// describes no rig.
    #[error("{}: {reason}", .path.display())]
    Applicator { path: PathBuf, reason: String },
    /// A controller table that cannot be read or is refused, with the reason.
    #[error("{}: {source}", .path.display())]
    Controller {
        path: PathBuf,
        #[source]
        source: tactile_core::designed::DesignedError,
    },
    /// A calibration record that cannot be fitted.
    #[error(transparent)]
    Calibration(#[from] crate::dynamic_calibration::CalibrationError),
    /// A run that could not finish, with the reason.
    #[error("{0}")]
    Failed(String),
}

impl Error {
    /// The process exit code: 2 for bad usage, 1 otherwise.
    pub fn exit_code(&self) -> u8 {
        match self {
            Error::Usage(_) => 2,
            _ => 1,
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> Error {
        let path = path.into();
        move |source| Error::Io { path, source }
    }

    /// A JSON error on `path`.
    pub fn json(path: impl Into<PathBuf>) -> impl FnOnce(serde_json::Error) -> Error {
        let path = path.into();
        move |source| Error::Json { path, source }
    }
}

/// Reads an applicator file (TOML, every field of [`crate::applicator::ApplicatorParams`]).
pub fn read_applicator(
    path: &std::path::Path,
) -> Result<crate::applicator::ApplicatorParams, Error> {
    let fail = |reason: String| Error::Applicator {
        path: path.to_path_buf(),
        reason,
    };
    let text = std::fs::read_to_string(path).map_err(Error::io(path))?;
    let params: crate::applicator::ApplicatorParams =
        toml::from_str(&text).map_err(|e| fail(e.to_string().trim_end().to_string()))?;
    params.validate().map_err(|e| fail(e.to_string()))?;
    Ok(params)
}

/// Reads a controller table (`tactile design --table`), checked as the firmware checks it at
/// start-up: a table it would refuse is refused here with the same reason.
pub fn read_controller(
    path: &std::path::Path,
) -> Result<tactile_core::designed::DesignedConfig, Error> {
    let bytes = std::fs::read(path).map_err(Error::io(path))?;
    tactile_core::designed::DesignedConfig::decode(&bytes).map_err(|source| Error::Controller {
        path: path.to_path_buf(),
        source,
    })
}
