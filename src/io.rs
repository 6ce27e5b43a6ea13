//! File input and output with the project's guarantees: sources are checked
//! for UTF-8 with the offending byte offset named, and every output is
//! written atomically (temp file in the same folder + rename), so a failed
//! run never leaves a half-written or clobbered file.

use std::io::Write as _;
use std::path::Path;

use thiserror::Error;

#[derive(Debug, Error)]
pub enum IoError {
    #[error("{path}: cannot read: {source}")]
    Read { path: String, source: std::io::Error },
    #[error("{path}: byte {offset} (line {line}) is not valid UTF-8; shadec sources must be UTF-8 text")]
    NotUtf8 { path: String, offset: usize, line: usize },
    #[error("{path}: cannot write: {source}")]
    Write { path: String, source: std::io::Error },
}

/// Reads a text file, rejecting non-UTF-8 input with the first bad byte's offset.
pub fn read_text(path: &Path) -> Result<String, IoError> {
    let bytes =
        std::fs::read(path).map_err(|source| IoError::Read { path: path.display().to_string(), source })?;
    text_from_bytes(path, bytes)
}

pub fn text_from_bytes(path: &Path, bytes: Vec<u8>) -> Result<String, IoError> {
    String::from_utf8(bytes).map_err(|e| {
        let offset = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..offset].iter().filter(|&&b| b == b'\n').count();
        IoError::NotUtf8 { path: path.display().to_string(), offset, line }
    })
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, then
/// rename. The file gets the permissions a plain create would (0666 less
/// the umask; a file it replaces keeps its own), not the temporary file's
/// owner-only 0600.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    let err = |source| IoError::Write { path: path.display().to_string(), source };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    if let Some(p) = output_permissions(path) {
        builder.permissions(p);
    }
    let mut tmp = builder.tempfile_in(dir).map_err(err)?;
    tmp.write_all(bytes).map_err(err)?;
    tmp.as_file().sync_all().map_err(err)?;
    tmp.persist(path).map_err(|e| err(e.error))?;
    Ok(())
}

/// The replaced file's own permissions, else what `File::create` asks for:
/// read and write for everyone, which the kernel narrows by the umask.
#[cfg(unix)]
fn output_permissions(path: &Path) -> Option<std::fs::Permissions> {
    use std::os::unix::fs::PermissionsExt;
    Some(
        std::fs::metadata(path)
            .map(|m| m.permissions())
            .unwrap_or_else(|_| std::fs::Permissions::from_mode(0o666)),
    )
}

/// Elsewhere the temporary file's defaults are a plain file's.
#[cfg(not(unix))]
fn output_permissions(_: &Path) -> Option<std::fs::Permissions> {
    None
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
        assert!(err.to_string().starts_with("/nonexistent-shadec-dir/out.png: cannot write"));
    }
}
