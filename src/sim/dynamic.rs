//! Truth from the vehicle's dynamics: the 6-DOF model flown by its autopilot through a
//! plan, RK4 at the IMU's rate, with Earth's rotation in the rigid-body terms.
//!
//! The model's world frame is the local NED frame; its position is carried on WGS-84 from
//! the step's NED displacement, so the synthesised IMU (from the model's attitude, body
//! rate and acceleration) is exactly consistent with the logged truth whatever the model.

use super::inertial::Motion;
use super::scenario::{Scenario, ScenarioError};
use super::truth::{TruthSample, TruthSource};
use crate::geodesy;
use crate::vehicle::six_dof::description::{Vehicle, BUILT_IN};
use crate::vehicle::six_dof::flight_plan::{start_state, Plan, PlanError, PlanPilot, Reference};
use crate::vehicle::six_dof::model::SixDof;
use crate::vehicle::six_dof::motion::{
    actuator_rates, rates, step_from, Actuators, MotionState, Rates,
};
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// Where and how a dynamic run starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DynamicStart {
    /// Latitude, longitude, rad; depth, m.
    pub lat_rad: f64,
    pub lon_rad: f64,
    pub depth_m: f64,
    /// Roll, pitch, yaw, rad.
    pub euler_rad: [f64; 3],
    pub speed_m_s: f64,
}

/// The model, its pilot and its state, stepped on a fixed grid.
pub struct DynamicTruth {
    model: SixDof,
    pilot: PlanPilot,
    state: MotionState,
    /// Latitude, longitude (rad), height (m).
    geodetic: Vector3<f64>,
    t_s: f64,
    dt_s: f64,
    duration_s: f64,
    reference: Option<Reference>,
    /// The current state's rates, when `sample` evaluated them (reused by the next step).
    sampled: Option<Rates>,
}

impl DynamicTruth {
    /// `dt_s`: the integration step (the IMU's sampling interval).
    pub fn new(
        model: SixDof,
        plan: Plan,
        start: DynamicStart,
        dt_s: f64,
    ) -> Result<DynamicTruth, PlanError> {
        let [roll, pitch, yaw] = start.euler_rad;
        let position_m = Vector3::new(0.0, 0.0, start.depth_m);
        let mut state = start_state(position_m, roll, pitch, yaw, start.speed_m_s, 0.0);
        let duration_s = plan.duration_s();
        let pilot = PlanPilot::new(&model, plan, &state)?;
        state.actuators.propeller_rad_s = pilot.cruise_propeller_rad_s();
        Ok(DynamicTruth {
            model,
            pilot,
            state,
            geodetic: Vector3::new(start.lat_rad, start.lon_rad, -start.depth_m),
            t_s: 0.0,
            dt_s,
            duration_s,
            reference: None,
            sampled: None,
        })
    }

    /// The vehicle's state now.
    pub fn state(&self) -> &MotionState {
        &self.state
    }

    /// What the autopilot followed over the last step (`None` before the first).
    pub fn reference(&self) -> Option<Reference> {
        self.reference
    }

    pub fn pilot(&self) -> &PlanPilot {
        &self.pilot
    }

    /// One step of `dt_s`.
    fn advance(&mut self) {
        let (command, reference) =
            self.pilot
                .command(&self.model, self.t_s, &self.state, self.dt_s);
        let earth = geodesy::earth_rate_ned(self.geodetic.x);
        // RK4's first stage: the state's rates as sampled, with the actuators moving toward
        // this step's command.
        let k1 = match self.sampled.take() {
            Some(r) => Rates {
                actuators: actuator_rates(&self.model, &self.state.actuators, &command),
                ..r
            },
            None => rates(&self.model, &self.state, &command, &earth),
        };
        let next = step_from(&self.model, &self.state, &k1, &command, &earth, self.dt_s);
        let mean_vel_ned = (next.position_m - self.state.position_m) / self.dt_s;
        self.geodetic +=
            geodesy::position_rates(self.geodetic.x, self.geodetic.z, &mean_vel_ned) * self.dt_s;
        self.state = next;
        self.t_s += self.dt_s;
        self.reference = Some(reference);
    }
}

impl TruthSource for DynamicTruth {
    fn duration_s(&self) -> f64 {
        self.duration_s
    }

