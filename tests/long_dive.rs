//! Seed 000's pure-SDINS study on the 5.5-hour `long-dive` (Table 1 mission, Table 2 sensors):
//! 20 seeded runs, each started from the truth with Table 2's initial errors drawn with the
//! run's seed. Pure SDINS: the mechanization alone with the uncorrected IMU, its vertical
//! channel held on the depth by a damping loop (unstable without), nothing estimated. The
//! paper reports a horizontal RMS error of about 1.4 km after 5.5 h, with the Schuler
//! oscillation (84 min) visible. Then hindsight's filter on the same runs, with the depth
//! alone (through the vertical channel it estimates part of the level gyro biases over
//! hours) and with the DVL for the first hour (as the scenario has it).
//!
//! Too long for CI (about 4 minutes on 2 cores):
//! `cargo test --release --test all long_dive:: -- --ignored --nocapture`

use crate::common;
use hindsight::align::latest_at;
use hindsight::config::Section;
use hindsight::contract::Truth;
use hindsight::filters::ins::driver::{run_forward, Inputs};
use hindsight::filters::ins::error_state::{self, ErrorMatrix, ErrorState};
use hindsight::filters::ins::forward::Estimate;
use hindsight::filters::ins::mechanization::{propagate, HeightDamping, ImuSample, NavState};
use hindsight::filters::ins::record::{NavPoint, Solution};
use hindsight::recon::config::Config;
use hindsight::recon::score::epoch_error;
use hindsight::recon::{output_stamps, Streams};
use hindsight::sim::scenario::Scenario;
use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;

/// Table 2's sensors as a configuration.
const TABLE_2: &str = include_str!("../configs/long-dive.toml");

/// Table 2's initial errors (1-sigma): position [10, 10, 1] m, velocity 0.1 m/s, attitude
/// [0.01, 0.01, 0.03] arcmin; drawn with the run's seed and added to the truth.
fn initial(t0: &Truth, config: &Config, seed: u64) -> Estimate {
    let arcmin = (1.0f64 / 60.0).to_radians();
    let sigma = [
        10.0,
        10.0,
        1.0,
        0.1,
        0.1,
        0.1,
        0.01 * arcmin,
        0.01 * arcmin,
        0.03 * arcmin,
    ];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1000 + seed);
    let normal = Normal::new(0.0, 1.0).unwrap();
    let mut dx = ErrorState::zeros();
    for (i, s) in sigma.iter().enumerate() {
        dx[i] = s * normal.sample(&mut rng);
    }
    let truth = NavState {
        lat_rad: t0.latitude_deg.to_radians(),
        lon_rad: t0.longitude_deg.to_radians(),
        height_m: -t0.down_m,
        vel_ned_m_s: Vector3::from(t0.velocity_ned),
        ned_from_body: UnitQuaternion::from_euler_angles(
            t0.attitude[0],
            t0.attitude[1],
            t0.attitude[2],
        ),
    };
    let spec = config.imu.spec();
    let mut diag = ErrorState::zeros();
    for (i, s) in sigma.iter().enumerate() {
        diag[i] = s * s;
    }
    for i in 9..12 {
        diag[i] = spec.gyro_bias_rad_s().powi(2);
    }
    for i in 12..15 {
        diag[i] = spec.accel_bias_m_s2().powi(2);
    }
    Estimate {
        // The estimate is the truth moved by the drawn error (truth = estimate (+) dx).
        nav: error_state::inject(&truth, &(-dx)),
        gyro_bias: Vector3::zeros(),
        accel_bias: Vector3::zeros(),
        dvl: Default::default(),
        water: Default::default(),
        gyro_scale_z: 0.0,
        sound_speed_scale: 0.0,
        cov: ErrorMatrix::from_diagonal(&diag),
    }
}

struct Outcome {
    /// Horizontal error at 5.5 h, m: free inertial (pure SDINS), the filter with depth
    /// alone, and the filter with the DVL's first hour.
    pure_m: f64,
    filter_depth_m: f64,
    dvl_hour_m: f64,
    /// (time s, north error m) every 10 s of the free-inertial run and of the filter with
    /// depth alone (the forward solution, as in `errors.parquet`).
    north_error: Vec<(f64, f64)>,
    filter_north_error: Vec<(f64, f64)>,
}

