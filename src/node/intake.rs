//! Requests that may be large, decoded off the node's thread ([`OffThread`]).
//!
//! A pose candidate or a set may carry inline meshes, and decoding one takes time in proportion
//! to its size, whatever the node then does with it: the elements beyond
//! `max_inline_mesh_triangles` are decoded and dropped (CDR has no way to skip a sequence but
//! element by element), and a 120 MB candidate (5M triangles) took one core 175 ms here (`perf
//! record` on the node while `tests/ros/test_mesh_loads.py` sends it). Decoded on the node's own
//! thread, that time would hold up every contact candidate, parameter request and transform
//! queued behind it. So the pose candidates and the sets of every kind (topics and services)
//! are read on a thread of their own, which decodes each message and hands it over a short
//! bounded channel: the node's thread only receives what is already decoded. When the node falls
//! behind, the channel fills and the reading thread waits, so the requests not yet taken stay in
//! the DDS reader's queue (its history depth) as before.

use futures::channel::{mpsc, oneshot};
use futures::stream::{FusedStream, LocalBoxStream, Stream, StreamExt as _};
use futures::{FutureExt as _, SinkExt as _};
use std::pin::Pin;
use std::task::{Context, Poll};

/// Decoded requests the reading thread may hold ready before the node's thread takes them.
const READY: usize = 2;

/// A stream read and decoded on its own thread, received on this one. Dropping it stops the
/// thread (after the message it is decoding, if any) and waits for it.
pub(crate) struct OffThread<T> {
    items: mpsc::Receiver<T>,
    stop: Option<oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl<T: Send + 'static> OffThread<T> {
    /// Starts a thread named `name` that owns `source` and reads `stream(&source)`: each item is
    /// decoded there and sent to the returned stream.
    pub(crate) fn spawn<S: Send + 'static>(
        name: &str,
        source: S,
        stream: for<'a> fn(&'a S) -> LocalBoxStream<'a, T>,
    ) -> std::io::Result<Self> {
        let (items_in, items) = mpsc::channel(READY);
        let (stop, stopped) = oneshot::channel();
        let thread = std::thread::Builder::new()
            .name(name.to_string())
            .spawn(move || {
                let read = std::panic::AssertUnwindSafe(|| {
                    smol::block_on(forward(stream(&source), items_in, stopped));
                });
                if std::panic::catch_unwind(read).is_err() {
                    log::error!("the thread reading requests panicked; they are no longer taken");
                }
            })?;
        Ok(Self {
            items,
            stop: Some(stop),
            thread: Some(thread),
        })
    }
}

/// Sends each item of `from` to `to` until `from` ends, `to` is dropped or `stop` fires; waits
/// while `to` is full.
async fn forward<T>(
    mut from: LocalBoxStream<'_, T>,
    mut to: mpsc::Sender<T>,
    stop: oneshot::Receiver<()>,
) {
    let mut stop = stop.fuse();
    loop {
        let item = futures::select_biased! {
            _ = stop => return,
            item = from.next().fuse() => match item {
                Some(item) => item,
                None => return,
            },
        };
        futures::select_biased! {
            _ = stop => return,
            sent = to.send(item).fuse() => if sent.is_err() {
                return;
            },
        }
    }
}

impl<T> Stream for OffThread<T> {
    type Item = T;

    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<T>> {
        self.items.poll_next_unpin(cx)
    }
}

impl<T> FusedStream for OffThread<T> {
    fn is_terminated(&self) -> bool {
        self.items.is_terminated()
    }
}

impl<T> Drop for OffThread<T> {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            stop.send(()).ok();
        }
        self.items.close();
        if let Some(thread) = self.thread.take() {
            thread.join().ok();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;

    /// A source whose stream records on which thread each item was made.
    struct Counting {
        made: Arc<AtomicUsize>,
        n: usize,
    }

    fn numbers(source: &Counting) -> LocalBoxStream<'_, (usize, std::thread::ThreadId)> {
        futures::stream::iter(0..source.n)
            .map(|k| {
                source.made.fetch_add(1, Ordering::SeqCst);
                (k, std::thread::current().id())
            })
            .boxed_local()
    }

    #[test]
    fn items_are_made_on_the_reading_thread_and_arrive_in_order() {
        let made = Arc::new(AtomicUsize::new(0));
        let source = Counting {
            made: made.clone(),
            n: 50,
        };
        let stream = OffThread::spawn("intake test", source, numbers).expect("thread starts");
        let got: Vec<_> = smol::block_on(stream.collect::<Vec<_>>());
        let here = std::thread::current().id();
        assert_eq!(got.len(), 50);
        assert!(got.iter().enumerate().all(|(k, (n, _))| k == *n));
        assert!(got.iter().all(|(_, made_on)| *made_on != here));
        assert_eq!(made.load(Ordering::SeqCst), 50);
    }

    fn endless(source: &Counting) -> LocalBoxStream<'_, usize> {
        futures::stream::repeat(())
            .map(|()| source.made.fetch_add(1, Ordering::SeqCst))
            .boxed_local()
    }

    #[test]
    fn the_reading_thread_waits_while_the_channel_is_full_and_stops_on_drop() {
        let made = Arc::new(AtomicUsize::new(0));
        let source = Counting {
            made: made.clone(),
            n: 0,
        };
        let mut stream = OffThread::spawn("intake test", source, endless).expect("thread starts");
        let first = smol::block_on(stream.next());
        assert_eq!(first, Some(0));
        std::thread::sleep(std::time::Duration::from_millis(100));
        // The channel holds READY items, one more is held by the sender per its slot, and one
        // more is made and waits to be sent: never an unbounded run ahead.
        let ahead = made.load(Ordering::SeqCst);
        assert!(
            ahead <= READY + 3,
            "{ahead} items made ahead of the receiver"
        );
        drop(stream); // joins the thread: it must see the stop while it waits to send
        let after = made.load(Ordering::SeqCst);
        std::thread::sleep(std::time::Duration::from_millis(50));
        assert_eq!(
            made.load(Ordering::SeqCst),
            after,
            "the thread still runs after drop"
        );
    }
}
