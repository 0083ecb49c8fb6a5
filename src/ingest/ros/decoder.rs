//! The decoder of one ROS topic: its schema text parsed, a plan compiled for the fields its
//! type's mapping reads (CDR for ROS 2, ROS 1's serialisation for ROS 1), each message
//! converted to the contract's and checked.

use super::cdr::{Picked, Plan, PlanError};
use super::map::{convert, Convention, Converted, RosSettings, RosType, FRAME};
use super::msg::{full_name, parse_as, Dialect, SchemaError};
use crate::contract::FieldIssue;
use crate::ingest::decode::{push_validated as push, Decoder};
use crate::ingest::samples::Samples;
use std::collections::BTreeMap;

/// Why a ROS topic cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RosSchemaError {
    #[error("schema text: {0}")]
    Schema(#[from] SchemaError),
    #[error("{0}")]
    Plan(#[from] PlanError),
    #[error("the schema of {ty} has no field `{field}`")]
    MissingField { ty: &'static str, field: String },
}

/// A topic and the topics named for roles (role -> topic).
#[derive(Debug, Clone, Copy)]
pub struct TopicRoles<'a> {
    pub topic: &'a str,
    pub named: &'a BTreeMap<String, String>,
}

/// Reads one topic of a standard ROS type.
#[derive(Debug, Clone)]
pub struct RosDecoder {
    ty: RosType,
    dialect: Dialect,
    plan: Plan,
    /// How many numbers the plan keeps (the stamp and the type's fields).
    numbers: usize,
    convention: Option<Convention>,
    settings: RosSettings,
}

impl RosDecoder {
    /// The decoder of a topic of the given ROS whose schema is `schema_name` with
    /// `schema_text`, if its type is one hindsight reads (`Ok(None)` otherwise), read in
    /// the type's usual role.
    pub fn for_schema_in(
        dialect: Dialect,
        schema_name: &str,
        schema_text: &str,
        convention: Option<Convention>,
        settings: RosSettings,
    ) -> Result<Option<RosDecoder>, RosSchemaError> {
        let usual = BTreeMap::new();
        let topic = TopicRoles {
            topic: "",
            named: &usual,
        };
        Self::for_topic_in(
            dialect,
            schema_name,
            schema_text,
            topic,
            convention,
            settings,
        )
    }

    /// [`RosDecoder::for_schema_in`] for `topic`: a type that serves more than one role is
    /// read in the one the topic plays (see [`RosType::on_topic`]).
    pub fn for_topic_in(
        dialect: Dialect,
        schema_name: &str,
        schema_text: &str,
        topic: TopicRoles<'_>,
        convention: Option<Convention>,
        settings: RosSettings,
    ) -> Result<Option<RosDecoder>, RosSchemaError> {
        let Some(ty) = full_name(schema_name).and_then(|n| RosType::of(&n)) else {
            return Ok(None);
        };
        let ty = ty.on_topic(topic.topic, topic.named);
        let defs = parse_as(dialect, schema_name, schema_text)?;
        let numbers = ty.numbers();
        let plan = Plan::new(&defs, &numbers, &FRAME)?;
        if let Some(i) =
            (0..numbers.len()).find(|&i| !plan.has_number(i) && !ty.may_lack(numbers[i]))
        {
            return Err(RosSchemaError::MissingField {
                ty: ty.name(),
                field: numbers[i].to_string(),
            });
        }
        Ok(Some(RosDecoder {
            ty,
            dialect,
            plan,
            numbers: numbers.len(),
            convention,
            settings,
        }))
    }

    /// The ROS type read.
    pub fn ros_type(&self) -> RosType {
        self.ty
    }

    /// The contract message of one serialised message.
    pub fn convert(&self, data: &[u8]) -> Result<Converted, FieldIssue> {
        let mut picked = Picked::new();
        self.plan
            .read_into(data, &mut picked)
            .map_err(|e| FieldIssue::new("(message)", e.to_string()))?;
        let frame = if self.plan.has_string(0) {
            picked.text[0]
        } else {
            ""
        };
        convert(
            self.ty,
            &picked.number[..self.numbers],
            (picked.integer[0], picked.integer[1]),
            frame,
            self.convention,
            &self.settings,
        )
    }
}

impl Decoder for RosDecoder {
    fn schema_name(&self) -> &str {
        self.ty.name()
    }
    fn message_encoding(&self) -> &str {
        match self.dialect {
            Dialect::Ros1 => "ros1",
            Dialect::Ros2 => "cdr",
        }
    }
    fn new_samples(&self) -> Box<dyn Samples> {
        use crate::contract::*;
        match self.ty {
            RosType::Imu => Box::new(Vec::<Imu>::new()),
            RosType::MagneticField => Box::new(Vec::<MagneticField>::new()),
            RosType::NavSatFix => Box::new(Vec::<GnssFix>::new()),
            RosType::FluidPressure => Box::new(Vec::<Depth>::new()),
            RosType::Range => Box::new(Vec::<Altimeter>::new()),
            RosType::TwistWithCovarianceStamped => Box::new(Vec::<Dvl>::new()),
            RosType::QuaternionStamped => Box::new(Vec::<Attitude>::new()),
            RosType::PointStamped => Box::new(Vec::<PositionFix>::new()),
            RosType::AcousticDvl | RosType::WaterLinkedDvl | RosType::UuvDvl => {
                Box::new(Vec::<Dvl>::new())
            }
            RosType::Odometry => Box::new(Vec::<Truth>::new()),
            RosType::GeoPointStamped | RosType::GeoPoseStamped | RosType::AcousticNavSatFix => {
                Box::new(Vec::<AcousticFix>::new())
            }
            RosType::ShipGeoPose => Box::new(Vec::<ShipPose>::new()),
            RosType::PoseWithCovarianceStamped => Box::new(Vec::<PositionFix>::new()),
            RosType::EvologicsUsblLong => Box::new(Vec::<UsblObservation>::new()),
        }
    }
    fn decode_into(&self, data: &[u8], out: &mut dyn Samples) -> Result<(), FieldIssue> {
        match self.convert(data)? {
            Converted::Imu(m) => push(out, m),
            Converted::MagneticField(m) => push(out, m),
            Converted::GnssFix(m) => push(out, m),
            Converted::Depth(m) => push(out, m),
            Converted::Altimeter(m) => push(out, m),
            Converted::Dvl(m) => push(out, m),
            Converted::Attitude(m) => push(out, m),
            Converted::PositionFix(m) => push(out, m),
            Converted::Truth(m) => push(out, m),
            Converted::AcousticFix(m) => push(out, m),
            Converted::ShipPose(m) => push(out, m),
            Converted::Usbl(m) => push(out, m),
        }
    }
}
