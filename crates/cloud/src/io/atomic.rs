//! Writing files whole or not at all: the bytes go to a hidden file beside the target
//! (`.NAME.partial-PID-K`), which is renamed over the target only when everything was written
//! and flushed; on an error or a panic the partial file is removed. Every writer of this crate
//! (PLY, LAS/LAZ, QSplat files through [`write`]) and the harness's results use it, so an error
//! never leaves half a file, and an existing file is kept until its replacement is complete.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Removes the partial file unless disarmed.
struct Partial(Option<PathBuf>);

impl Drop for Partial {
    fn drop(&mut self) {
        if let Some(path) = self.0.take() {
            let _ = std::fs::remove_file(path);
        }
    }
}

fn partial_path(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    let k = COUNTER.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(".{name}.partial-{}-{k}", std::process::id()))
}

/// Lets `fill` write the file at the partial path it is given (for writers that open files
/// themselves), then renames it to `path` (a failed rename becomes an `E` by `rename_error`).
pub fn write_via<T, E>(
    path: &Path,
    fill: impl FnOnce(&Path) -> Result<T, E>,
    rename_error: impl FnOnce(io::Error) -> E,
) -> Result<T, E> {
    let partial = partial_path(path);
    let mut guard = Partial(Some(partial.clone()));
    let value = fill(&partial)?;
    std::fs::rename(&partial, path).map_err(rename_error)?;
    guard.0 = None;
    Ok(value)
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

    #[test]
    fn a_missing_folder_is_an_error_not_a_partial_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no/such/folder/out.bin");
        assert!(write(&path, b"x").is_err());
        assert!(entries(dir.path()).is_empty());
    }
}
