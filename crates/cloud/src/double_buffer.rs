//! A front/back buffer fed by a background thread: seed 000 §5 as a reusable component.
//!
//! Seed 000 §5 (and seed 001's concurrent update and render): the visible points need not be
//! recomputed every frame. An auxiliary thread keeps computing for the latest camera into a
//! *back buffer*; when it finishes it raises a flag; the main thread, once per frame, sees the
//! flag and swaps the back buffer to the *front buffer*, which is what it renders. Rendering
//! never waits; the displayed result is as old as one computation.
//!
//! [`DoubleBuffer::request`] posts the latest input (replacing any input not yet started);
//! the worker computes the newest input whenever it is idle; [`DoubleBuffer::swap_if_ready`]
//! is the flag check; [`DoubleBuffer::front`] is what to render, with the input it was computed
//! for and its sequence number. A panic in the computation is caught and reported by
//! `swap_if_ready`; dropping the buffer stops and joins the thread.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// A computed result and the input it belongs to.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame<Req, Res> {
    /// Sequence number of the request (1 for the first).
    pub sequence: u64,
    /// The input.
    pub request: Req,
    /// The output.
    pub result: Res,
}

/// The worker thread panicked.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("the background computation panicked: {0}")]
pub struct WorkerPanicked(pub String);

struct State<Req, Res> {
    pending: Option<(u64, Req)>,
    back: Option<Frame<Req, Res>>,
    busy: bool,
    shutdown: bool,
    panicked: Option<String>,
}

struct Shared<Req, Res> {
    state: Mutex<State<Req, Res>>,
    wake: Condvar,
}

impl<Req, Res> Shared<Req, Res> {
    fn lock(&self) -> MutexGuard<'_, State<Req, Res>> {
        // A poisoned lock only means the other side panicked while holding it; the state
        // itself is always consistent (single assignments), so keep going.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Front and back buffers with a worker thread.
pub struct DoubleBuffer<Req: Send + 'static, Res: Send + 'static> {
    shared: Arc<Shared<Req, Res>>,
    worker: Option<JoinHandle<()>>,
    front: Option<Frame<Req, Res>>,
    next_sequence: u64,
}

impl<Req: Send + 'static, Res: Send + 'static> DoubleBuffer<Req, Res> {
    /// Starts the worker with the computation `compute`.
    pub fn spawn(mut compute: impl FnMut(&Req) -> Res + Send + 'static) -> Self {
        let shared = Arc::new(Shared {
            state: Mutex::new(State {
                pending: None,
                back: None,
                busy: false,
                shutdown: false,
                panicked: None,
            }),
            wake: Condvar::new(),
        });
        let worker_shared = Arc::clone(&shared);
        let worker = std::thread::spawn(move || {
            loop {
                let (sequence, request) = {
                    let mut state = worker_shared.lock();
                    loop {
                        if state.shutdown {
                            return;
                        }
                        if let Some(job) = state.pending.take() {
                            state.busy = true;
                            break job;
                        }
                        state = worker_shared
                            .wake
                            .wait(state)
                            .unwrap_or_else(|e| e.into_inner());
                    }
                };
                let outcome = catch_unwind(AssertUnwindSafe(|| compute(&request)));
                let mut state = worker_shared.lock();
                state.busy = false;
                match outcome {
                    Ok(result) => {
                        state.back = Some(Frame {
                            sequence,
                            request,
                            result,
                        })
                    }
                    Err(payload) => {
                        state.panicked = Some(
                            payload
                                .downcast_ref::<&str>()
                                .map(|s| (*s).to_owned())
                                .or_else(|| payload.downcast_ref::<String>().cloned())
                                .unwrap_or_else(|| "non-string panic payload".into()),
                        );
                        worker_shared.wake.notify_all();
                        return;
                    }
                }
                worker_shared.wake.notify_all();
            }
        });
        Self {
            shared,
            worker: Some(worker),
            front: None,
            next_sequence: 1,
        }
    }

    /// Posts the latest input; an input posted earlier and not yet started is dropped.
    /// Returns the input's sequence number.
    pub fn request(&mut self, request: Req) -> u64 {
        let sequence = self.next_sequence;
        self.next_sequence += 1;
        self.shared.lock().pending = Some((sequence, request));
        self.shared.wake.notify_all();
        sequence
    }

