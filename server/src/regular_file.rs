//! Opening a file found by name without blocking on what is not a regular file.
//!
//! A stat then an open leaves a window: a file swapped for a FIFO between the two blocks the
//! open (or the read) until something writes to the FIFO, and a server's rescan that does so
//! stops for good. Opening with `O_NONBLOCK` returns at once whatever the file is, and the
//! open file's own stat says what was opened; `O_NONBLOCK` changes nothing for a regular
//! file's reads.

use std::fs::{File, Metadata, OpenOptions};
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::Path;

/// Why [`open`] failed: not a regular file, or the open itself.
#[derive(Debug)]
pub enum OpenError {
    /// What the path names instead ("a folder", "a FIFO", …, see [`kind`]).
    NotRegular(&'static str),
    Io(std::io::Error),
}

impl std::fmt::Display for OpenError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NotRegular(what) => write!(f, "not a regular file ({what})"),
            Self::Io(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for OpenError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::NotRegular(_) => None,
            Self::Io(e) => Some(e),
        }
    }
}

/// `path` opened for reading, and its metadata as opened, when it is a regular file (a link
/// to one included).
pub fn open(path: &Path) -> Result<(File, Metadata), OpenError> {
    let file = OpenOptions::new()
        .read(true)
        .custom_flags(rustix::fs::OFlags::NONBLOCK.bits() as i32)
        .open(path)
        .map_err(|e| {
            // A socket cannot be opened at all.
            if e.raw_os_error() == Some(rustix::io::Errno::NXIO.raw_os_error()) {
                OpenError::NotRegular("a socket")
            } else {
                OpenError::Io(e)
            }
        })?;
    let meta = file.metadata().map_err(OpenError::Io)?;
    match kind(&meta) {
        None => Ok((file, meta)),
        Some(what) => Err(OpenError::NotRegular(what)),
    }
}

/// What a file that is not a regular file is, for messages; `None` for a regular file.
pub fn kind(meta: &Metadata) -> Option<&'static str> {
    let t = meta.file_type();
    if t.is_file() {
        None
    } else if t.is_dir() {
        Some("a folder")
    } else if t.is_fifo() {
        Some("a FIFO")
    } else if t.is_socket() {
        Some("a socket")
    } else if t.is_char_device() || t.is_block_device() {
        Some("a device")
    } else if t.is_symlink() {
        // Only a stat that does not follow links sees one: a link to nothing.
        Some("a link to nothing")
    } else {
        Some("not a file")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fifo_is_refused_at_once_and_a_file_is_read() {
        let d = crate::fixtures::scratch("regular-file");
        let fifo = d.join("x.obj");
        crate::fixtures::mkfifo(&fifo);
        // No writer ever opens it: a blocking open would never return.
        let f = fifo.clone();
        let got = crate::fixtures::within(10, "opening a FIFO blocked", move || {
            open(&f).map(|_| ()).map_err(|e| e.to_string())
        });
        assert_eq!(got, Err("not a regular file (a FIFO)".to_string()));

        let file = d.join("y.obj");
        std::fs::write(&file, b"v 0 0 0\n").unwrap();
        let (mut opened, meta) = open(&file).unwrap();
        assert_eq!(meta.len(), 8);
        let mut text = String::new();
        std::io::Read::read_to_string(&mut opened, &mut text).unwrap();
        assert_eq!(text, "v 0 0 0\n");

        match open(&d) {
            Err(OpenError::NotRegular(what)) => assert_eq!(what, "a folder"),
            other => panic!("{other:?}"),
        }
        match open(Path::new("/dev/null")) {
            Err(OpenError::NotRegular(what)) => assert_eq!(what, "a device"),
            other => panic!("{other:?}"),
        }
        match open(&d.join("absent")) {
            Err(OpenError::Io(e)) => assert_eq!(e.kind(), std::io::ErrorKind::NotFound),
            other => panic!("{other:?}"),
        }
        let _ = std::fs::remove_dir_all(&d);
    }
}
