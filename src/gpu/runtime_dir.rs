//! A private runtime directory for the drivers wgpu loads.
//!
//! Mesa's Vulkan and GL drivers (lavapipe, llvmpipe) try the Wayland and X11
//! display paths when they start, and libwayland prints
//! `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` on
//! standard error when the variable is missing or does not name a usable
//! directory — as in containers, CI runners and `ssh` sessions. shadec never
//! draws to a display, but the line reads as if it were shadec's own error.
//! [`ensure`] gives the process a directory of its own before any instance
//! is made, so the drivers find a valid one and stay quiet.

use std::path::{Path, PathBuf};
use std::sync::Once;

static ONCE: Once = Once::new();

/// Makes `XDG_RUNTIME_DIR` name a directory this user owns with mode 0700,
/// creating `shadec-runtime-UID` in the temporary directory when the
/// variable is unset or invalid. Runs once per process; later calls do
/// nothing. Best effort: if no directory can be made, the variable is left
/// as it was (the only cost is the driver's warning).
///
/// Call it before threads that read the environment start (the CLI calls
/// it first thing in `render` and `bench`); [`crate::gpu::runner::Gpu::new`]
/// calls it too, for library users.
pub fn ensure() {
    ONCE.call_once(|| {
        #[cfg(unix)]
        if let Some(dir) = replacement(std::env::var_os("XDG_RUNTIME_DIR").as_deref().map(Path::new)) {
            // Set before any wgpu instance exists; `Once` makes it happen a
            // single time.
            std::env::set_var("XDG_RUNTIME_DIR", dir);
        }
    });
}

/// The directory to use instead of `current`, or `None` when `current` is
/// already valid (or nothing better can be made).
#[cfg(unix)]
pub fn replacement(current: Option<&Path>) -> Option<PathBuf> {
    let uid = current_uid()?;
    if current.is_some_and(|p| valid(p, uid)) {
        return None;
    }
    let dir = std::env::temp_dir().join(format!("shadec-runtime-{uid}"));
    if !valid(&dir, uid) {
        use std::os::unix::fs::{DirBuilderExt as _, PermissionsExt as _};
        match std::fs::DirBuilder::new().mode(0o700).create(&dir) {
            Ok(()) => {}
            // Ours already, with the wrong mode: tighten it.
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && owned_dir(&dir, uid) => {
                std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700)).ok()?;
            }
            Err(_) => return None,
        }
    }
    valid(&dir, uid).then_some(dir)
}

/// An absolute path to a real directory (not a link) owned by `uid`, mode 0700.
#[cfg(unix)]
fn valid(path: &Path, uid: u32) -> bool {
    use std::os::unix::fs::{MetadataExt as _, PermissionsExt as _};
    path.is_absolute()
        && owned_dir(path, uid)
        && std::fs::symlink_metadata(path)
            .is_ok_and(|m| m.permissions().mode() & 0o777 == 0o700 && m.uid() == uid)
}

#[cfg(unix)]
fn owned_dir(path: &Path, uid: u32) -> bool {
    use std::os::unix::fs::MetadataExt as _;
    std::fs::symlink_metadata(path).is_ok_and(|m| m.is_dir() && m.uid() == uid)
}

/// This process's user id, from a file it has just created (no libc call).
#[cfg(unix)]
fn current_uid() -> Option<u32> {
    use std::os::unix::fs::MetadataExt as _;
    let probe = tempfile::NamedTempFile::new().ok()?;
    probe.as_file().metadata().ok().map(|m| m.uid())
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt as _;

    #[test]
    fn an_invalid_or_missing_dir_is_replaced_by_a_private_one() {
        for current in [None, Some(Path::new("/nonexistent/run")), Some(Path::new("relative/dir"))] {
            let dir = replacement(current).expect("a private runtime dir can be made");
            let meta = std::fs::symlink_metadata(&dir).unwrap();
            assert!(meta.is_dir() && dir.is_absolute(), "{}", dir.display());
            assert_eq!(meta.permissions().mode() & 0o777, 0o700, "{}", dir.display());
            // The replacement is itself valid: asking again keeps it.
            assert_eq!(replacement(Some(&dir)), None);
        }
    }

    #[test]
    fn a_directory_others_can_read_is_not_valid() {
        let open = tempfile::tempdir().unwrap();
        std::fs::set_permissions(open.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
        let dir = replacement(Some(open.path())).expect("replaced");
        assert_ne!(dir, open.path());
    }
}
