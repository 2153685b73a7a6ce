//! Writing files whole or not at all, and only where a file may be written.
//!
//! The bytes go to a hidden file beside the target (`.NAME.partial-HOST-PID-K`), which is
//! renamed over the target only when everything was written and flushed; on an error or a
//! panic the partial file is removed (and on a signal, through [`crate::scratch`]'s registry).
//! Every writer of this crate (PLY, LAS/LAZ, QSplat and SPT files through [`write`]) and the
//! harness's results use it, so an error never leaves half a file, and an existing file is
//! kept until its replacement is complete.
//!
//! What an output may replace ([`target`]): nothing, or a regular file. A directory, a FIFO, a
//! socket or a device is refused (renaming over a device node replaced it with a regular file);
//! a symbolic link is written through: the file it names is replaced (keeping its permissions)
//! and the link kept. A file this process has read as input (any reader of [`crate::io`]
//! notes it, [`note_input`]) is never replaced, and [`check_output`] refuses an output that is
//! one of a command's inputs (the same file by device and inode) before any work.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Removes the partial file unless disarmed.
struct Partial(Option<crate::scratch::Registered>);

impl Drop for Partial {
    fn drop(&mut self) {
        if let Some(registered) = self.0.take() {
            let _ = std::fs::remove_file(registered.path());
        }
    }
}

fn partial_path(path: &Path) -> PathBuf {
    crate::scratch::beside(path, "partial")
}

/// A file's identity: device, inode and modification time (seconds, nanoseconds). The time
/// tells a file apart from a later one that reuses a deleted file's inode (a file read, then
/// removed, must not make a new file at its inode count as an input).
type Identity = (u64, u64, i64, i64);

/// Files this process has read.
static INPUTS: Mutex<Vec<Identity>> = Mutex::new(Vec::new());

/// The identity of an existing file (symbolic links followed).
#[cfg(unix)]
fn identity(path: &Path) -> Option<Identity> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path)
        .ok()
        .map(|m| (m.dev(), m.ino(), m.mtime(), m.mtime_nsec()))
}

#[cfg(not(unix))]
fn identity(_path: &Path) -> Option<Identity> {
    None
}

/// Notes that this process reads `path`, so that no output replaces it.
pub fn note_input(path: &Path) {
    if let Some(id) = identity(path)
        && let Ok(mut inputs) = INPUTS.lock()
        && !inputs.contains(&id)
    {
        inputs.push(id);
    }
}

/// True when `path` is a file this process has read ([`note_input`]; links followed).
pub fn was_read(path: &Path) -> bool {
    identity(path).is_some_and(|id| INPUTS.lock().is_ok_and(|i| i.contains(&id)))
}

fn kind_of(file_type: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return "a FIFO";
        }
        if file_type.is_socket() {
            return "a socket";
        }
        if file_type.is_char_device() {
            return "a character device";
        }
        if file_type.is_block_device() {
            return "a block device";
        }
    }
    if file_type.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

/// Where a file output at `path` goes: `path` itself when nothing is there or it is a regular
/// file; the file a symbolic link names (followed to the end, a dangling link's target
/// created); an error naming what is there when that is not a regular file, or when it is a
/// file this process has read.
pub fn target(path: &Path) -> io::Result<PathBuf> {
    let mut at = path.to_path_buf();
    for _ in 0..40 {
        let meta = match std::fs::symlink_metadata(&at) {
            Ok(m) => m,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(at),
            Err(e) => return Err(e),
        };
        if meta.file_type().is_symlink() {
            let link = std::fs::read_link(&at)?;
            at = match at.parent() {
                Some(dir) if link.is_relative() => dir.join(link),
                _ => link,
            };
            continue;
        }
        if !meta.file_type().is_file() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "{} is {}: a file output replaces only a regular file",
                    describe(path, &at),
                    kind_of(meta.file_type())
                ),
            ));
        }
        if was_read(&at) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "{} is a file this command reads: an output never replaces an input",
                    describe(path, &at)
                ),
            ));
        }
        return Ok(at);
    }
    Err(io::Error::new(
        io::ErrorKind::InvalidInput,
        format!("{}: too many levels of symbolic links", path.display()),
    ))
}

