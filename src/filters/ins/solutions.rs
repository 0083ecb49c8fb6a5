//! The solutions of a whole mission (forward or smoothed), one per filter epoch, kept on a
//! temporary file beyond a block (`spill`) so that a day-long mission does not hold them in
//! memory. The smoother makes them last first; they are read in time order.

use super::record::Solution;
use crate::disk_backed::Spilled;
use std::io;
use std::ops::Range;

/// Solutions in time order, stored last first.
#[derive(Debug, Default)]
pub struct Solutions {
    last_first: Spilled<Solution>,
}

impl Solutions {
    /// Empty, to be filled from the last epoch to the first.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the solution just before the earliest one held.
    pub fn push_earlier(&mut self, s: Solution) {
        self.last_first.push(s);
    }

    pub fn len(&self) -> usize {
        self.last_first.len()
    }

    pub fn is_empty(&self) -> bool {
        self.last_first.is_empty()
    }

    /// Whether their temporary file is read and written past the system's cache.
    pub fn is_direct(&self) -> bool {
        self.last_first.is_direct()
    }

    /// Why they could not go to a temporary file (they are then all in memory).
    pub fn spill_failure(&self) -> Option<String> {
        self.last_first.spill_failure()
    }

    /// Solutions `range` (time order).
    pub fn read(&self, range: Range<usize>) -> io::Result<Vec<Solution>> {
        let n = self.len();
        let flipped = n.checked_sub(range.end).zip(n.checked_sub(range.start));
        let (start, end) = flipped.ok_or(io::ErrorKind::InvalidInput)?;
        let mut out = self.last_first.read(start..end)?;
        out.reverse();
        Ok(out)
    }

    pub fn first(&self) -> io::Result<Option<Solution>> {
        self.last_first.last()
    }

    pub fn last(&self) -> io::Result<Option<Solution>> {
        (!self.is_empty())
            .then(|| self.last_first.get(0))
            .transpose()
    }

    /// Every solution in time order, a block read at a time.
    pub fn iter(&self) -> impl Iterator<Item = io::Result<Solution>> + '_ {
        self.last_first.iter_rev()
    }

    /// Every solution in memory (short runs, tests).
    pub fn to_vec(&self) -> io::Result<Vec<Solution>> {
        self.read(0..self.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filters::ins::record::{NavPoint, PackedCov};

    fn solution(k: usize) -> Solution {
        let mut nav = crate::filters::ins::mechanization::NavState {
            lat_rad: 0.6,
            lon_rad: 2.2,
            height_m: -(k as f64),
            vel_ned_m_s: nalgebra::Vector3::zeros(),
            ned_from_body: nalgebra::UnitQuaternion::identity(),
        };
        nav.vel_ned_m_s.x = k as f64 * 0.1;
        let point = NavPoint {
            nav,
            gyro_bias: nalgebra::Vector3::zeros(),
            accel_bias: nalgebra::Vector3::zeros(),
            dvl: crate::filters::ins::error_state::DvlCalibration::zeros(),
            water: crate::filters::ins::error_state::WaterState::zeros(),
            gyro_scale_z: 0.0,
            sound_speed_scale: 0.0,
        };
        let cov = crate::filters::ins::error_state::ErrorMatrix::identity() * (k as f64 + 1.0);
        Solution::new(k as i64 * 100, point, &PackedCov::pack(&cov))
    }

    #[test]
    fn filled_last_first_and_read_in_time_order_across_blocks() {
        let all: Vec<Solution> = (0..40).map(solution).collect();
        let mut s = Solutions {
            last_first: Spilled::with_block(6),
        };
        for x in all.iter().rev() {
            s.push_earlier(*x);
        }
        assert!(s.last_first.on_file() > 0, "the test must cross the file");
        assert_eq!(s.len(), 40);
        assert_eq!(s.to_vec().unwrap(), all);
        assert_eq!(s.read(3..17).unwrap(), all[3..17]);
        assert_eq!(s.first().unwrap(), Some(all[0]));
        assert_eq!(s.last().unwrap(), Some(all[39]));
        let iterated: Vec<Solution> = s.iter().map(Result::unwrap).collect();
        assert_eq!(iterated, all);
        assert_eq!(Solutions::new().last().unwrap(), None);
        assert!(s.read(30..41).is_err());
    }
}
