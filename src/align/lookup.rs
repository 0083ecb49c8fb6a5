//! Look-ups into one time-sorted stream.

use crate::angle::lerp_angle;
use crate::contract::{Message, PropValue};
use crate::ingest::Samples;

/// The messages with `t0_ns < stamp_ns <= t1_ns` (e.g. the IMU samples of one filter step).
pub fn between<T: Message>(messages: &[T], t0_ns: i64, t1_ns: i64) -> &[T] {
    let lo = messages.partition_point(|m| m.stamp_ns() <= t0_ns);
    let hi = messages.partition_point(|m| m.stamp_ns() <= t1_ns);
    &messages[lo..hi.max(lo)]
}

/// Index of the latest message stamped at or before `t_ns`, and its age `t_ns - stamp`.
pub fn latest_index_at(samples: &dyn Samples, t_ns: i64) -> Option<(usize, i64)> {
    let (mut lo, mut hi) = (0usize, samples.len());
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if samples.stamp_ns(mid) <= t_ns {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    let i = lo.checked_sub(1)?;
    Some((i, t_ns - samples.stamp_ns(i)))
}

/// The latest message at or before `t_ns` and its age in nanoseconds.
pub fn latest_at<T: Message>(messages: &[T], t_ns: i64) -> Option<(&T, i64)> {
    let i = messages
        .partition_point(|m| m.stamp_ns() <= t_ns)
        .checked_sub(1)?;
    Some((&messages[i], t_ns - messages[i].stamp_ns()))
}

/// The stream's value at `t_ns`, interpolated between the two messages around it.
///
/// Numbers are interpolated linearly, angles along the shorter arc (wrapped to (-pi, pi]);
/// booleans, strings and nulls hold the earlier message's value. `None` outside the stream's
/// span or when the two messages are more than `max_interval_ns` apart (a gap is not bridged).
pub fn interpolate<T: Message>(messages: &[T], t_ns: i64, max_interval_ns: i64) -> Option<T> {
    let after = messages.partition_point(|m| m.stamp_ns() < t_ns);
    let b = messages.get(after)?;
    if b.stamp_ns() == t_ns {
        return Some(b.clone());
    }
    let a = &messages[after.checked_sub(1)?];
    let span = b.stamp_ns() - a.stamp_ns();
    if span > max_interval_ns {
        return None;
    }
    let frac = (t_ns - a.stamp_ns()) as f64 / span as f64;
    let mut out = a.clone();
    out.set_stamp_ns(t_ns);
    for (p, prop) in T::PROPERTIES.iter().enumerate() {
        let (va, vb) = (a.get(p), b.get(p));
        if matches!(va, PropValue::Bool(_) | PropValue::Str(_)) {
            continue;
        }
        for c in 0..3 {
            if let (Some(x), Some(y)) = (va.component(c), vb.component(c)) {
                let v = if prop.angle {
                    lerp_angle(x, y, frac)
                } else {
                    x + frac * (y - x)
                };
                out.set_component(p, c, v);
            }
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::{Attitude, Dvl, Imu};
    use std::f64::consts::PI;

    fn imu(stamp_ns: i64, x: f64) -> Imu {
        Imu {
            stamp_ns,
            angular_velocity: [x, 0.0, 0.0],
            specific_force: [0.0, 0.0, -9.8],
        }
    }

    #[test]
    fn between_is_half_open() {
        let v: Vec<Imu> = (0..10).map(|i| imu(i * 10, i as f64)).collect();
        let s = between(&v, 20, 50);
        assert_eq!(
            s.iter().map(|m| m.stamp_ns).collect::<Vec<_>>(),
            vec![30, 40, 50]
        );
        assert!(between(&v, 50, 20).is_empty());
        assert_eq!(between(&v, -5, 0).len(), 1);
    }

    #[test]
    fn latest_with_age() {
        let v: Vec<Imu> = (0..3).map(|i| imu(i * 10, 0.0)).collect();
        assert_eq!(
            latest_at(&v, 25).map(|(m, age)| (m.stamp_ns, age)),
            Some((20, 5))
        );
        assert_eq!(
            latest_at(&v, 20).map(|(m, age)| (m.stamp_ns, age)),
            Some((20, 0))
        );
        assert!(latest_at(&v, -1).is_none());
        let dynv: &dyn Samples = &v;
        assert_eq!(latest_index_at(dynv, 25), Some((2, 5)));
        assert_eq!(latest_index_at(dynv, 9), Some((0, 9)));
        assert_eq!(latest_index_at(dynv, -1), None);
    }

    #[test]
    fn interpolates_numbers_and_angles() {
        let v = vec![imu(0, 1.0), imu(100, 3.0)];
        let m = interpolate(&v, 25, 1000).unwrap();
        assert_eq!(m.stamp_ns, 25);
        assert!((m.angular_velocity[0] - 1.5).abs() < 1e-12);
        assert!(interpolate(&v, 101, 1000).is_none());
        assert!(interpolate(&v, -1, 1000).is_none());
        assert!(interpolate(&v, 50, 99).is_none(), "gap not bridged");

        let a = vec![
            Attitude {
                stamp_ns: 0,
                roll: 0.0,
                pitch: 0.0,
                yaw: PI - 0.1,
            },
            Attitude {
                stamp_ns: 10,
                roll: 0.2,
                pitch: 0.0,
                yaw: -PI + 0.1,
            },
        ];
        let m = interpolate(&a, 5, 100).unwrap();
        assert!((m.yaw.abs() - PI).abs() < 1e-12, "{}", m.yaw);
        assert!((m.roll - 0.1).abs() < 1e-12);
    }

    #[test]
    fn holds_booleans_and_nulls() {
        let v = vec![
            Dvl {
                stamp_ns: 0,
                velocity: [1.0, 0.0, 0.0],
                valid: true,
                altitude: Some(10.0),
            },
            Dvl {
                stamp_ns: 10,
                velocity: [2.0, 0.0, 0.0],
                valid: false,
                altitude: None,
            },
        ];
        let m = interpolate(&v, 5, 100).unwrap();
        assert!(m.valid);
        assert_eq!(m.altitude, Some(10.0));
        assert!((m.velocity[0] - 1.5).abs() < 1e-12);
    }
}
