//! A time series one thread makes while another reads it: the reader waits for the part it
//! needs. It lets a pass that drives another filter (the attitude that drives seed 000's
//! model) run beside it instead of before it.

use std::sync::{Condvar, Mutex, MutexGuard};

/// Items appended by one producer, read by others as they arrive; closed when complete.
#[derive(Debug, Default)]
pub struct Feed<T> {
    state: Mutex<State<T>>,
    grown: Condvar,
}

#[derive(Debug, Default)]
struct State<T> {
    items: Vec<T>,
    closed: bool,
}

impl<T> Feed<T> {
    pub fn new() -> Self {
        Feed {
            state: Mutex::new(State {
                items: Vec::new(),
                closed: false,
            }),
            grown: Condvar::new(),
        }
    }

    /// A feed already complete.
    pub fn complete(items: Vec<T>) -> Self {
        Feed {
            state: Mutex::new(State {
                items,
                closed: true,
            }),
            grown: Condvar::new(),
        }
    }

    fn lock(&self) -> MutexGuard<'_, State<T>> {
        // A producer that panicked left whole items behind: they are still good to read.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Appends items and wakes the readers.
    pub fn extend(&self, items: impl IntoIterator<Item = T>) {
        self.lock().items.extend(items);
        self.grown.notify_all();
    }

    /// No more items will come.
    pub fn close(&self) {
        self.lock().closed = true;
        self.grown.notify_all();
    }

    /// Waits until `ready` holds of the items so far, or the feed is closed, then reads them.
    pub fn read_when<R>(&self, ready: impl Fn(&[T]) -> bool, read: impl FnOnce(&[T]) -> R) -> R {
        let mut state = self.lock();
        while !state.closed && !ready(&state.items) {
            state = self.grown.wait(state).unwrap_or_else(|e| e.into_inner());
        }
        read(&state.items)
    }

    /// The items (a producer still running may add more).
    pub fn into_items(self) -> Vec<T> {
        self.state
            .into_inner()
            .unwrap_or_else(|e| e.into_inner())
            .items
    }
}

/// Closes the feed when dropped: a producer that returns early or panics never leaves its
/// readers waiting.
pub struct Closer<'a, T>(pub &'a Feed<T>);

impl<T> Drop for Closer<'_, T> {
    fn drop(&mut self) {
        self.0.close();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reader_waits_for_the_items_it_needs() {
        let feed = Feed::new();
        std::thread::scope(|s| {
            s.spawn(|| {
                let _closer = Closer(&feed);
                for chunk in (0..1000).collect::<Vec<i32>>().chunks(7) {
                    feed.extend(chunk.iter().copied());
                }
            });
            for want in [0usize, 10, 500, 999] {
                let got = feed.read_when(|items| items.len() > want, |items| items[want]);
                assert_eq!(got, want as i32);
            }
            // Past the end: the reader is released when the feed closes.
            let len = feed.read_when(|items| items.len() > 5000, |items| items.len());
            assert_eq!(len, 1000);
        });
        assert_eq!(feed.into_items().len(), 1000);
    }

    #[test]
    fn a_panicking_producer_releases_its_readers() {
        let feed: Feed<i32> = Feed::new();
        let outcome = std::thread::scope(|s| {
            let producer = s.spawn(|| {
                let _closer = Closer(&feed);
                feed.extend([1, 2, 3]);
                panic!("the producer fails");
            });
            let len = feed.read_when(|items| items.len() > 10, |items| items.len());
            (len, producer.join().is_err())
        });
        assert_eq!(outcome, (3, true));
    }
}
