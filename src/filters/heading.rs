//! The heading of a magnetic field vector turned into NED, and its row with respect to a small
//! rotation of the NED frame: the magnetometer's heading measurement that the INS and the
//! attitude filter share.
//!
//! With `m = C b` the field in NED (`C` the attitude, `b` the body reading), the field's
//! heading is `atan2(m_E, m_N)`, which is the declination when `C` is right. A small rotation
//! `psi` of the NED frame (`C' = exp([psi x]) C`) moves `m` by `psi x m = -[m x] psi`, so the
//! heading moves by `a^T (-[m x]) psi` with `a = (-m_E, m_N, 0) / (m_N^2 + m_E^2)`.

use nalgebra::{RowVector3, Vector3};

/// The heading of the field `m_ned` (rad, from north towards east) and its row with respect to
/// a small rotation of the NED frame; `None` when the field has no horizontal part.
pub fn field_heading(m_ned: &Vector3<f64>) -> Option<(f64, RowVector3<f64>)> {
    let horizontal2 = m_ned.x * m_ned.x + m_ned.y * m_ned.y;
    if horizontal2 <= 1e-30 {
        return None;
    }
    let a = Vector3::new(-m_ned.y, m_ned.x, 0.0) / horizontal2;
    Some((
        m_ned.y.atan2(m_ned.x),
        a.transpose() * (-m_ned.cross_matrix()),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::angle::wrap_pi;
    use nalgebra::UnitQuaternion;

    /// The row is the Jacobian of the heading with respect to a small rotation of the NED
    /// frame (central finite differences), at a steep attitude.
    #[test]
    fn row_matches_finite_differences() {
        let q = UnitQuaternion::from_euler_angles(2.8, 0.7, -2.2);
        let field = Vector3::new(1.9e-5, -0.4e-5, 4.4e-5);
        let heading = |q: &UnitQuaternion<f64>| field_heading(&(q * field)).unwrap().0;
        let (_, row) = field_heading(&(q * field)).unwrap();
        for k in 0..3 {
            let mut d = Vector3::zeros();
            d[k] = 1e-7;
            let numeric = wrap_pi(
                heading(&(UnitQuaternion::from_scaled_axis(d) * q))
                    - heading(&(UnitQuaternion::from_scaled_axis(-d) * q)),
            ) / 2e-7;
            assert!(
                (numeric - row[k]).abs() < 1e-6,
                "{k}: {numeric} vs {}",
                row[k]
            );
        }
        assert!(field_heading(&Vector3::new(0.0, 0.0, 4e-5)).is_none());
    }
}
