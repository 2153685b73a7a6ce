//! Reading ahead: a LAS or LAZ file's next batch decoded on a thread of its own while the
//! preparation (`cloud::ooc::prepare`) checks, samples and writes the current one to scratch.
//!
//! The decoding is parallel (`las`'s LAZ decoder on every core) but the preparation's pass over
//! a batch is sequential (its records go to scratch in input order), so one after the other
//! left a core idle for most of the reading stage. The batches come in the file's order, each
//! the points [`cloud::io::las::LasStream::next_into`] gives, so the preparation sees the very
//! same points in the same batches as without reading ahead.
//!
//! The points carry the file's normals where its extra bytes give them (`LasStream::normals`,
//! each checked to be a unit vector as it is decoded), else none.
//!
//! Memory: two batches of points (the one being prepared and the one being decoded) besides
//! the stream's buffers (its records' extra bytes counted, `LasStream::bytes_per_point`); the consumer hands each batch back once done so the two are reused.
//! After the last batch the reading thread is joined, so its buffers are gone before the
//! preparation loads its first chunk.

use std::path::Path;
use std::sync::mpsc::{Receiver, Sender, SyncSender, channel, sync_channel};
use std::thread::{Scope, ScopedJoinHandle};

use cloud::glam::Vec3;
use cloud::io::las::{LasOptions, LasStream};
use cloud::io::las_extra::ExtraNormals;
use cloud::lod_file::Error;
use cloud::ooc::Point;

/// A batch, and whether more follow; or the reading's error.
type Batch = Result<(Vec<Point>, bool), cloud::ReadError>;

/// What the file's header says.
pub(super) struct Info {
    /// Points the header announces.
    pub announced: u64,
    /// Whether the points have RGB.
    pub with_color: bool,
    /// The grid every position lies on (`LasStream::grid`).
    pub grid: cloud::ooc::Grid,
    /// The normals the file's extra bytes give, if any (`LasStream::normals`).
    pub normals: Option<ExtraNormals>,
}

/// The consumer's end of a stream read ahead on a scoped thread.
pub(super) struct ReadAhead<'scope> {
    batches: Receiver<Batch>,
    spent: Sender<Vec<Point>>,
    thread: Option<ScopedJoinHandle<'scope, ()>>,
}

impl<'scope> ReadAhead<'scope> {
    /// Opens `path` on a thread of `scope` (the `las` crate's reader stays on the thread that
    /// opened it) and decodes it there in batches that `memory_limit` allows
    /// (`super::read_chunk`), colours and normals kept where the file has them; returns once
    /// the file's header and chunk table are checked.
    pub(super) fn open<'env>(
        scope: &'scope Scope<'scope, 'env>,
        path: &'env Path,
        memory_limit: u64,
    ) -> Result<(Self, Info), cloud::ReadError> {
        let (info_tx, info_rx) = sync_channel(1);
        // A rendezvous: the thread holds at most the one batch it has decoded.
        let (tx, batches) = sync_channel(0);
        let (spent, spent_rx) = channel();
        let thread = scope.spawn(move || {
            let stream = match LasStream::open(path, &LasOptions::default()) {
                Ok(s) => {
                    let chunk = super::read_chunk(memory_limit, s.bytes_per_point());
                    s.with_chunk(chunk)
                }
                Err(e) => {
                    let _ = info_tx.send(Err(e));
                    return;
                }
            };
            let info = Info {
                announced: stream.announced,
                with_color: stream.with_color,
                grid: stream.grid(),
                normals: stream.normals.clone(),
            };
            let (colors, normals) = (info.with_color, info.normals.is_some());
            if info_tx.send(Ok(info)).is_ok() {
                produce(stream, colors, normals, &tx, &spent_rx);
            }
        });
        let mut ahead = ReadAhead {
            batches,
            spent,
            thread: Some(thread),
        };
        match info_rx.recv() {
            Ok(Ok(info)) => Ok((ahead, info)),
            Ok(Err(e)) => {
                ahead.join();
                Err(e)
            }
            // The thread ends without a header only by panicking: the panic goes on here.
            Err(_) => {
                ahead.join();
                unreachable!("the reading thread ended without a header or a panic");
            }
        }
    }

    /// Replaces `batch` with the next batch (the old one goes back to be refilled); `false`
    /// once the last was given.
    pub(super) fn next(&mut self, batch: &mut Vec<Point>) -> Result<bool, Error> {
        if self.thread.is_none() {
            return Ok(false);
        }
        let got = match self.batches.recv() {
            Ok(got) => got,
            // The thread ends without a last batch only by panicking: the panic goes on here.
            Err(_) => {
                self.join();
                unreachable!("the reading thread ended without its last batch or a panic");
            }
        };
        let (points, more) = match got {
            Ok(got) => got,
            Err(e) => {
                self.join();
                return Err(Error::Cloud(cloud::Error::Read(e)));
            }
        };
        let spent = std::mem::replace(batch, points);
        if more {
            // The thread may have stopped already only after an error, reported above.
            let _ = self.spent.send(spent);
        } else {
            // The reading buffers go before the chunks come.
            self.join();
        }
        Ok(more)
    }

    fn join(&mut self) {
        if let Some(t) = self.thread.take()
            && let Err(panic) = t.join()
        {
            std::panic::resume_unwind(panic);
        }
    }
}

/// The reading thread: decodes batch after batch, each into a vector the consumer handed back,
/// until the last, an error, or the consumer is gone.
fn produce(
    mut stream: LasStream,
    colors: bool,
    normals: bool,
    tx: &SyncSender<Batch>,
    spent: &Receiver<Vec<Point>>,
) {
    let mut chunk = cloud::PointCloud {
        colors: colors.then(Vec::new),
        normals: normals.then(Vec::new),
        ..cloud::PointCloud::default()
    };
    let mut batch = Vec::new();
    loop {
        chunk.positions.clear();
        if let Some(c) = chunk.colors.as_mut() {
            c.clear();
        }
        if let Some(n) = chunk.normals.as_mut() {
            n.clear();
        }
        let got = stream.next_into(&mut chunk).map(|more| {
            batch.clear();
            batch.extend(chunk.positions.iter().enumerate().map(|(i, &p)| Point {
                position: p,
                normal: chunk.normals.as_ref().map_or(Vec3::ZERO, |n| n[i]),
                color: chunk.colors.as_ref().map_or([0; 3], |c| c[i]),
            }));
            (std::mem::take(&mut batch), more)
        });
        let last = !matches!(got, Ok((_, true)));
        if tx.send(got).is_err() || last {
            return;
        }
        match spent.recv() {
            Ok(b) => batch = b,
            Err(_) => return,
        }
    }
}
