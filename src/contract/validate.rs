//! Plausibility checks on a decoded message: stamp range, finite numbers, field ranges.

use super::{Message, PropValue};
use crate::time;

/// What is wrong with one field of one message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldIssue {
    /// JSON path of the field, e.g. `angular_velocity[1]` or `stamp_ns`.
    pub field: String,
    /// What is wrong, for a person.
    pub reason: String,
}

impl FieldIssue {
    pub fn new(field: impl Into<String>, reason: impl Into<String>) -> Self {
        FieldIssue {
            field: field.into(),
            reason: reason.into(),
        }
    }
}

impl std::fmt::Display for FieldIssue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "field `{}`: {}", self.field, self.reason)
    }
}

/// Checks a decoded message against the contract and hindsight's plausible ranges.
pub fn validate<T: Message>(msg: &T) -> Result<(), FieldIssue> {
    let stamp = msg.stamp_ns();
    if !time::stamp_in_range(stamp) {
        return Err(FieldIssue::new(
            "stamp_ns",
            format!(
                "{stamp} ({}) is outside 1970-01-01..2100-01-01",
                time::format_utc(stamp)
            ),
        ));
    }
    for (index, prop) in T::PROPERTIES.iter().enumerate() {
        let value = msg.get(index);
        let components: &[f64] = match &value {
            PropValue::F64(v) => std::slice::from_ref(v),
            PropValue::Vec3(v) => v,
            PropValue::OptF64(Some(v)) => std::slice::from_ref(v),
            PropValue::OptF64(None) | PropValue::Bool(_) | PropValue::Str(_) => &[],
        };
        for (c, &v) in components.iter().enumerate() {
            let path = || match value {
                PropValue::Vec3(_) => format!("{}[{c}]", prop.name),
                _ => prop.name.to_string(),
            };
            if !v.is_finite() {
                return Err(FieldIssue::new(
                    path(),
                    format!("{v} is not a finite number"),
                ));
            }
            if let Some((min, max)) = prop.range {
                if !(min..=max).contains(&v) {
                    return Err(FieldIssue::new(
                        path(),
                        format!(
                            "{v} {} is outside the plausible range [{min}, {max}]",
                            prop.unit
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::{Dvl, Imu};

    fn imu() -> Imu {
        Imu {
            stamp_ns: 1_700_000_000_000_000_000,
            angular_velocity: [0.01, 0.0, 0.0],
            specific_force: [0.0, 0.0, -9.81],
        }
    }

    #[test]
    fn accepts_plausible_message() {
        assert_eq!(validate(&imu()), Ok(()));
    }

    #[test]
    fn names_the_component_out_of_range() {
        let mut m = imu();
        m.angular_velocity[1] = 500.0;
        let issue = validate(&m).unwrap_err();
        assert_eq!(issue.field, "angular_velocity[1]");
        assert!(issue.reason.contains("plausible range"));
    }

    #[test]
    fn rejects_non_finite_and_bad_stamps() {
        let mut m = imu();
        m.specific_force[2] = f64::NAN;
        assert_eq!(validate(&m).unwrap_err().field, "specific_force[2]");
        let mut m = imu();
        m.stamp_ns = -5;
        assert_eq!(validate(&m).unwrap_err().field, "stamp_ns");
        m.stamp_ns = time::END_STAMP_NS;
        assert_eq!(validate(&m).unwrap_err().field, "stamp_ns");
    }

    #[test]
    fn null_optional_is_fine_but_out_of_range_is_not() {
        let mut d = Dvl {
            stamp_ns: 1,
            velocity: [1.0, 0.0, 0.0],
            valid: true,
            altitude: None,
        };
        assert_eq!(validate(&d), Ok(()));
        d.altitude = Some(-3.0);
        assert_eq!(validate(&d).unwrap_err().field, "altitude");
    }
}
