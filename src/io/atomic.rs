//! Output files that never exist half-written under their final name: bytes go to a
//! temporary file in the same directory, which is renamed over the final name only when the
//! whole output has been written and flushed. A failed or killed run leaves at most a
//! temporary file (removed on drop when the process survives).
//!
//! A path that already exists and is not a regular file (`/dev/null`, a FIFO, a terminal) is
//! written in place: renaming a file over a device node would replace the device.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::{Error, Result};

pub struct AtomicFile {
    path: PathBuf,
    writer: BufWriter<Sink>,
}

enum Sink {
    Temporary(tempfile::NamedTempFile),
    /// An existing special file (device, FIFO): no temporary, no rename.
    InPlace(std::fs::File),
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Sink::Temporary(f) => f.write(buf),
            Sink::InPlace(f) => f.write(buf),
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Sink::Temporary(f) => f.flush(),
            Sink::InPlace(f) => f.flush(),
        }
    }
}

impl std::io::Seek for Sink {
    fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
        match self {
            Sink::Temporary(f) => f.seek(pos),
            Sink::InPlace(f) => f.seek(pos),
        }
    }
}

impl AtomicFile {
    pub fn create(path: &Path) -> Result<Self> {
        let fail = |e: std::io::Error| Error::Output {
            path: path.to_path_buf(),
            source: e,
        };
        if std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
            let f = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(fail)?;
            return Ok(AtomicFile {
                path: path.to_path_buf(),
                writer: BufWriter::with_capacity(1 << 16, Sink::InPlace(f)),
            });
        }
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tmp = tempfile::Builder::new()
            .prefix(&format!(".{name}."))
            .suffix(".tmp")
            .tempfile_in(dir)
            .map_err(fail)?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            writer: BufWriter::with_capacity(1 << 16, Sink::Temporary(tmp)),
        })
    }

    /// Flush, sync and rename onto the final name.
    pub fn commit(self) -> Result<()> {
        let path = self.path;
        let fail = |e: std::io::Error| Error::Output {
            path: path.clone(),
            source: e,
        };
        match self.writer.into_inner().map_err(|e| fail(e.into_error()))? {
            Sink::Temporary(tmp) => {
                // Temporary files are created private (0600); outputs are ordinary files.
                #[cfg(unix)]
                {
                    use std::os::unix::fs::PermissionsExt;
                    let mode = std::fs::Permissions::from_mode(0o644);
                    tmp.as_file().set_permissions(mode).map_err(fail)?;
                }
                tmp.as_file().sync_all().map_err(fail)?;
                tmp.persist(&path).map_err(|e| fail(e.error))?;
            }
            Sink::InPlace(mut f) => f.flush().map_err(fail)?,
        }
        Ok(())
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.writer.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.writer.flush()
    }
}

/// Where a stream goes: stdout ("-"), or a file written atomically.
pub enum Output {
    Stdout(std::io::BufWriter<std::io::Stdout>),
    File(AtomicFile),
}

impl Output {
    pub fn open(path: &Path) -> Result<Self> {
        if path.as_os_str() == "-" {
            Ok(Output::Stdout(std::io::BufWriter::with_capacity(
                1 << 16,
                std::io::stdout(),
            )))
        } else {
            Ok(Output::File(AtomicFile::create(path)?))
        }
    }

    /// Flush stdout, or commit the file under its final name.
    pub fn commit(self) -> Result<()> {
        match self {
            Output::Stdout(mut w) => w.flush().map_err(|e| Error::io("stdout", e)),
            Output::File(f) => f.commit(),
        }
    }
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Output::Stdout(w) => w.write(buf),
            Output::File(f) => f.write(buf),
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Output::Stdout(w) => w.flush(),
            Output::File(f) => f.flush(),
        }
    }
}

impl std::io::Seek for AtomicFile {
    fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
        self.writer.seek(pos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nothing_under_the_final_name_until_commit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        let mut f = AtomicFile::create(&path).unwrap();
        f.write_all(b"hello").unwrap();
        assert!(!path.exists());
        f.commit().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"hello");

        let mut g = AtomicFile::create(&path).unwrap();
        g.write_all(b"half").unwrap();
        drop(g); // a failed run: the old file stays, no temporary is left behind
        assert_eq!(std::fs::read(&path).unwrap(), b"hello");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_device_is_written_in_place_not_replaced() {
        let null = Path::new("/dev/null");
        if !null.exists() {
            return;
        }
        let mut f = AtomicFile::create(null).unwrap();
        f.write_all(b"discarded").unwrap();
        f.commit().unwrap();
        let meta = std::fs::metadata(null).unwrap();
        assert!(!meta.is_file(), "/dev/null must still be a device");
    }
}
