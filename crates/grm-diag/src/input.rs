//! Reading an input file with a bound: the one way grm reads a file a user
//! names (a grammar on the command line or in an `import`, a curves file).
//!
//! Only a regular file is read, and no more of it than the caller's limit.
//! Anything else is refused before a byte is read: a directory, a device
//! (`/dev/zero` never ends: `grmc fmt /dev/zero` read 6.5 GB), a named
//! pipe (opening one waits for a writer: `grmc check FIFO` blocked
//! forever) or a socket. The file is opened without waiting (`O_NONBLOCK`)
//! and what was opened is checked again, so a path swapped for a pipe
//! between the two looks is refused too, not waited on.

use std::io::{self, Read};
use std::path::Path;

/// The bytes of the regular file at `path`, refused when it is larger than
/// `max` bytes. `what` names the kind of file in that refusal: "it is
/// larger than 16 MiB, the most a grammar file may be".
///
/// Errors keep the system's kind where there is one (`NotFound`, ...);
/// the refusals are `IsADirectory` ("it is a directory"), `InvalidInput`
/// ("it is not a regular file") and `FileTooLarge`, each message a clause
/// to follow "cannot read PATH: ".
pub fn read_bounded(path: &Path, max: u64, what: &str) -> io::Result<Vec<u8>> {
    usable(&std::fs::metadata(path)?, max, what)?;
    let mut open = std::fs::OpenOptions::new();
    open.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // A regular file reads the same with it; a pipe is not waited on.
        open.custom_flags(libc::O_NONBLOCK);
    }
    let file = open.open(path)?;
    let meta = file.metadata()?;
    usable(&meta, max, what)?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    // A file that grows while it is read stops at the limit too.
    file.take(max.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(too_large(max, what));
    }
    Ok(bytes)
}

/// [`read_bounded`] for text: invalid UTF-8 is an `InvalidData` error.
pub fn read_bounded_string(path: &Path, max: u64, what: &str) -> io::Result<String> {
    String::from_utf8(read_bounded(path, max, what)?)
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidData, "it is not valid UTF-8 text"))
}

/// Refuse what is no regular file, or one larger than `max`.
fn usable(meta: &std::fs::Metadata, max: u64, what: &str) -> io::Result<()> {
    if meta.is_dir() {
        Err(io::Error::new(
            io::ErrorKind::IsADirectory,
            "it is a directory",
        ))
    } else if !meta.is_file() {
        Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "it is not a regular file",
        ))
    } else if meta.len() > max {
        Err(too_large(max, what))
    } else {
        Ok(())
    }
}

fn too_large(max: u64, what: &str) -> io::Error {
    let size = if max >= 1 << 20 && max.is_multiple_of(1 << 20) {
        format!("{} MiB", max >> 20)
    } else {
        format!("{max} bytes")
    };
    io::Error::new(
        io::ErrorKind::FileTooLarge,
        format!("it is larger than {size}, the most {what} may be"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("grm-diag-input-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("temp dir");
        d
    }

    #[test]
    fn regular_files_up_to_the_limit() {
        let d = temp("regular");
        let f = d.join("a.grm");
        std::fs::write(&f, b"0123456789").expect("write");
        assert_eq!(read_bounded(&f, 10, "a file").expect("read"), b"0123456789");
        let e = read_bounded(&f, 9, "a test file").expect_err("too large");
        assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
        assert_eq!(
            e.to_string(),
            "it is larger than 9 bytes, the most a test file may be"
        );
        let e = read_bounded(&d.join("none"), 10, "a file").expect_err("missing");
        assert_eq!(e.kind(), io::ErrorKind::NotFound);
        let e = read_bounded(&d, 10, "a file").expect_err("directory");
        assert_eq!(e.to_string(), "it is a directory");
        std::fs::write(&f, b"\xff").expect("write");
        assert_eq!(
            read_bounded_string(&f, 10, "a file")
                .expect_err("utf-8")
                .kind(),
            io::ErrorKind::InvalidData
        );
        let _ = std::fs::remove_dir_all(&d);
    }

    /// A device is refused unread: `/dev/zero` was read to the limit (or,
    /// unbounded, until memory ran out).
    #[cfg(unix)]
    #[test]
    fn devices_are_refused_unread() {
        for dev in ["/dev/zero", "/dev/null", "/dev/urandom"] {
            if Path::new(dev).exists() {
                let e = read_bounded(Path::new(dev), 16 << 20, "a file").expect_err(dev);
                assert_eq!(e.to_string(), "it is not a regular file", "{dev}");
            }
        }
    }

    /// A named pipe with no writer is refused at once: opening it to read
    /// blocked forever (`grmc check FIFO`).
    #[cfg(unix)]
    #[test]
    fn a_named_pipe_is_refused_without_waiting() {
        let d = temp("fifo");
        let fifo = d.join("pipe.grm");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            return; // no mkfifo here
        }
        let (tx, rx) = std::sync::mpsc::channel();
        let f = fifo.clone();
        std::thread::spawn(move || {
            let _ = tx.send(read_bounded(&f, 1 << 20, "a file").map_err(|e| e.to_string()));
        });
        let got = rx
            .recv_timeout(std::time::Duration::from_secs(20))
            .expect("reading a named pipe returns without a writer");
        assert_eq!(got, Err("it is not a regular file".to_string()));
        let _ = std::fs::remove_dir_all(&d);
    }
}
