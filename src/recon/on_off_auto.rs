//! `Switch`: a part of the reconstruction that the configuration turns on or off, or leaves
//! to the plan (`"auto"`, decided from the log: [`super::plan`]).

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// On, off, or decided from the log. In TOML: `true`, `false` or `"auto"`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Switch {
    /// The plan decides from the log (a reconstruction run without a plan leaves it off).
    #[default]
    Auto,
    On,
    Off,
}

impl Switch {
    /// On (the plan's decision made, or the user's).
    pub fn is_on(self) -> bool {
        self == Switch::On
    }

    /// What the user said, when they said it.
    pub fn given(self) -> Option<bool> {
        match self {
            Switch::Auto => None,
            Switch::On => Some(true),
            Switch::Off => Some(false),
        }
    }

    pub fn from_bool(on: bool) -> Switch {
        if on {
            Switch::On
        } else {
            Switch::Off
        }
    }
}

impl Serialize for Switch {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self.given() {
            Some(on) => s.serialize_bool(on),
            None => s.serialize_str("auto"),
        }
    }
}

impl<'de> Deserialize<'de> for Switch {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Switch, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Given {
            Bool(bool),
            Text(String),
        }
        match Given::deserialize(d)? {
            Given::Bool(on) => Ok(Switch::from_bool(on)),
            Given::Text(t) if t == "auto" => Ok(Switch::Auto),
            Given::Text(t) => Err(serde::de::Error::custom(format!(
                "`{t}`: expected true, false or \"auto\""
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize, Serialize, PartialEq)]
    struct S {
        x: Switch,
    }

    #[test]
    fn a_switch_reads_true_false_and_auto_and_refuses_anything_else() {
        for (text, want, json) in [
            ("x = true", Switch::On, r#"{"x":true}"#),
            ("x = false", Switch::Off, r#"{"x":false}"#),
            ("x = \"auto\"", Switch::Auto, r#"{"x":"auto"}"#),
        ] {
            let s: S = toml::from_str(text).unwrap();
            assert_eq!(s.x, want);
            assert_eq!(serde_json::to_string(&s).unwrap(), json);
        }
        let e = toml::from_str::<S>("x = \"maybe\"").unwrap_err();
        assert!(e.to_string().contains("auto"), "{e}");
    }
}
