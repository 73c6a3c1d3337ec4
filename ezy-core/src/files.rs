//! Reading the files a user names (model files, scene files, overlays,
//! saved tables) with a bound: only regular files are read (a FIFO, a device such as
//! `/dev/zero`, a directory or a socket is refused before a byte is read,
//! and opening never blocks), and at most one byte past a cap, so an
//! endless or huge file costs neither time nor memory. Errors say what
//! the file was and which path is at fault, in words (a link loop is
//! named as such, not as the system's "Too many levels of symbolic links").

use std::path::{Path, PathBuf};

/// Bytes `cap` as a person would write it: `1 MiB`, `32 MiB`, `512 KiB`.
pub fn fmt_bytes(cap: u64) -> String {
    if cap >= 1 << 20 && cap.is_multiple_of(1 << 20) {
        format!("{} MiB", cap >> 20)
    } else if cap >= 1 << 10 && cap.is_multiple_of(1 << 10) {
        format!("{} KiB", cap >> 10)
    } else {
        format!("{cap} bytes")
    }
}

/// What a file that is not a regular one is: "a FIFO (named pipe)", "a
/// character device", "a directory", ...
pub fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    if t.is_symlink() {
        return "a symbolic link";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_file() { "a regular file" } else { "not a regular file" }
}

/// The first path among `path` and its ancestors (shortest first) that
/// is a symbolic link whose links never end (`ELOOP` when followed), if
/// any.
fn loop_in(path: &Path) -> Option<PathBuf> {
    let mut ancestors: Vec<&Path> = path.ancestors().filter(|p| !p.as_os_str().is_empty()).collect();
    ancestors.reverse();
    ancestors.into_iter().find(|p| std::fs::metadata(p).is_err_and(|e| is_loop(&e))).map(Path::to_path_buf)
}

/// Whether `e` is the system's "Too many levels of symbolic links".
pub fn is_loop(e: &std::io::Error) -> bool {
    #[cfg(unix)]
    {
        e.raw_os_error() == Some(libc::ELOOP)
    }
    #[cfg(not(unix))]
    {
        let _ = e;
        false
    }
}

/// `e`, an error of `doing` ("cannot read the scene file") on `path`, in
/// words: a symbolic-link loop names the link at fault (`path` or the
/// directory on its way that loops), a link refused because ezy opened
/// `path` without following links says so; any other error is the
/// system's message.
pub fn io_message(path: &Path, e: &std::io::Error, doing: &str) -> String {
    // a link loop where a directory is to be created shows as "exists"
    let looped = is_loop(e)
        || (matches!(e.kind(), std::io::ErrorKind::AlreadyExists | std::io::ErrorKind::NotADirectory)
            && loop_in(path).is_some());
    if looped {
        return match loop_in(path) {
            Some(p) if p == path => format!(
                "{doing}: {} is a symbolic link that leads back to itself (a loop of links); point it at a real file or directory",
                path.display()
            ),
            Some(p) => format!(
                "{doing}: {} is a symbolic link that leads back to itself (a loop of links), so {} cannot be reached; point it at a real directory",
                p.display(),
                path.display()
            ),
            // a link opened without following it (`O_NOFOLLOW`)
            None if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) => format!(
                "{doing}: {} is a symbolic link, and ezy does not follow links to the files it keeps; put a regular file there or choose another directory",
                path.display()
            ),
            None => format!("{doing}: {} passes through a loop of symbolic links", path.display()),
        };
    }
    format!("{doing}: {e}")
}

/// Reads the regular file `path`, at most `cap` bytes; `what` names it in
/// errors ("the scene file", "the overlay file").
///
/// # Errors
/// A message (without the path, which the caller puts in front) if
/// `path` is not a regular file (a FIFO, a device, a directory: refused
/// before it is read, and opened without blocking), is larger than `cap`
/// bytes (at most `cap + 1` bytes are read), or cannot be read (a loop
/// of symbolic links is named, see [`io_message`]).
pub fn read_capped(path: &Path, cap: u64, what: &str) -> Result<Vec<u8>, String> {
    use std::io::Read;
    let doing = format!("cannot read {what}");
    let meta = std::fs::metadata(path).map_err(|e| io_message(path, &e, &doing))?;
    let not_regular =
        |m: &std::fs::Metadata| format!("{what} must be a regular file, and this is {}: nothing was read", kind_of(m));
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    // a FIFO put in the file's place since the check above opens at once
    // instead of waiting for a writer (and is refused below)
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(|e| io_message(path, &e, &doing))?;
    let meta = file.metadata().map_err(|e| io_message(path, &e, &doing))?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    let too_large = || format!("{what} is larger than {}, the most {what} may be", fmt_bytes(cap));
    if meta.len() > cap {
        return Err(too_large());
    }
    let mut bytes = Vec::with_capacity(usize::try_from(meta.len()).unwrap_or(0));
    file.take(cap.saturating_add(1)).read_to_end(&mut bytes).map_err(|e| io_message(path, &e, &doing))?;
    if bytes.len() as u64 > cap {
        return Err(too_large());
    }
    Ok(bytes)
}

/// [`read_capped`] as UTF-8 text.
///
/// # Errors
/// As [`read_capped`], or the byte offset of the first byte that is not
/// UTF-8.
pub fn read_capped_text(path: &Path, cap: u64, what: &str) -> Result<String, String> {
    String::from_utf8(read_capped(path, cap, what)?)
        .map_err(|e| format!("{what} is not UTF-8 text (byte {} is not valid UTF-8)", e.utf8_error().valid_up_to() + 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caps_devices_fifos_and_loops() {
        let dir = std::env::temp_dir().join(format!("ezy-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("a.txt");
        std::fs::write(&f, "0123456789").unwrap();
        assert_eq!(read_capped(&f, 10, "the file").unwrap(), b"0123456789");
        let e = read_capped(&f, 9, "the file").unwrap_err();
        assert!(e.contains("larger than 9 bytes"), "{e}");
        assert_eq!(fmt_bytes(1 << 20), "1 MiB");
        assert_eq!(fmt_bytes(32 << 20), "32 MiB");
        #[cfg(unix)]
        {
            let e = read_capped(Path::new("/dev/zero"), 1 << 20, "the file").unwrap_err();
            assert!(e.contains("character device"), "{e}");
            let fifo = dir.join("fifo");
            let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
            // SAFETY: a valid C string; mkfifo only creates the node
            assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
            let e = read_capped(&fifo, 1 << 20, "the file").unwrap_err();
            assert!(e.contains("FIFO"), "{e}");
            let link = dir.join("loop");
            std::os::unix::fs::symlink(&link, &link).unwrap();
            let e = read_capped(&link, 1 << 20, "the file").unwrap_err();
            assert!(e.contains("loop.") || e.contains("loop is") || e.contains("a loop of links"), "{e}");
            assert!(!e.contains("Too many levels"), "{e}");
            let e = read_capped(&link.join("x.toml"), 1 << 20, "the file").unwrap_err();
            assert!(e.contains(&format!("{} is a symbolic link that leads back", link.display())), "{e}");
        }
        let e = read_capped(&dir, 1 << 20, "the file").unwrap_err();
        assert!(e.contains("a directory"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
