//! The file layer the level-of-detail methods share (QSplat's tree files, the sequential point
//! trees' list files, and the out-of-core preparation that feeds both): one error type for
//! building, writing and reading them, and a positional reader that names its file in every
//! error and counts the bytes it read (what a selection from a file reports).
//!
//! A method crate uses [`Error`] as its own (`pub use`), naming its format where a message says
//! which kind of file is damaged or too old, so that a damaged file, a missing normal or an
//! unreadable scratch file reads the same whichever method met it.

use std::fs::File;
use std::os::unix::fs::FileExt as _;
use std::path::Path;

/// Why a level-of-detail structure could not be built, written, read or traversed.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Invalid input caught by the rest of this crate (a non-finite point, a bad `k`).
    #[error(transparent)]
    Cloud(#[from] crate::Error),
    /// No points.
    #[error("the point cloud is empty")]
    EmptyCloud,
    /// The points have no normals, which the method (or [`crate::ooc::Normals::Given`]) needs.
    #[error("the points have no normals, and a normal per point is needed")]
    MissingNormals,
    /// A parameter (or what the input makes of one) is out of range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Name.
        name: &'static str,
        /// Why.
        reason: String,
    },
    /// A file (a built one, a scratch file or the output beside it) could not be read or
    /// written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// A file of an older format version.
    #[error(
        "{path}: written by an older pointsight ({format} file format version {version}, this \
         reads version {current}{changes}); rebuild it with `pointsight lod-build`"
    )]
    OldVersion {
        /// The file.
        path: String,
        /// The format's name ("QSplat", "sequential point tree").
        format: &'static str,
        /// Its version.
        version: u32,
        /// The version this reads.
        current: u32,
        /// What the versions since changed, as a clause (", which adds checksums").
        changes: &'static str,
    },
    /// A block whose checksum does not match: the file was damaged after it was written.
    #[error(
        "{path}: checksum mismatch in {block} (bytes {offset}..{end}): the file is damaged; \
         rebuild it with `pointsight lod-build`"
    )]
    Checksum {
        /// The file.
        path: String,
        /// Which block ("the header", "word page 3", "entry block 3").
        block: String,
        /// The block's first byte.
        offset: u64,
        /// One past its last byte.
        end: u64,
    },
    /// The file is not of the format or is damaged.
    #[error("{path}: corrupt {format} file at byte {offset}: {reason}")]
    Corrupt {
        /// The file.
        path: String,
        /// The format's name.
        format: &'static str,
        /// Byte offset of the problem.
        offset: u64,
        /// What is wrong.
        reason: String,
    },
}

/// Result alias of the layer.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// A built file opened for positional reads (`pread`: no seek state, no mapping, which would
/// need `unsafe`).
#[derive(Debug)]
pub struct FileReader {
    file: File,
    path: String,
    len: u64,
    bytes_read: u64,
}

impl FileReader {
    /// Opens `path` and reads its length.
    pub fn open(path: &Path) -> Result<Self> {
        let name = path.display().to_string();
        let io = |source| Error::Io {
            path: name.clone(),
            source,
        };
        let file = File::open(path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        Ok(Self {
            file,
            path: name,
            len,
            bytes_read: 0,
        })
    }

    /// The file as its errors name it.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// The file's length, bytes, when it was opened.
    pub fn len(&self) -> u64 {
        self.len
    }

    /// True for an empty file.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Bytes read so far.
    pub fn bytes_read(&self) -> u64 {
        self.bytes_read
    }

    /// Its first `max` bytes, or the whole file when it is shorter (a header, checked by the
    /// caller against what it says of the length).
    pub fn head(&mut self, max: usize) -> Result<Vec<u8>> {
        let mut head = vec![0u8; usize::try_from(self.len).map_or(max, |len| max.min(len))];
        self.read_at(&mut head, 0)?;
        Ok(head)
    }

    /// Fills `buf` from byte `offset` on; a short file is an error naming it.
    pub fn read_at(&mut self, buf: &mut [u8], offset: u64) -> Result<()> {
        self.file
            .read_exact_at(buf, offset)
            .map_err(|source| Error::Io {
                path: self.path.clone(),
                source,
            })?;
        self.bytes_read += buf.len() as u64;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_name_the_file_and_count_their_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tree.bin");
        std::fs::write(&path, b"0123456789").unwrap();
        let mut r = FileReader::open(&path).unwrap();
        assert_eq!((r.len(), r.bytes_read()), (10, 0));
        assert_eq!(r.head(4).unwrap(), b"0123");
        assert_eq!(r.head(64).unwrap(), b"0123456789");
        let mut buf = [0u8; 3];
        r.read_at(&mut buf, 7).unwrap();
        assert_eq!((&buf, r.bytes_read()), (b"789", 17));
        let err = r.read_at(&mut buf, 8).unwrap_err().to_string();
        assert!(err.starts_with(&path.display().to_string()), "{err}");
        let missing = FileReader::open(&dir.path().join("none")).unwrap_err();
        assert!(matches!(missing, Error::Io { .. }), "{missing}");
    }

    #[test]
    fn messages_name_the_format() {
        let e = Error::Corrupt {
            path: "t.qsplat".into(),
            format: "QSplat",
            offset: 12,
            reason: "bad word".into(),
        };
        assert_eq!(
            e.to_string(),
            "t.qsplat: corrupt QSplat file at byte 12: bad word"
        );
        let e = Error::OldVersion {
            path: "t.spt".into(),
            format: "sequential point tree",
            version: 1,
            current: 3,
            changes: ": checksums since 2",
        };
        assert!(
            e.to_string()
                .contains("(sequential point tree file format version 1, this reads version 3: checksums since 2); rebuild"),
            "{e}"
        );
    }
}
