//! Seed 000's model-aided velocity for a reconstruction: the vehicle file, the attitude of a
//! first forward pass that drives the model, the filter's run, and the check that the model
//! fits the vehicle before its velocities are trusted.

use super::alignment::start::Initialisation;
use super::config::{ModelMethod, ModelVelocityConfig};
use super::AttitudeTrack;
use super::Streams;
use crate::filters::ins::aid_sources::{
    Borrowed, ModelVelocityAid, ModelVelocitySelection, ModelVelocityUse,
};
use crate::filters::ins::aid_table::{Aid, AidTable};
use crate::filters::ins::driver::{
    run_forward, ForwardRun, Inputs, Keep, NavAt, Running, Settings,
};
use crate::filters::velocity::model_aided::{
    self, AttitudeAt, AttitudeSource, BodyVelocityReading, Mode, ModelAidedFilter, ModelRun,
    ModelVelocity,
};
use crate::growing_series::{Closer, Feed};
use crate::ingest::Mission;
use crate::vehicle::six_dof::description::{Vehicle, BUILT_IN};
use crate::vehicle::six_dof::model::SixDof;
use std::sync::Arc;

/// A vehicle the configuration names cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("vehicle `{name}`: {reason}")]
pub struct VehicleError {
    pub name: String,
    pub reason: String,
}

/// The built-in names, for messages.
pub fn built_in_names() -> String {
    BUILT_IN
        .iter()
        .map(|(n, _)| *n)
        .collect::<Vec<_>>()
        .join(", ")
}

/// A vehicle file's text, as the vehicle it describes (the caller read the file).
pub fn parse_vehicle_file(name: &str, text: &str) -> Result<Vehicle, VehicleError> {
    Vehicle::from_json(text).map_err(|e| VehicleError {
        name: name.to_string(),
        reason: e.to_string(),
    })
}

/// The model of a built-in vehicle by name, else of the vehicle file read for it (`file`).
pub fn vehicle_model(name: &str, file: Option<&Vehicle>) -> Result<SixDof, VehicleError> {
    let bad = |reason: String| VehicleError {
        name: name.to_string(),
        reason,
    };
    let vehicle = match (Vehicle::built_in(name), file) {
        (Some(v), _) => v.map_err(|e| bad(e.to_string()))?,
        (None, Some(v)) => v.clone(),
        (None, None) => {
            return Err(bad(format!(
                "not a built-in vehicle ({}), and no vehicle file was read for it",
                built_in_names()
            )))
        }
    };
    SixDof::new(vehicle).ok_or_else(|| bad("the mass matrix is singular".into()))
}

/// The model for the aid: the configuration's vehicle (an error when it cannot be read), else
/// the mission's when built in, else `Ok(Err(why))`.
pub(crate) fn model_for(
    config: &ModelVelocityConfig,
    mission: &Mission,
) -> Result<Result<SixDof, String>, VehicleError> {
    if !config.vehicle.is_empty() {
        return vehicle_model(&config.vehicle, config.vehicle_file.as_ref()).map(Ok);
    }
    Ok(match Vehicle::built_in(&mission.vehicle) {
        Some(_) => vehicle_model(&mission.vehicle, None).map_err(|e| e.to_string()),
        None => Err(format!(
            "the mission's vehicle `{}` is not built in ({}): give a vehicle file as \
             model_velocity.vehicle",
            mission.vehicle,
            built_in_names()
        )),
    })
}

/// The attitude of a forward pass's epochs.
pub(crate) fn attitude_track(navigation: &[NavAt]) -> Vec<AttitudeAt> {
    navigation
        .iter()
        .map(|n| AttitudeAt {
            stamp_ns: n.stamp_ns,
            ned_from_body: n.nav.ned_from_body,
            lat_rad: n.nav.lat_rad,
        })
        .collect()
}

/// Log time a pass runs between two hand-overs (the attitude pass's attitude to the model's
/// filter, the model's velocities to the navigation pass), ns.
const STRETCH_NS: i64 = 10_000_000_000;

