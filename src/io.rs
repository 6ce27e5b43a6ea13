//! File input and output with the project's guarantees: sources are checked
//! for UTF-8 with the offending byte offset named, and every output is
//! written atomically (temp file in the same folder + rename), so a failed
//! run never leaves a half-written or clobbered file.

use std::io::{Read as _, Write as _};
use std::path::{Path, PathBuf};

use thiserror::Error;

/// The largest text input shadec reads — a program, a scene, a profile,
/// a combiner setup: 16 MiB. Eight times the largest program
/// the language server is measured on (BENCHMARKS.md); past it a file is
/// refused before more of it is read, so `check /dev/zero` ends at once.
pub const MAX_TEXT_BYTES: u64 = 16 << 20;

/// Why a file could not be read or written: every case names the path.
#[derive(Debug, Error)]
pub enum IoError {
    #[error("{}: cannot read: {source}", shown(path))]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{}: is a folder, not a file", shown(path))]
    IsFolder { path: PathBuf },
    #[error("{}: {what} is larger than shadec's limit of {limit} bytes for a text input (io::MAX_TEXT_BYTES); split it", shown(path))]
    TooLarge { path: PathBuf, what: String, limit: u64 },
    #[error(
        "{}: byte {offset} (line {line}) is not valid UTF-8; shadec sources must be UTF-8 text",
        shown(path)
    )]
    NotUtf8 { path: PathBuf, offset: usize, line: usize },
    #[error("{}: cannot write: {source}", shown(path))]
    Write { path: PathBuf, source: std::io::Error },
    #[error("{}: cannot write: the folder {} does not exist", shown(path), shown(folder))]
    NoFolder { path: PathBuf, folder: PathBuf },
}

/// A path as messages show it: control characters (a NUL, a newline, an
/// escape sequence) escaped, so that a name cannot garble the terminal or
/// forge a line of output.
pub fn shown(path: &Path) -> String {
    let text = path.display().to_string();
    if !text.chars().any(char::is_control) {
        return text;
    }
    text.chars()
        .map(|c| if c.is_control() { c.escape_default().to_string() } else { c.to_string() })
        .collect()
}

/// Reads a text file, rejecting non-UTF-8 input with the first bad byte's
/// offset, a folder, and anything over [`MAX_TEXT_BYTES`] — a regular
/// file by its size before reading, a FIFO or a device by reading at most
/// one byte past the limit.
pub fn read_text(path: &Path) -> Result<String, IoError> {
    read_text_bounded(path, MAX_TEXT_BYTES)
}

/// [`read_text`] with another limit.
pub fn read_text_bounded(path: &Path, limit: u64) -> Result<String, IoError> {
    let read_err = |source| IoError::Read { path: path.to_path_buf(), source };
    let meta = std::fs::metadata(path).map_err(read_err)?;
    if meta.is_dir() {
        return Err(IoError::IsFolder { path: path.to_path_buf() });
    }
    if meta.is_file() && meta.len() > limit {
        let what = format!("the file ({} bytes)", meta.len());
        return Err(IoError::TooLarge { path: path.to_path_buf(), what, limit });
    }
    let file = std::fs::File::open(path).map_err(read_err)?;
    let mut bytes = Vec::with_capacity(if meta.is_file() { meta.len() as usize } else { 1 << 16 });
    file.take(limit + 1).read_to_end(&mut bytes).map_err(read_err)?;
    if bytes.len() as u64 > limit {
        let what = "what it gives (it is not a regular file)".to_string();
        return Err(IoError::TooLarge { path: path.to_path_buf(), what, limit });
    }
    text_from_bytes(path, bytes)
}

/// The text of `bytes` read from `path`, or an error at the first byte that is not UTF-8.
pub fn text_from_bytes(path: &Path, bytes: Vec<u8>) -> Result<String, IoError> {
    String::from_utf8(bytes).map_err(|e| {
        let offset = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..offset].iter().filter(|&&b| b == b'\n').count();
        IoError::NotUtf8 { path: path.to_path_buf(), offset, line }
    })
}

/// The temporary file [`write_atomic`] writes before renaming it to
/// `path`: `.NAME.shadec-tmp` beside it, named after its destination so
/// that one left by a killed run says what it was, and the next write of
/// that output replaces it.
pub fn temporary_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "output".into());
    path.with_file_name(format!(".{name}.shadec-tmp"))
}