/// `path`, and where its links lead when that is elsewhere.
fn describe(path: &Path, at: &Path) -> String {
    if path == at {
        path.display().to_string()
    } else {
        format!("{} (a link to {})", path.display(), at.display())
    }
}

/// Fails unless `out` can be written as a file output ([`target`]) and is none of `inputs`
/// (the same file by device and inode, links followed): what a command checks before any work.
pub fn check_output(out: &Path, inputs: &[&Path]) -> io::Result<()> {
    target(out)?;
    check_not_input(out, inputs)
}

/// Fails when `out` exists and is one of `inputs` (the same file by device and inode): for
/// outputs that are folders as for files.
pub fn check_not_input(out: &Path, inputs: &[&Path]) -> io::Result<()> {
    let Some(id) = identity(out) else {
        return Ok(());
    };
    match inputs.iter().find(|i| identity(i) == Some(id)) {
        Some(input) => Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "the output {} is the input {}: an output never replaces an input",
                out.display(),
                input.display()
            ),
        )),
        None => Ok(()),
    }
}

/// Fails unless a folder output at `path` can be made or replaced: nothing there, or a
/// directory (a symbolic link to one is followed: the returned path is where it leads).
pub fn folder_target(path: &Path) -> io::Result<PathBuf> {
    let resolved = match std::fs::canonicalize(path) {
        Ok(p) => p,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(path.to_path_buf()),
        Err(e) => return Err(e),
    };
    let meta = std::fs::metadata(&resolved)?;
    if !meta.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "{} is {}: a folder output is a directory",
                describe(path, &resolved),
                kind_of(meta.file_type())
            ),
        ));
    }
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
        Ok(resolved)
    } else {
        Ok(path.to_path_buf())
    }
}

/// Lets `fill` write the file at the partial path it is given (for writers that open files
/// themselves), then renames it to `path`'s [`target`] (a failed rename, or a target that
/// may not be replaced, becomes an `E` by `rename_error`).
pub fn write_via<T, E>(
    path: &Path,
    fill: impl FnOnce(&Path) -> Result<T, E>,
    rename_error: impl FnOnce(io::Error) -> E,
) -> Result<T, E> {
    let target = match target(path) {
        Ok(t) => t,
        Err(e) => return Err(rename_error(e)),
    };
    let partial = partial_path(&target);
    let mut guard = Partial(Some(crate::scratch::register(&partial)));
    let value = fill(&partial)?;
    if let Err(e) = put_in_place(&partial, &target) {
        return Err(rename_error(e));
    }
    // In place: no longer scratch.
    drop(guard.0.take());
    Ok(value)
}

/// Renames the finished `partial` over `target`, checked again (something may have appeared
/// there while the file was written); a replaced file's permissions are kept.
fn put_in_place(partial: &Path, target: &Path) -> io::Result<()> {
    let target = self::target(target)?;
    if let Ok(meta) = std::fs::metadata(&target) {
        std::fs::set_permissions(partial, meta.permissions())?;
    }
    std::fs::rename(partial, &target)
}

/// Runs `fill` on a buffered writer over a partial file beside `path`, then renames it to
/// `path`.
pub fn write_with<T>(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> io::Result<T>,
) -> io::Result<T> {
    write_via(
        path,
        |partial| {
            let mut out = BufWriter::with_capacity(1 << 20, File::create(partial)?);
            let value = fill(&mut out)?;
            out.flush()?;
            out.get_ref().sync_data()?;
            Ok(value)
        },
        |e| e,
    )
}