/// The model's aid and the attitude that drove it: the track handed in, else the attitude of a
/// forward pass without the aid, run on a thread beside the model's filter (which waits for
/// the attitude it needs) rather than before it.
pub(crate) fn aid_beside_attitude<A>(
    shared: Option<AttitudeTrack>,
    settings: &Settings,
    inputs: &Inputs<'_>,
    init: &Initialisation,
    aid: impl FnOnce(&dyn AttitudeSource) -> A,
) -> (A, AttitudeTrack) {
    if let Some(track) = shared {
        return (aid(&*track), track);
    }
    let feed = Feed::new();
    let made = std::thread::scope(|s| {
        s.spawn(|| attitude_pass(settings, inputs, init, &feed));
        aid(&feed)
    });
    (made, Arc::new(feed.into_items()))
}

/// The attitude of a forward pass from `init` without the model's aid, into `feed` as it goes.
fn attitude_pass(
    settings: &Settings,
    inputs: &Inputs<'_>,
    init: &Initialisation,
    feed: &Feed<AttitudeAt>,
) {
    let _closer = Closer(feed);
    let inputs = Inputs {
        keep: Keep::Navigation,
        ..*inputs
    };
    run_in_stretches(
        settings,
        &inputs,
        init,
        |_| {},
        |running| feed.extend(attitude_track(&running.take_navigation())),
    );
}

/// How the model's velocities are handed to the navigation filter.
fn use_of(config: &ModelVelocityConfig) -> ModelVelocityUse {
    ModelVelocityUse {
        correlation_s: config.correlation_s,
        min_interval_s: config.min_interval_s,
        dvl_timeout_s: config.dvl_timeout_s,
    }
}

/// The model's filter run over the log with `attitude` driving the model, its velocities
/// handed on as they are made; refused (the reason, as the aid's note) when the model cannot
/// run or does not fit the vehicle.
pub(crate) fn run_model(
    model: &SixDof,
    streams: &Streams<'_>,
    attitude: &dyn AttitudeSource,
    dvl_in_range: &[BodyVelocityReading],
    config: &ModelVelocityConfig,
    filter: &ModelAidedFilter,
    hand_on: &mut dyn FnMut(&[ModelVelocity]),
) -> Result<ModelRun, String> {
    let inputs = model_aided::Inputs {
        fins: streams.fins,
        propeller: streams.rpm,
        attitude,
        imu: streams.imu,
        depth: streams.depth,
        eml: streams.eml,
        dvl: dvl_in_range,
    };
    let settings = ModelAidedFilter {
        mode: match config.method {
            ModelMethod::Proposed => Mode::Proposed,
            ModelMethod::VirtualSensor => Mode::VirtualSensor,
        },
        ..*filter
    };
    let run = model_aided::run_handing_on(&settings, model, &inputs, hand_on)
        .map_err(|why| why.to_string())?;
    if let Some(why) = misfit(&run, config.max_nis) {
        return Err(format!(
            "the vehicle model `{}` does not fit this vehicle: {why}; \
             the navigation runs without it",
            model.vehicle.name
        ));
    }
    Ok(run)
}

/// The navigation pass with the model's aid, and what came of the aid.
pub struct BesideModel {
    pub run: ForwardRun,
    /// Why the aid was refused, when it was.
    pub refused: Option<String>,
    /// The attitude that drove the model.
    pub attitude: AttitudeTrack,
}