    fn sample(&mut self, t_s: f64) -> TruthSample {
        while self.t_s + 0.5 * self.dt_s < t_s {
            self.advance();
        }
        let s = &self.state;
        let earth = geodesy::earth_rate_ned(self.geodetic.x);
        // The body accelerations do not depend on the fin commands, only on their state;
        // kept for the next step's first stage.
        let at_sample = rates(&self.model, s, &Actuators::default(), &earth);
        self.sampled = Some(at_sample);
        let nu_dot = at_sample.nu;
        let v_body = Vector3::new(s.nu[0], s.nu[1], s.nu[2]);
        let omega = Vector3::new(s.nu[3], s.nu[4], s.nu[5]);
        let v_body_dot = Vector3::new(nu_dot[0], nu_dot[1], nu_dot[2]);
        let ned_from_body = s.ned_from_body.to_rotation_matrix();
        let (roll, pitch, yaw) = s.euler();
        TruthSample {
            lat_rad: self.geodetic.x,
            lon_rad: self.geodetic.y,
            height_m: self.geodetic.z,
            motion: Motion::from_body(ned_from_body, v_body, v_body_dot, omega),
            euler_rad: [roll, pitch, yaw],
            speed_m_s: s.nu[0],
            actuators: Some(s.actuators),
        }
    }
}

/// A dynamic scenario ready to fly.
pub struct Flight {
    pub truth: DynamicTruth,
    /// The log's `vehicle_truth` metadata record: the vehicle file, the uncertainty, each
    /// drawn factor (`factor.NAME`) and each true coefficient (`true.NAME`, SI).
    pub vehicle_record: BTreeMap<String, String>,
}

/// The flight of a scenario with `[dynamics]` (`None` for a kinematic one).
pub fn from_scenario(
    scenario: &Scenario,
    seed: u64,
    dt_s: f64,
) -> Result<Option<Flight>, ScenarioError> {
    let Some(d) = &scenario.dynamics else {
        return Ok(None);
    };
    let bad = |reason: String| ScenarioError::Invalid {
        name: scenario.name.clone(),
        reason,
    };
    let nominal = match &d.vehicle_json {
        Some(text) => Vehicle::from_json(text),
        None => Vehicle::built_in(&d.vehicle).ok_or_else(|| {
            let known: Vec<_> = BUILT_IN.iter().map(|(n, _)| *n).collect();
            bad(format!(
                "dynamics.vehicle `{}` is not built in ({}) and was not read as a file",
                d.vehicle,
                known.join(", ")
            ))
        })?,
    }
    .map_err(|e| bad(format!("vehicle `{}`: {e}", d.vehicle)))?;
    let (vehicle, factors) = if d.coef_uncertainty > 0.0 {
        nominal.perturbed(d.coef_uncertainty, seed)
    } else {
        (nominal, Vec::new())
    };
    let mut record = BTreeMap::new();
    record.insert("vehicle".into(), d.vehicle.clone());
    record.insert("name".into(), vehicle.name.clone());
    record.insert("coef_uncertainty".into(), d.coef_uncertainty.to_string());
    record.insert("seed".into(), seed.to_string());
    for (name, k) in &factors {
        record.insert(format!("factor.{name}"), k.to_string());
    }
    for t in &vehicle.terms {
        record.insert(format!("true.{}", t.name), t.coefficient.to_string());
    }
    let model = SixDof::new(vehicle).ok_or_else(|| {
        bad(format!(
            "vehicle `{}`: the mass matrix (rigid body + added mass) is singular",
            d.vehicle
        ))
    })?;
    let origin_lat = scenario.mission.origin_latitude_deg.to_radians();
    let st = &scenario.start;
    let start = DynamicStart {
        lat_rad: origin_lat + st.north_m / geodesy::meridian_radius_m(origin_lat),
        lon_rad: scenario.mission.origin_longitude_deg.to_radians()
            + st.east_m / (geodesy::prime_vertical_radius_m(origin_lat) * origin_lat.cos()),
        depth_m: st.depth_m,
        euler_rad: [
            st.roll_deg.to_radians(),
            st.pitch_deg.to_radians(),
            st.yaw_deg.to_radians(),
        ],
        speed_m_s: st.speed_m_s,
    };
    let plan = Plan::new(
        d.speed_m_s,
        d.max_vertical_rate_m_s,
        d.max_turn_rate_deg_s.to_radians(),
        scenario.phases.clone(),
    );
    let truth = DynamicTruth::new(model, plan, start, dt_s).map_err(|e| bad(e.to_string()))?;
    Ok(Some(Flight {
        truth,
        vehicle_record: record,
    }))
}