    /// True while the worker computes or an input waits.
    pub fn is_busy(&self) -> bool {
        let state = self.shared.lock();
        state.busy || state.pending.is_some()
    }

    /// The flag check of seed 000 §5: when the worker has finished a result, make it the
    /// front buffer. Returns whether the front changed.
    pub fn swap_if_ready(&mut self) -> Result<bool, WorkerPanicked> {
        let mut state = self.shared.lock();
        if let Some(message) = &state.panicked {
            return Err(WorkerPanicked(message.clone()));
        }
        match state.back.take() {
            Some(frame) => {
                drop(state);
                self.front = Some(frame);
                Ok(true)
            }
            None => Ok(false),
        }
    }

    /// Blocks until the result of request `sequence` (or a newer one) is the front buffer.
    pub fn wait_for(&mut self, sequence: u64) -> Result<(), WorkerPanicked> {
        loop {
            self.swap_if_ready()?;
            if self.front.as_ref().is_some_and(|f| f.sequence >= sequence) {
                return Ok(());
            }
            let state = self.shared.lock();
            if state.back.is_none() && state.panicked.is_none() {
                drop(
                    self.shared
                        .wake
                        .wait(state)
                        .unwrap_or_else(|e| e.into_inner()),
                );
            }
        }
    }

    /// What to render: the newest swapped-in result.
    pub fn front(&self) -> Option<&Frame<Req, Res>> {
        self.front.as_ref()
    }
}

impl<Req: Send + 'static, Res: Send + 'static> Drop for DoubleBuffer<Req, Res> {
    fn drop(&mut self) {
        self.shared.lock().shutdown = true;
        self.shared.wake.notify_all();
        if let Some(worker) = self.worker.take() {
            let _ = worker.join();
        }
    }
}

impl<Req: Send + 'static, Res: Send + 'static> std::fmt::Debug for DoubleBuffer<Req, Res> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DoubleBuffer")
            .field("front_sequence", &self.front.as_ref().map(|fr| fr.sequence))
            .field("next_sequence", &self.next_sequence)
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::time::Duration;

    use super::*;

    #[test]
    fn results_arrive_in_order_and_stale_inputs_are_skipped() {
        let computed = Arc::new(AtomicUsize::new(0));
        let counter = Arc::clone(&computed);
        let mut buf = DoubleBuffer::spawn(move |x: &u64| {
            counter.fetch_add(1, Ordering::SeqCst);
            std::thread::sleep(Duration::from_millis(20));
            x * 2
        });
        assert!(buf.front().is_none());
        let first = buf.request(1);
        // While the first computes, post several inputs: only the newest is computed next.
        std::thread::sleep(Duration::from_millis(5));
        for x in 2..10 {
            buf.request(x);
        }
        let last = buf.request(10);
        buf.wait_for(last).unwrap();
        let front = buf.front().unwrap();
        assert_eq!(
            (front.sequence, front.request, front.result),
            (last, 10, 20)
        );
        assert!(first < last);
        assert!(
            computed.load(Ordering::SeqCst) <= 3,
            "{}",
            computed.load(Ordering::SeqCst)
        );
    }

    #[test]
    fn the_front_only_changes_at_a_swap() {
        let mut buf = DoubleBuffer::spawn(|x: &i32| *x);
        let s = buf.request(7);
        while buf.is_busy() {
            std::thread::sleep(Duration::from_millis(1));
        }
        // Finished, but not yet swapped.
        assert!(buf.front().is_none());
        assert!(buf.swap_if_ready().unwrap());
        assert_eq!(buf.front().unwrap().sequence, s);
        assert!(!buf.swap_if_ready().unwrap());
    }

    #[test]
    fn a_panic_in_the_worker_is_reported() {
        let mut buf = DoubleBuffer::spawn(|x: &i32| if *x < 0 { panic!("negative") } else { *x });
        let s = buf.request(-1);
        let err = buf.wait_for(s).unwrap_err();
        assert_eq!(err, WorkerPanicked("negative".into()));
    }
}
