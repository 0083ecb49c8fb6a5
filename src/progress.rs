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
        if done.is_multiple_of(every.max(1)) && total > 0 {
            f((done as f64 / total as f64).clamp(0.0, 1.0));
        }
    }
}

/// A reader that tells `progress` the fraction of `total` bytes read, every megabyte or so.
pub struct ReadProgress<'a, R> {
    inner: R,
    read: u64,
    told: u64,
    total: u64,
    progress: Progress<'a>,
}

impl<'a, R> ReadProgress<'a, R> {
    pub fn new(inner: R, total: u64, progress: Progress<'a>) -> Self {
        ReadProgress {
            inner,
            read: 0,
            told: 0,
            total,
            progress,
        }
    }
}

impl<R: std::io::Read> std::io::Read for ReadProgress<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.read += n as u64;
        if let Some(tell) = self.progress {
            if self.total > 0 && (self.read - self.told >= 1 << 20 || n == 0) {
                self.told = self.read;
                tell((self.read as f64 / self.total as f64).clamp(0.0, 1.0));
            }
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[test]
    fn tells_every_nth_step_as_a_fraction() {
        let told = Mutex::new(Vec::new());
        let record = |f: f64| told.lock().unwrap().push(f);
        for k in 0..1000 {
            tell(Some(&record), k, 1000, 250);
        }
        assert_eq!(*told.lock().unwrap(), [0.0, 0.25, 0.5, 0.75]);
        tell(Some(&record), 5, 0, 1);
        tell(None, 0, 10, 1);
        assert_eq!(
            told.lock().unwrap().len(),
            4,
            "nothing for an empty total or no listener"
        );
    }
}