/// Pure SDINS: the mechanization alone from the initial state, IMU uncorrected, the vertical
/// channel held by a critically damped loop on the depth (100 s); nothing is estimated.
/// Returns (time since start s, error north/east/down m) every 10 s.
fn free_inertial(streams: &Streams<'_>, start: &NavState) -> Vec<(f64, Vector3<f64>)> {
    let damping = HeightDamping::critical(0.01);
    let t0 = streams.imu[0].stamp_ns;
    let sample = |m: &hindsight::contract::Imu| ImuSample {
        omega_ib_body: m.angular_velocity.into(),
        specific_force_body: m.specific_force.into(),
    };
    let mut nav = *start;
    let mut out = Vec::new();
    let mut next_out = t0;
    for w in streams.imu.windows(2) {
        let dt = (w[1].stamp_ns - w[0].stamp_ns) as f64 * 1e-9;
        let depth = latest_at(streams.depth, w[1].stamp_ns).map(|(d, _)| -d.depth);
        nav = propagate(
            &nav,
            &sample(&w[0]),
            &sample(&w[1]),
            dt,
            depth.map(|h| (damping, h)),
        );
        if w[1].stamp_ns >= next_out {
            next_out += 10_000_000_000;
            let solution = Solution {
                stamp_ns: w[1].stamp_ns,
                point: NavPoint {
                    nav,
                    gyro_bias: Vector3::zeros(),
                    accel_bias: Vector3::zeros(),
                    dvl: Default::default(),
                    water: Default::default(),
                    gyro_scale_z: 0.0,
                    sound_speed_scale: 0.0,
                },
                sigma: ErrorState::repeat(1.0),
                position_cov: nalgebra::Matrix3::identity(),
                attitude_cov: nalgebra::Matrix3::identity(),
            };
            if let Some(e) = epoch_error(streams.truth, &solution) {
                out.push(((w[1].stamp_ns - t0) as f64 * 1e-9, e.position_m));
            }
        }
    }
    out
}

fn run_seed(scenario: &Scenario, config: &Config, seed: u64) -> Outcome {
    let log = common::simulated_log(scenario, seed);
    let streams = Streams::of(&log);
    let mission = log.mission().unwrap();
    let settings = config.settings();
    let stamps = output_stamps(streams.imu, 0.1);
    let start = initial(&streams.truth[0], config, seed);
    let final_error = |dvl| {
        let used = Streams {
            eml: &[],
            mag: &[],
            gnss: &[],
            fixes: &[],
            dvl,
            ..streams
        };
        let origin_rad = (
            mission.origin_latitude_deg.to_radians(),
            mission.origin_longitude_deg.to_radians(),
        );
        let aids = settings.aiding.table(&used, origin_rad);
        let inputs = Inputs {
            imu: streams.imu,
            aids: &aids,
            output_stamps_ns: &stamps,
            progress: None,
            keep: hindsight::filters::ins::driver::Keep::Records,
        };
        let run = run_forward(&settings, &inputs, start);
        let errors: Vec<_> = run
            .records
            .iter()
            .map(Result::unwrap)
            .filter(|r| r.output)
            .filter_map(|r| epoch_error(streams.truth, &Solution::forward(&r)))
            .collect();
        let t0 = errors[0].stamp_ns;
        let north: Vec<(f64, f64)> = errors
            .iter()
            .step_by(100)
            .map(|e| ((e.stamp_ns - t0) as f64 * 1e-9, e.position_m.x))
            .collect();
        (errors.last().unwrap().horizontal_m(), north)
    };
    let pure = free_inertial(&streams, &start.nav);
    let p = pure.last().unwrap().1;
    let (filter_depth_m, filter_north_error) = final_error(&[]);
    Outcome {
        pure_m: p.x.hypot(p.y),
        filter_depth_m,
        dvl_hour_m: final_error(streams.dvl).0,
        north_error: pure.iter().map(|(t, p)| (*t, p.x)).collect(),
        filter_north_error,
    }
}