/// The navigation pass with the model's aid, run beside the filters that make it.
///
/// The attitude pass (on a thread) drives the model's filter (on another), whose velocities
/// the pass takes as they come, [`STRETCH_NS`] of log time at a time: each velocity is
/// in the pass's table before the pass reaches its stamp, so the pass is the one a pass after
/// the model would be. The model's misfit check needs its whole run: when it refuses the aid,
/// a pass that took any of its velocities runs again without them.
///
/// `inputs` hold the other aids; `run_model` runs the model's filter ([`run_model`]).
pub(crate) fn pass_beside_model(
    shared: Option<AttitudeTrack>,
    settings: &Settings,
    inputs: &Inputs<'_>,
    init: &Initialisation,
    (dvl_in_range, config): (&[BodyVelocityReading], &ModelVelocityConfig),
    run_model: impl FnOnce(&dyn AttitudeSource, &mut dyn FnMut(&[ModelVelocity])) -> Result<ModelRun, String>
        + Send,
) -> BesideModel {
    let how = use_of(config);
    let made: Feed<ModelVelocity> = Feed::new();
    let aid = ModelVelocityAid::taking(&how);
    let mut table: AidTable<'_> = inputs
        .aids
        .iter()
        .map(|a| Box::new(Borrowed(a.as_ref())) as Box<dyn Aid>)
        .collect();
    table.push(Box::new(Borrowed(&aid)));
    let with_model = Inputs {
        aids: &table,
        ..*inputs
    };
    let quiet = Inputs {
        progress: None,
        ..*inputs
    };
    let (run, (model_run, attitude)) = std::thread::scope(|s| {
        let model = s.spawn(|| {
            let _closer = Closer(&made);
            aid_beside_attitude(shared, settings, &quiet, init, |attitude| {
                run_model(attitude, &mut |v| made.extend(v.iter().copied()))
            })
        });
        let mut selection = ModelVelocitySelection::new(dvl_in_range, &how);
        let mut seen = 0;
        let take_until = |until_ns: i64| {
            made.read_when(
                |v| v.last().is_some_and(|last| last.stamp_ns >= until_ns),
                |v| {
                    aid.take(&v[seen..], &mut selection);
                    seen = v.len();
                },
            )
        };
        let run = run_in_stretches(settings, &with_model, init, take_until, |_| {});
        let made = model
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (run, made)
    });
    let refused = model_run.err();
    let run = match &refused {
        Some(_) if !aid.is_empty() => {
            table.pop();
            table.push(Box::new(ModelVelocityAid::refused(String::new())));
            run_forward(
                settings,
                &Inputs {
                    aids: &table,
                    ..*inputs
                },
                init.estimate,
            )
        }
        _ => run,
    };
    BesideModel {
        run,
        refused,
        attitude,
    }
}

/// A pass from `init` a stretch of [`STRETCH_NS`] of log time at a time: `before(until_ns)`
/// is called before each stretch (and before the start) to put in the readings up to its
/// end, `after` once the stretch is run (to hand on what it made).
fn run_in_stretches(
    settings: &Settings,
    inputs: &Inputs<'_>,
    init: &Initialisation,
    mut before: impl FnMut(i64),
    mut after: impl FnMut(&mut Running<'_>),
) -> ForwardRun {
    let (Some(first), Some(last)) = (inputs.imu.first(), inputs.imu.last()) else {
        return ForwardRun::default();
    };
    before(first.stamp_ns);
    let Some(mut running) = Running::start(settings, inputs, init.estimate) else {
        return ForwardRun::default();
    };
    let mut until_ns = first.stamp_ns;
    while until_ns < last.stamp_ns {
        until_ns = until_ns.saturating_add(STRETCH_NS);
        before(until_ns);
        running.run_until(until_ns);
        after(&mut running);
    }
    running.finish()
}

/// Why the filter's updates say the model does not fit (mean NIS per dimension of the DVL's
/// and the EM log's updates above `max_nis`, or most of them rejected), if they do.
fn misfit(run: &model_aided::ModelRun, max_nis: f64) -> Option<String> {
    [("DVL", &run.dvl), ("EM log", &run.eml)]
        .into_iter()
        .find_map(|(name, t)| {
            let rejected = t.rejected as f64 / t.updates.max(1) as f64;
            let mean = t.mean_per_dim()?;
            (mean > max_nis || rejected > 0.5).then(|| {
                format!(
                    "its {name} updates' mean NIS is {mean:.1} per axis (at most {max_nis} \
                     expected) with {:.0} % rejected",
                    rejected * 100.0
                )
            })
        })
}

#[cfg(test)]
mod vehicle_files {
    use super::*;

    /// The library reads no files: a vehicle that is not built in needs the file its caller
    /// read, and says so without one.
    #[test]
    fn a_vehicle_file_comes_from_the_caller() {
        assert!(vehicle_model("nps-auv-ii", None).is_ok());
        let e = vehicle_model("my-auv.json", None).unwrap_err();
        assert!(e.reason.contains("no vehicle file was read"), "{e}");
        let text = BUILT_IN
            .iter()
            .find(|(n, _)| *n == "remus-100")
            .map(|(_, t)| *t)
            .unwrap();
        let file = parse_vehicle_file("my-auv.json", text).unwrap();
        let model = vehicle_model("my-auv.json", Some(&file)).unwrap();
        assert_eq!(model.vehicle.name, file.name);
        assert!(parse_vehicle_file("bad.json", "{}").is_err());
    }
}
