//! The files a command writes, claimed before it works: a path that cannot be written is said
//! at once, not after minutes of fitting. A run that stops before writing leaves the path as it
//! found it: no empty file where there was none, and a file that was there (an earlier
//! record's table, say) untouched.
//!
//! ```
//! # let dir = std::env::temp_dir().join(format!("output-doc-{}", std::process::id()));
//! use sim_host::output::Output;
//! let path = dir.join("new/folder/model.json");
//! let out = Output::claim(&path, &[])?; // the folder made, the file opened
//! out.write_json(&[1.0, 2.0])?;
//! assert_eq!(std::fs::read_to_string(&path)?, "[\n  1.0,\n  2.0\n]");
//!
//! let again = Output::claim(&path, &[])?;
//! drop(again); // the run stopped before writing: the earlier file is as it was
//! assert_eq!(std::fs::read_to_string(&path)?, "[\n  1.0,\n  2.0\n]");
//! let other = dir.join("other.bin");
//! drop(Output::claim(&other, &[])?); // and where there was none, none is left
//! assert!(!other.exists());
//!
//! // A file the command reads is not one it may write.
//! std::fs::write(dir.join("record.csv"), "t_s,force_g,strain_pct\n")?;
//! assert!(Output::claim(&dir.join("record.csv"), &[&dir.join("./record.csv")]).is_err());
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::fs::File;
use std::path::{Path, PathBuf};

use crate::Error;

/// A file claimed for writing: its folder made, the file opened for writing (created if it was
/// not there). Dropped unwritten, a file it created is removed.
#[derive(Debug)]
pub struct Output {
    path: PathBuf,
    /// Removed on drop: created by the claim and not written since.
    created: bool,
}

impl Output {
    /// Claims `path`; `inputs` are the files the command reads, which it must not write over
    /// (a usage error, exit 2).
    pub fn claim(path: &Path, inputs: &[&Path]) -> Result<Self, Error> {
        if let Some(input) = inputs.iter().find(|i| same_file(path, i)) {
            return Err(Error::Usage(format!(
                "{}: that is {}, which this command reads; write elsewhere",
                path.display(),
                input.display()
            )));
        }
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(Error::io(dir))?;
        }
        // NOTE: opened to append, so that the check empties nothing: the run may still stop.
        let created = !path.exists();
        std::fs::OpenOptions::new()
            .append(true)
            .create(true)
            .open(path)
            .map_err(Error::io(path))?;
        Ok(Self {
            path: path.to_path_buf(),
            created,
        })
    }

    /// [`Output::claim`] of an optional path.
    pub fn claim_some(path: Option<&Path>, inputs: &[&Path]) -> Result<Option<Self>, Error> {
        path.map(|p| Self::claim(p, inputs)).transpose()
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether a file was at the path before the claim (it is left as it was unless written).
    pub fn existed(&self) -> bool {
        !self.created
    }

    /// The file opened again, to write in pieces.
    pub fn into_file(mut self) -> Result<File, Error> {
        self.created = false;
        File::create(&self.path).map_err(Error::io(&self.path))
    }

    /// Writes `bytes` as the file's whole content; returns its path, to say what was written.
    pub fn write(mut self, bytes: impl AsRef<[u8]>) -> Result<PathBuf, Error> {
        self.created = false;
        std::fs::write(&self.path, bytes).map_err(Error::io(&self.path))?;
        Ok(std::mem::take(&mut self.path))
    }

    /// Writes `value` as pretty JSON; returns its path.
    pub fn write_json(self, value: &impl serde::Serialize) -> Result<PathBuf, Error> {
        let text = serde_json::to_string_pretty(value).map_err(Error::json(&self.path))?;
        self.write(text)
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        if self.created {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Whether `a` and `b` name one existing file.
fn same_file(a: &Path, b: &Path) -> bool {
    matches!(
        (std::fs::canonicalize(a), std::fs::canonicalize(b)),
        (Ok(x), Ok(y)) if x == y
    )
}
