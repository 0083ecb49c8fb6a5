//! Which topic plays each role of the contract (the IMU, the DVL, ...).
//!
//! A role is named after its default topic without the slash (`imu`, `dvl`, `position_fix`).
//! Its topic is, in this order:
//! 1. the topic named for it (a config or the command line);
//! 2. the contract's default topic, when it holds the role's message type;
//! 3. the one topic that holds the role's message type (a ROS 2 recording's
//!    `/vehicle/imu/data` holding `sensor_msgs/msg/Imu`).
//!
//! Two or more topics of the type, none of them the default, make the role ambiguous: it is
//! refused with the candidates named, never guessed.

use super::log::Stream;
use crate::contract::{all_kinds, MessageKind};
use std::collections::BTreeMap;

/// How a role's topic was chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RoleSource {
    /// Named by the user.
    Named,
    /// The contract's default topic.
    DefaultTopic,
    /// The only topic of the role's message type.
    ByType,
}

/// One role and its topic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RoleChoice {
    /// Role name, e.g. `imu`.
    pub role: &'static str,
    /// Contract schema of the role, e.g. `hindsight.Imu`.
    pub schema_name: &'static str,
    pub topic: String,
    pub source: RoleSource,
}

/// Why a role has no topic.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RoleError {
    #[error("unknown topic role `{role}` (the roles are: {known})")]
    UnknownRole { role: String, known: String },
    #[error(
        "topic role {role}: the log has no topic {topic} (topics of type {schema}: {candidates})"
    )]
    NoSuchTopic {
        role: String,
        topic: String,
        schema: &'static str,
        candidates: String,
    },
    #[error(
        "topic role {role}: topic {topic} holds `{found}`, not a message that maps to {schema}"
    )]
    WrongType {
        role: String,
        topic: String,
        found: String,
        schema: &'static str,
    },
    #[error(
        "topic role {role} is ambiguous: {candidates} all hold {schema} and none is the default \
         topic {default}; name the one to use (role {role})"
    )]
    Ambiguous {
        role: &'static str,
        schema: &'static str,
        default: &'static str,
        candidates: String,
    },
}

/// The role name of a message kind: its default topic without the leading slash.
pub fn role_name(kind: &dyn MessageKind) -> &'static str {
    kind.default_topic().trim_start_matches('/')
}

/// Every role name, in the contract's table order.
pub fn role_names() -> Vec<&'static str> {
    all_kinds().iter().map(|k| role_name(*k)).collect()
}

/// Checks that every role named in `named` (role -> topic) exists.
pub fn check_role_names(named: &BTreeMap<String, String>) -> Result<(), RoleError> {
    let known = role_names();
    match named.keys().find(|r| !known.contains(&r.as_str())) {
        Some(role) => Err(RoleError::UnknownRole {
            role: role.clone(),
            known: known.join(", "),
        }),
        None => Ok(()),
    }
}

/// Resolves every role over the decoded `streams`. Roles with no topic are absent from the
/// result; every role that cannot be resolved is returned as a problem.
pub fn resolve(
    streams: &[Stream],
    named: &BTreeMap<String, String>,
) -> (Vec<RoleChoice>, Vec<RoleError>) {
    let (mut choices, mut problems) = (Vec::new(), Vec::new());
    if let Err(e) = check_role_names(named) {
        problems.push(e);
    }
    for kind in all_kinds() {
        match resolve_one(*kind, streams, named) {
            Ok(Some(choice)) => choices.push(choice),
            Ok(None) => {}
            Err(e) => problems.push(e),
        }
    }
    (choices, problems)
}

fn resolve_one(
    kind: &dyn MessageKind,
    streams: &[Stream],
    named: &BTreeMap<String, String>,
) -> Result<Option<RoleChoice>, RoleError> {
    let role = role_name(kind);
    let schema = kind.schema_name();
    let of_type: Vec<&Stream> = streams
        .iter()
        .filter(|s| s.samples.schema_name() == schema)
        .collect();
    let choice = |topic: &str, source| RoleChoice {
        role,
        schema_name: schema,
        topic: topic.to_string(),
        source,
    };
    if let Some(topic) = named.get(role) {
        return match streams.iter().find(|s| &s.topic == topic) {
            Some(s) if s.samples.schema_name() == schema => {
                Ok(Some(choice(topic, RoleSource::Named)))
            }
            Some(s) => Err(RoleError::WrongType {
                role: role.to_string(),
                topic: topic.clone(),
                found: s.schema_name.clone(),
                schema,
            }),
            None => Err(RoleError::NoSuchTopic {
                role: role.to_string(),
                topic: topic.clone(),
                schema,
                candidates: list_or_none(&of_type),
            }),
        };
    }
    if of_type.iter().any(|s| s.topic == kind.default_topic()) {
        return Ok(Some(choice(kind.default_topic(), RoleSource::DefaultTopic)));
    }
    match of_type.as_slice() {
        [] => Ok(None),
        [only] => Ok(Some(choice(&only.topic, RoleSource::ByType))),
        many => Err(RoleError::Ambiguous {
            role,
            schema,
            default: kind.default_topic(),
            candidates: list_or_none(many),
        }),
    }
}

fn list_or_none(streams: &[&Stream]) -> String {
    if streams.is_empty() {
        return "none".into();
    }
    streams
        .iter()
        .map(|s| format!("{} ({})", s.topic, s.schema_name))
        .collect::<Vec<_>>()
        .join(", ")
}