/// Writes `bytes` to `path` atomically: the temporary file
/// [`temporary_path`] names, synced, then renamed over `path`. On every
/// error the temporary file is removed; a kill between its creation and
/// the rename leaves it, and the next write of the same output removes it.
/// The file gets the permissions a plain create would (0666 less the
/// umask; a file it replaces keeps its own), not owner-only.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    let err = |source| IoError::Write { path: path.to_path_buf(), source };
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !folder.is_dir() {
        return Err(IoError::NoFolder { path: path.to_path_buf(), folder: folder.to_path_buf() });
    }
    if path.is_dir() {
        return Err(err(std::io::Error::other("it is a folder")));
    }
    let tmp = temporary_path(path);
    // A stale temporary file of this output (a killed run's) goes first.
    match std::fs::remove_file(&tmp) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(err(e)),
    }
    let mut file = std::fs::OpenOptions::new().write(true).create_new(true).open(&tmp).map_err(err)?;
    let guard = RemoveOnDrop(&tmp);
    if let Some(p) = output_permissions(path) {
        file.set_permissions(p).map_err(err)?;
    }
    file.write_all(bytes).map_err(err)?;
    file.sync_all().map_err(err)?;
    drop(file);
    std::fs::rename(&tmp, path).map_err(err)?;
    std::mem::forget(guard);
    Ok(())
}

/// Removes the temporary file on every way out of [`write_atomic`] but
/// success.
struct RemoveOnDrop<'a>(&'a Path);

impl Drop for RemoveOnDrop<'_> {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(self.0);
    }
}

/// The replaced file's own permissions; a new file keeps what
/// `OpenOptions` gave it, as `File::create` does (0666 less the umask).
fn output_permissions(path: &Path) -> Option<std::fs::Permissions> {
    std::fs::metadata(path).ok().filter(|m| m.is_file()).map(|m| m.permissions())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An output file is readable by others as one `File::create` makes
    /// (the umask decides), not owner-only like a temporary file.
    #[cfg(unix)]
    #[test]
    fn atomic_write_keeps_the_permissions_a_create_gives() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let (plain, atomic) = (dir.path().join("plain.txt"), dir.path().join("atomic.txt"));
        std::fs::write(&plain, b"x").unwrap();
        write_atomic(&atomic, b"x").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&atomic), mode(&plain));
        // A file it replaces keeps its own mode.
        std::fs::set_permissions(&atomic, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_atomic(&atomic, b"y").unwrap();
        assert_eq!(mode(&atomic), 0o640);
    }

    #[test]
    fn non_utf8_names_the_byte_offset() {
        let err = text_from_bytes(Path::new("x.shd"), b"ab\ncd\xffef".to_vec()).unwrap_err();
        assert_eq!(
            err.to_string(),
            "x.shd: byte 5 (line 2) is not valid UTF-8; shadec sources must be UTF-8 text"
        );
    }

    #[test]
    fn atomic_write_replaces_whole_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        write_atomic(&path, b"first").unwrap();
        write_atomic(&path, b"second").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temp file left behind");
    }

    #[test]
    fn atomic_write_into_missing_folder_fails_cleanly() {
        let err = write_atomic(Path::new("/nonexistent-shadec-dir/out.png"), b"x").unwrap_err();
        // The real path and the missing folder, no temporary name.
        assert_eq!(
            err.to_string(),
            "/nonexistent-shadec-dir/out.png: cannot write: the folder /nonexistent-shadec-dir does not exist"
        );
    }

    /// A temporary file a killed run left is named after its output and
    /// removed by the next write; a failed write leaves none.
    #[test]
    fn stale_temporary_files_are_replaced_and_failures_leave_none() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.png");
        let stale = temporary_path(&path);
        assert_eq!(stale.file_name().unwrap(), ".out.png.shadec-tmp");
        std::fs::write(&stale, b"half a picture").unwrap();
        write_atomic(&path, b"whole").unwrap();
        assert!(!stale.exists());
        assert_eq!(std::fs::read(&path).unwrap(), b"whole");
        // A folder where the output should be: an error, no temporary file.
        let folder = dir.path().join("sub");
        std::fs::create_dir(&folder).unwrap();
        assert!(write_atomic(&folder, b"x").is_err());
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 2, "{names:?}");
    }

    #[test]
    fn folders_large_files_and_endless_devices_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let err = read_text(dir.path()).unwrap_err();
        assert!(err.to_string().ends_with(": is a folder, not a file"), "{err}");
        let big = dir.path().join("big.shd");
        std::fs::write(&big, vec![b' '; 101]).unwrap();
        let err = read_text_bounded(&big, 100).unwrap_err();
        assert!(
            err.to_string().contains("the file (101 bytes) is larger than shadec's limit of 100 bytes"),
            "{err}"
        );
        assert_eq!(read_text_bounded(&big, 101).unwrap().len(), 101);
        #[cfg(unix)]
        {
            let err = read_text_bounded(Path::new("/dev/zero"), 1000).unwrap_err();
            assert!(err.to_string().contains("it is not a regular file"), "{err}");
        }
    }

    #[test]
    fn control_characters_in_paths_are_escaped() {
        let err = read_text(Path::new("/nonexistent/a\u{0}b\nc.shd")).unwrap_err();
        assert!(err.to_string().starts_with(r"/nonexistent/a\u{0}b\nc.shd: cannot read"), "{err}");
    }
}