/// The period (minutes) of the sinusoid that, with a quadratic trend, best fits `series`:
/// least squares over a grid of periods from 40 to 150 min.
fn dominant_period_min(series: &[(f64, f64)]) -> f64 {
    use nalgebra::{DMatrix, DVector};
    let y = DVector::from_iterator(series.len(), series.iter().map(|s| s.1));
    let scale = series.last().unwrap().0;
    let mut best = (f64::INFINITY, 0.0);
    for period_min in (400..=1500).map(|p| p as f64 / 10.0) {
        let w = std::f64::consts::TAU / (period_min * 60.0);
        let a = DMatrix::from_fn(series.len(), 5, |i, j| {
            let t = series[i].0;
            match j {
                0 => 1.0,
                1 => t / scale,
                2 => (t / scale).powi(2),
                3 => (w * t).sin(),
                _ => (w * t).cos(),
            }
        });
        let x = a.clone().svd(true, true).solve(&y, 1e-12).unwrap();
        let residual = (a * x - &y).norm_squared();
        if residual < best.0 {
            best = (residual, period_min);
        }
    }
    best.1
}

#[test]
#[ignore = "20 runs of the 5.5-hour mission: about 4 minutes on 2 cores"]
fn pure_sdins_reproduces_seed_000() {
    let scenario = Scenario::built_in("long-dive").unwrap();
    let config = Config::from_toml(TABLE_2).unwrap();
    let outcomes: Vec<Outcome> = (0..20u64)
        .into_par_iter()
        .map(|seed| run_seed(&scenario, &config, seed))
        .collect();
    let rms = |f: &dyn Fn(&Outcome) -> f64| {
        (outcomes.iter().map(|o| f(o).powi(2)).sum::<f64>() / outcomes.len() as f64).sqrt()
    };
    let pure = rms(&|o| o.pure_m);
    let filter_depth = rms(&|o| o.filter_depth_m);
    let dvl_hour = rms(&|o| o.dvl_hour_m);
    let periods: Vec<f64> = outcomes
        .iter()
        .map(|o| dominant_period_min(&o.north_error))
        .collect();
    let mut sorted = periods.clone();
    sorted.sort_by(f64::total_cmp);
    let median_period = sorted[sorted.len() / 2];
    let mut filter_periods: Vec<f64> = outcomes
        .iter()
        .map(|o| dominant_period_min(&o.filter_north_error))
        .collect();
    filter_periods.sort_by(f64::total_cmp);
    let filter_period = filter_periods[filter_periods.len() / 2];
    println!(
        "Schuler period fitted to the filter's (depth alone) north error, as errors.parquet has it: \
         median {filter_period:.1} min (range {:.1}-{:.1})",
        filter_periods[0],
        filter_periods[filter_periods.len() - 1]
    );
    println!(
        "long-dive, 20 runs: horizontal RMS at 5.5 h, pure SDINS {:.0} m (seed 000: about 1400 m); \
         hindsight's filter with depth alone {:.0} m, with the DVL's first hour {:.0} m; Schuler period \
         fitted to the pure SDINS north error: median {:.1} min (range {:.1}-{:.1})",
        pure,
        filter_depth,
        dvl_hour,
        median_period,
        sorted[0],
        sorted[sorted.len() - 1]
    );
    for (seed, (o, p)) in outcomes.iter().zip(&periods).enumerate() {
        println!(
            "  seed {seed:2}: pure {:6.0} m, filter with depth {:6.0} m, with the DVL hour {:6.0} m; period {p:.1} min",
            o.pure_m, o.filter_depth_m, o.dvl_hour_m
        );
    }
    assert!((0.6 * 1400.0..=1.4 * 1400.0).contains(&pure), "{pure} m");
    // Schuler period at this latitude and depth: 2 pi sqrt(R / g) = 84.4 min.
    assert!((median_period - 84.4).abs() < 8.0, "{median_period} min");
    assert!((filter_period - 84.4).abs() < 8.0, "{filter_period} min");
}
