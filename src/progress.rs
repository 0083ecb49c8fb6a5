//! Progress of long work (a forward pass, the smoother), told to whoever asked: the library
//! never draws; the command line turns it into a bar on a terminal.

/// Called now and then (not per sample) with the fraction of the work done, in `[0, 1]`.
/// `None`: nobody asked.
pub type Progress<'a> = Option<&'a (dyn Fn(f64) + Sync)>;

/// Tells `progress` the fraction `done / total` every `every`-th step (and never divides by
/// zero).
#[inline]
pub fn tell(progress: Progress<'_>, done: usize, total: usize, every: usize) {
    if let Some(f) = progress {
        if done % every.max(1) == 0 && total > 0 {
            f((done as f64 / total as f64).clamp(0.0, 1.0));
        }
    }
}
