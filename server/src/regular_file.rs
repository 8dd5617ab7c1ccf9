//! Opening a file found by name without blocking on what is not a regular file.
//!
//! A FIFO's open (or read) waits for a writer, and a server's rescan that does so stops for
//! good; opening a device can have effects of its own (a tape rewinds on close). So the
//! path is stat'ed first and only a regular file is opened, and, for a file swapped for
//! something else between the two, the open is non-blocking and without a controlling
//! terminal, and the open file's own stat has the last word. The file handed back is
//! blocking again: a dataset reads from it for as long as it is served, and not every
//! filesystem ignores `O_NONBLOCK` on a regular file.

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

/// Transparent over the I/O error: it is already this error's text, and an error chain
/// (`{:#}`) printed it twice ("No such file or directory (os error 2): No such file …").
impl OpenError {
    /// Whether the operating system refused the open (no such file, no permission, an I/O
    /// error), not the file's kind.
    pub fn is_io(&self) -> bool {
        matches!(self, Self::Io(_))
    }

    /// Whether a later try may well succeed: an I/O failure other than no such file or no
    /// permission (out of descriptors, an interrupted or failed read of the device).
    pub fn may_pass(&self) -> bool {
        use std::io::ErrorKind::{NotFound, PermissionDenied};
        matches!(self, Self::Io(e) if !matches!(e.kind(), NotFound | PermissionDenied))
    }
}

impl std::error::Error for OpenError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::NotRegular(_) => None,
            Self::Io(e) => e.source(),
        }
    }
}

/// `path` opened for reading (blocking), and its metadata as opened, when it is a regular
/// file (a link to one included).
pub fn open(path: &Path) -> Result<(File, Metadata), OpenError> {
    if let Some(what) = std::fs::metadata(path).ok().as_ref().and_then(kind) {
        return Err(OpenError::NotRegular(what));
    }
    open_as_found(path)
}

/// Refuses a command's input `path` when it is there and not a regular file, before a reader
/// opens it: a FIFO's open waits for a writer (`ingest` on one hung for good), and a folder or
/// device failed with a message about its contents. A missing file is left to the reader's
/// open, whose error names it.
pub fn check_input(path: &Path) -> anyhow::Result<()> {
    match std::fs::metadata(path).ok().as_ref().and_then(kind) {
        Some(what) => anyhow::bail!("{}: {}", path.display(), OpenError::NotRegular(what)),
        None => Ok(()),
    }
}

/// [`open`] without the stat before: what a file swapped since the stat meets.
fn open_as_found(path: &Path) -> Result<(File, Metadata), OpenError> {
    use rustix::fs::{fcntl_getfl, fcntl_setfl, OFlags};
    let not_regular = |meta: &Metadata| kind(meta).map(OpenError::NotRegular);
    let file = OpenOptions::new()
        .read(true)
        .custom_flags((OFlags::NONBLOCK | OFlags::NOCTTY).bits() as i32)
        .open(path)
        .map_err(|e| {
            // A socket cannot be opened (nor a device without a driver): say which it is.
            let swapped = (e.raw_os_error() == Some(rustix::io::Errno::NXIO.raw_os_error()))
                .then(|| std::fs::metadata(path).ok())
                .flatten()
                .as_ref()
                .and_then(not_regular);
            swapped.unwrap_or(OpenError::Io(e))
        })?;
    let meta = file.metadata().map_err(OpenError::Io)?;
    if let Some(e) = not_regular(&meta) {
        return Err(e);
    }
    let flags = fcntl_getfl(&file).map_err(|e| OpenError::Io(e.into()))?;
    fcntl_setfl(&file, flags - OFlags::NONBLOCK).map_err(|e| OpenError::Io(e.into()))?;
    Ok((file, meta))
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
        let flags = rustix::fs::fcntl_getfl(&opened).unwrap();
        assert!(!flags.contains(rustix::fs::OFlags::NONBLOCK), "{flags:?}");
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
        // What a file swapped after the stat meets: a FIFO opened without blocking and
        // refused by its own stat, a socket by the open's ENXIO.
        let f = fifo.clone();
        let got = crate::fixtures::within(10, "opening a FIFO as found blocked", move || {
            open_as_found(&f).map(|_| ()).map_err(|e| e.to_string())
        });
        assert_eq!(got, Err("not a regular file (a FIFO)".to_string()));
        let socket = d.join("s.obj");
        let _listening = std::os::unix::net::UnixListener::bind(&socket).unwrap();
        match open_as_found(&socket) {
            Err(OpenError::NotRegular(what)) => assert_eq!(what, "a socket"),
            other => panic!("{other:?}"),
        }
        // Out of descriptors may pass; no such file or no permission will not.
        let io = |k: std::io::ErrorKind| OpenError::Io(k.into());
        assert!(io(std::io::ErrorKind::Other).may_pass());
        assert!(!io(std::io::ErrorKind::NotFound).may_pass());
        assert!(!io(std::io::ErrorKind::PermissionDenied).may_pass());
        assert!(!OpenError::NotRegular("a FIFO").may_pass());
        match open(&d.join("absent")) {
            Err(e @ OpenError::Io(_)) => {
                // Said once through a chain of contexts.
                let said = format!("{:#}", anyhow::Error::new(e).context("opening absent"));
                assert_eq!(
                    said,
                    "opening absent: No such file or directory (os error 2)"
                );
            }
            other => panic!("{other:?}"),
        }
        let _ = std::fs::remove_dir_all(&d);
    }

    /// `ingest`, `eval terrain`, `eval mesh` and `subdivide` refuse a FIFO input at once, by
    /// name, as `info` and `export` do: each blocked for good in the reader's open.
    #[test]
    fn every_commands_input_refuses_a_fifo_at_once() {
        let d = crate::fixtures::scratch("input-fifo");
        let fifo = |name: &str| {
            let p = d.join(name);
            crate::fixtures::mkfifo(&p);
            p
        };
        let expect = |p: &Path| format!("{}: not a regular file (a FIFO)", p.display());
        let said = |e: anyhow::Error| format!("{e:#}");

        let hgt = fifo("in.hgt");
        let job = crate::ingest::Ingest {
            input: hgt.clone(),
            ..crate::ingest::Ingest::for_test("f", "geodetic", &d.join("data"))
        };
        let got = crate::fixtures::within(10, "ingest blocked on a FIFO", move || {
            crate::ingest::run(&job).map(|_| ()).map_err(said)
        });
        assert_eq!(got, Err(expect(&hgt)));

        let eval = crate::eval::terrain::TerrainEval {
            input: hgt.clone(),
            crop: None,
            encoding: None,
            npz_key: None,
            wavelet: None,
            step: None,
            sweep: crate::eval::terrain::Sweep::Lossless,
            repeat: 1,
            eight_bit: false,
            mesher: None,
            decode_share: None,
            out: None,
        };
        let got = crate::fixtures::within(10, "eval terrain blocked on a FIFO", move || {
            crate::eval::terrain::load(&eval).map(|_| ()).map_err(said)
        });
        assert_eq!(got, Err(expect(&hgt)));

        let obj = fifo("in.obj");
        let args = crate::cli::SubdivideArgs {
            input: obj.clone(),
            output: d.join("out.obj"),
            times: 1,
        };
        let got = crate::fixtures::within(10, "subdivide blocked on a FIFO", move || {
            crate::eval::mesh::subdivide(&args).map_err(said)
        });
        assert_eq!(got, Err(expect(&obj)));
        let _ = std::fs::remove_dir_all(&d);
    }
}
