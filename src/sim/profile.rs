//! Smooth scalar channels for truth trajectories: constant levels joined by smootherstep
//! transitions, `v(t) = a + (b - a) s((t - t0) / T)` with `s(x) = 6x^5 - 15x^4 + 10x^3`.
//!
//! `s` has zero first and second derivatives at both ends, so a channel is twice
//! continuously differentiable: a speed channel gives continuous acceleration, a turn-rate or
//! pitch channel continuous angular acceleration. Values, first and second derivatives and
//! the running integral are all analytic (no numerical differentiation anywhere).

/// One transition of a channel.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Transition {
    start_s: f64,
    duration_s: f64,
    from: f64,
    to: f64,
}

/// A channel: an initial level and transitions in time order, none overlapping.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    initial: f64,
    transitions: Vec<Transition>,
}

/// Value and derivatives of a channel at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    pub value: f64,
    pub rate: f64,
    pub accel: f64,
}

fn smootherstep(x: f64) -> (f64, f64, f64) {
    let x = x.clamp(0.0, 1.0);
    let x2 = x * x;
    let x3 = x2 * x;
    (
        x3 * (10.0 - 15.0 * x + 6.0 * x2),
        30.0 * x2 * (1.0 - 2.0 * x + x2),
        60.0 * x * (1.0 - 3.0 * x + 2.0 * x2),
    )
}

/// Integral of smootherstep from 0 to x (x in [0, 1]): x^6 - 3x^5 + 2.5x^4.
fn smootherstep_integral(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    let x4 = x.powi(4);
    x4 * (2.5 - 3.0 * x + x * x)
}

impl Profile {
    /// A channel that starts at `initial`.
    pub fn new(initial: f64) -> Self {
        Profile {
            initial,
            transitions: Vec::new(),
        }
    }

    /// The level after the last transition.
    pub fn final_value(&self) -> f64 {
        self.transitions.last().map_or(self.initial, |t| t.to)
    }

    /// Time at which the last transition ends (0 if none).
    pub fn end_s(&self) -> f64 {
        self.transitions
            .last()
            .map_or(0.0, |t| t.start_s + t.duration_s)
    }

    /// Moves smoothly to `to` over `[start_s, start_s + duration_s]`. Transitions must be
    /// added in time order without overlap; a zero duration is not allowed.
    pub fn ramp(&mut self, start_s: f64, duration_s: f64, to: f64) {
        assert!(duration_s > 0.0, "a transition needs a positive duration");
        assert!(
            start_s >= self.end_s() - 1e-9,
            "transitions must not overlap"
        );
        let from = self.final_value();
        self.transitions.push(Transition {
            start_s,
            duration_s,
            from,
            to,
        });
    }

    /// Value, rate and acceleration at `t_s`.
    pub fn at(&self, t_s: f64) -> Sample {
        let mut level = self.initial;
        for tr in &self.transitions {
            if t_s < tr.start_s {
                break;
            }
            if t_s < tr.start_s + tr.duration_s {
                let (s, ds, dds) = smootherstep((t_s - tr.start_s) / tr.duration_s);
                let span = tr.to - tr.from;
                return Sample {
                    value: tr.from + span * s,
                    rate: span * ds / tr.duration_s,
                    accel: span * dds / (tr.duration_s * tr.duration_s),
                };
            }
            level = tr.to;
        }
        Sample {
            value: level,
            rate: 0.0,
            accel: 0.0,
        }
    }

    /// Integral of the channel from 0 to `t_s`.
    pub fn integral(&self, t_s: f64) -> f64 {
        let mut total = 0.0;
        let mut level = self.initial;
        let mut since = 0.0;
        for tr in &self.transitions {
            if t_s <= tr.start_s {
                break;
            }
            total += level * (tr.start_s - since);
            let x = ((t_s - tr.start_s) / tr.duration_s).min(1.0);
            total += tr.duration_s * (tr.from * x + (tr.to - tr.from) * smootherstep_integral(x));
            level = tr.to;
            since = tr.start_s + tr.duration_s;
            if t_s < since {
                return total;
            }
        }
        total + level * (t_s - since)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile() -> Profile {
        let mut p = Profile::new(1.0);
        p.ramp(10.0, 20.0, -0.5);
        p.ramp(40.0, 5.0, 2.0);
        p
    }

    #[test]
    fn derivatives_match_finite_differences_and_are_continuous() {
        let p = profile();
        // Small steps: at a joint the third derivative jumps, so a central difference of the
        // rate is off by O(h) there.
        let h = 1e-6;
        for k in 0..6000 {
            let t = k as f64 * 0.01;
            let (a, b) = (p.at(t - h), p.at(t + h));
            let s = p.at(t);
            assert!(
                (s.rate - (b.value - a.value) / (2.0 * h)).abs() < 1e-6,
                "rate at {t}"
            );
            assert!(
                (s.accel - (b.rate - a.rate) / (2.0 * h)).abs() < 1e-5,
                "accel at {t}"
            );
        }
        // C2 at the joints: value, rate and acceleration agree from both sides.
        for joint in [10.0, 30.0, 40.0, 45.0] {
            let (l, r) = (p.at(joint - 1e-9), p.at(joint + 1e-9));
            assert!(
                (l.value - r.value).abs() < 1e-7
                    && (l.rate - r.rate).abs() < 1e-6
                    && (l.accel - r.accel).abs() < 1e-5
            );
        }
        assert_eq!(p.at(100.0).value, 2.0);
        assert_eq!(p.final_value(), 2.0);
    }

    #[test]
    fn integral_matches_quadrature() {
        let p = profile();
        let mut sum = 0.0;
        let dt = 1e-3;
        for k in 0..60_000 {
            let t = (k as f64 + 0.5) * dt;
            sum += p.at(t).value * dt;
            if k % 5000 == 4999 {
                let t_end = (k + 1) as f64 * dt;
                assert!(
                    (p.integral(t_end) - sum).abs() < 1e-6,
                    "at {t_end}: {} vs {sum}",
                    p.integral(t_end)
                );
            }
        }
    }
}