/// Writes `bytes` to `path` whole or not at all.
pub fn write(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_with(path, |out| out.write_all(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_failed_write_leaves_no_file_and_keeps_the_old_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        let err = write_with(&path, |out| {
            out.write_all(b"half")?;
            Err::<(), _>(io::Error::other("disk full"))
        })
        .unwrap_err();
        assert_eq!(err.to_string(), "disk full");
        assert!(entries(dir.path()).is_empty(), "{:?}", entries(dir.path()));

        write(&path, b"old").unwrap();
        let _ = write_with(&path, |out| {
            out.write_all(b"new, but")?;
            Err::<(), _>(io::Error::other("interrupted"))
        });
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(entries(dir.path()), vec!["out.bin".to_owned()]);
    }

    #[test]
    fn a_panic_while_writing_leaves_no_partial_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        let result = std::panic::catch_unwind(|| {
            write_with(&path, |out| -> io::Result<()> {
                out.write_all(b"x")?;
                panic!("a bug while writing")
            })
        });
        assert!(result.is_err());
        assert!(entries(dir.path()).is_empty());
    }

    #[cfg(unix)]
    #[test]
    fn only_a_regular_file_is_replaced_and_links_are_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // A directory, a socket and a device are refused, named, and left as they were.
        std::fs::create_dir(d.join("folder")).unwrap();
        let _socket = std::os::unix::net::UnixListener::bind(d.join("socket")).unwrap();
        for (path, what) in [
            (d.join("folder"), "is a directory"),
            (d.join("socket"), "is a socket"),
            (PathBuf::from("/dev/null"), "is a character device"),
        ] {
            let err = target(&path).unwrap_err().to_string();
            assert!(err.contains(what), "{err}");
            if path.starts_with(d) {
                let err = write(&path, b"x").unwrap_err().to_string();
                assert!(err.contains(what), "{err}");
            }
        }
        assert!(d.join("folder").is_dir());
        let meta = std::fs::symlink_metadata(d.join("socket")).unwrap();
        assert!(std::os::unix::fs::FileTypeExt::is_socket(&meta.file_type()));
        // A FIFO (made by mkfifo where the system has it).
        if std::process::Command::new("mkfifo")
            .arg(d.join("fifo"))
            .status()
            .is_ok_and(|s| s.success())
        {
            let err = write(&d.join("fifo"), b"x").unwrap_err().to_string();
            assert!(err.contains("is a FIFO"), "{err}");
        }
        // A link to a regular file: the file replaced, the link kept, the mode kept.
        std::fs::create_dir(d.join("real")).unwrap();
        let real = d.join("real/data.bin");
        std::fs::write(&real, b"old").unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o640)).unwrap();
        std::os::unix::fs::symlink("real/data.bin", d.join("link.bin")).unwrap();
        write(&d.join("link.bin"), b"new").unwrap();
        assert!(
            std::fs::symlink_metadata(d.join("link.bin"))
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        assert_eq!(
            std::fs::metadata(&real).unwrap().permissions().mode() & 0o777,
            0o640
        );
        // A link to a directory is refused like the directory.
        std::os::unix::fs::symlink("folder", d.join("to-folder")).unwrap();
        let err = write(&d.join("to-folder"), b"x").unwrap_err().to_string();
        assert!(
            err.contains("a link to") && err.contains("is a directory"),
            "{err}"
        );
        // No partial file anywhere.
        assert!(
            entries(d)
                .iter()
                .chain(&entries(&d.join("real")))
                .all(|n| !n.contains("partial")),
            "{:?}",
            entries(d)
        );
    }

    #[test]
    fn an_input_is_never_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("cloud.xyz");
        std::fs::write(&input, b"0 0 0\n").unwrap();
        let other = dir.path().join("other.xyz");
        std::fs::write(&other, b"1 1 1\n").unwrap();
        #[cfg(unix)]
        std::os::unix::fs::symlink("cloud.xyz", dir.path().join("alias.xyz")).unwrap();
        let err = check_output(&input, &[&other, &input])
            .unwrap_err()
            .to_string();
        assert!(err.contains("is the input"), "{err}");
        #[cfg(unix)]
        assert!(check_output(&dir.path().join("alias.xyz"), &[&input]).is_err());
        assert!(check_output(&other, &[&input]).is_ok());
        // Once read through a reader, no writer replaces it.
        crate::io::read(&input).unwrap();
        let err = write(&input, b"2 2 2\n").unwrap_err().to_string();
        assert!(err.contains("a file this command reads"), "{err}");
        assert_eq!(std::fs::read(&input).unwrap(), b"0 0 0\n");
    }

    #[test]
    fn a_missing_folder_is_an_error_not_a_partial_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no/such/folder/out.bin");
        assert!(write(&path, b"x").is_err());
        assert!(entries(dir.path()).is_empty());
    }
}
