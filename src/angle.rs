//! Angles on the circle: wrapping and interpolation.

use std::f64::consts::{PI, TAU};

/// Wraps an angle to (-pi, pi].
pub fn wrap_pi(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(TAU) - PI;
    if w <= -PI {
        w + TAU
    } else {
        w
    }
}

/// Interpolates from `a` to `b` along the shorter arc; `frac` in [0, 1]. Result in (-pi, pi].
pub fn lerp_angle(a: f64, b: f64, frac: f64) -> f64 {
    wrap_pi(a + frac * wrap_pi(b - a))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_into_half_open_interval() {
        assert!((wrap_pi(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_pi(-PI) - PI).abs() < 1e-12);
        assert!((wrap_pi(0.5) - 0.5).abs() < 1e-15);
        assert!((wrap_pi(-7.0) - (-7.0 + TAU)).abs() < 1e-12);
    }

    #[test]
    fn interpolates_across_the_seam() {
        let a = PI - 0.1;
        let b = -PI + 0.1;
        assert!((lerp_angle(a, b, 0.5) - PI).abs() < 1e-12);
        assert!((lerp_angle(a, b, 0.25) - (PI - 0.05)).abs() < 1e-12);
    }
}
