//! A file written in pieces beside its destination and moved there only when complete, so a run
//! that fails or stops leaves no half file and never touches an existing one it was not asked
//! to replace.

use crate::IoError;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// What to do when the output file exists.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Existing {
    /// Refuse with [`IoError::Exists`], when the writer is created and again when it finishes.
    #[default]
    Keep,
    /// Replace it when the new file is complete.
    Replace,
}

/// The file being written: `.NAME.partial-PID` beside `NAME`, removed if dropped unfinished.
pub(crate) struct PartialFile {
    pub name: String,
    path: PathBuf,
    partial: PathBuf,
    out: Option<BufWriter<File>>,
    existing: Existing,
    /// Set after an I/O error: the file's content is unknown, so nothing more is written.
    broken: bool,
}

impl PartialFile {
    pub fn create(path: &Path, existing: Existing) -> Result<Self, IoError> {
        let name = path.display().to_string();
        let io = |e: std::io::Error| IoError::Io {
            file: name.clone(),
            message: e.to_string(),
        };
        if existing == Existing::Keep && path.exists() {
            return Err(IoError::Exists { file: name });
        }
        let Some(file_name) = path.file_name() else {
            return Err(IoError::Io {
                file: name,
                message: "not a file name".into(),
            });
        };
        let mut partial = std::ffi::OsString::from(".");
        partial.push(file_name);
        // The process and a counter: two writers of one name in one process do not collide.
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        partial.push(format!(".partial-{}-{n}", std::process::id()));
        let partial = path.with_file_name(partial);
        let file = File::create(&partial).map_err(io)?;
        Ok(Self {
            name,
            path: path.to_path_buf(),
            partial,
            out: Some(BufWriter::with_capacity(1 << 20, file)),
            existing,
            broken: false,
        })
    }

    fn io(&mut self, e: std::io::Error) -> IoError {
        self.broken = true;
        IoError::Io {
            file: self.name.clone(),
            message: e.to_string(),
        }
    }

    fn writer(&mut self) -> Result<&mut BufWriter<File>, IoError> {
        match (&mut self.out, self.broken) {
            (Some(out), false) => Ok(out),
            _ => Err(IoError::Io {
                file: self.name.clone(),
                message: "an earlier write failed; the file is abandoned".into(),
            }),
        }
    }

    pub fn write(&mut self, bytes: &[u8]) -> Result<(), IoError> {
        let result = self.writer()?.write_all(bytes);
        result.map_err(|e| self.io(e))
    }

    /// Overwrites bytes already written at `offset` (same length), then returns to the end.
    pub fn patch(&mut self, offset: u64, bytes: &[u8]) -> Result<(), IoError> {
        let out = self.writer()?;
        let result = out
            .flush()
            .and_then(|()| out.seek(SeekFrom::Start(offset)))
            .and_then(|_| out.write_all(bytes))
            .and_then(|()| out.seek(SeekFrom::End(0)).map(drop));
        result.map_err(|e| self.io(e))
    }

    /// Flushes and moves the file into place (or refuses, if one appeared there meanwhile and
    /// it is to be kept).
    pub fn commit(mut self) -> Result<(), IoError> {
        let out = self.writer()?;
        let flushed = out.flush().and_then(|()| out.get_ref().sync_all());
        flushed.map_err(|e| self.io(e))?;
        self.out = None;
        let placed = match self.existing {
            Existing::Replace => std::fs::rename(&self.partial, &self.path),
            // A hard link fails if the name is taken: no window in which a file created by
            // someone else meanwhile could be replaced.
            // A file system without hard links falls back to a check and a rename.
            Existing::Keep => match std::fs::hard_link(&self.partial, &self.path) {
                Ok(()) => std::fs::remove_file(&self.partial),
                Err(_) if self.path.exists() => {
                    return Err(IoError::Exists {
                        file: self.name.clone(),
                    });
                }
                Err(_) => std::fs::rename(&self.partial, &self.path),
            },
        };
        placed.map_err(|e| self.io(e))
    }
}

impl Drop for PartialFile {
    fn drop(&mut self) {
        self.out = None;
        // Gone already after a commit, so the error is expected then.
        let _ = std::fs::remove_file(&self.partial);
    }
}
