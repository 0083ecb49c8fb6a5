//! The forward error-state filter and the RTS smoother on the simulated `survey` (DVL
//! throughout, depth, GNSS at the surface at both ends), scored against `/truth`.
//!
//! The initial state is the truth's first sample with set errors (3 m north, 0.2 deg roll and
//! pitch, 2 deg heading): initialisation from the log itself is tested elsewhere
//! (`alignment`, `default_run`); this test exercises propagation, updates and smoothing.

use crate::common;
use hindsight::contract::{Depth, Imu, Streams, Truth};
use hindsight::filters::ins::aid_table::{Aiding, Sensor};
use hindsight::filters::ins::driver::{run_forward, Inputs, Propagation, Settings};
use hindsight::filters::ins::error_state::{ErrorMatrix, N};
use hindsight::filters::ins::forward::{DvlMounting, Estimate, Filter, ImuNoise};
use hindsight::filters::ins::mechanization::NavState;
use hindsight::filters::ins::record::NavPoint;
use hindsight::geodesy;
use hindsight::sim::scenario::Scenario;
use hindsight::smooth::rts::smooth;
use nalgebra::{SVector, UnitQuaternion, Vector3};

fn horizontal_error(t: &Truth, e: &NavPoint) -> f64 {
    let (n, east) = geodesy::local_north_east_m(
        t.latitude_deg.to_radians(),
        t.longitude_deg.to_radians(),
        e.nav.lat_rad,
        e.nav.lon_rad,
    );
    n.hypot(east)
}

/// The aiding of these tests: DVL 0.015 m/s, depth 0.1 m (every reading), the EM log with
/// `eml_sigma_m_s` (or not), gate 0.999 never reopened.
fn aiding(eml_sigma_m_s: Option<f64>) -> Aiding {
    Aiding {
        dvl_sigma_m_s: 0.015,
        dvl_max_altitude_m: 100.0,
        dvl_check_range: true,
        altimeter_max_age_s: 2.0,
        dvl_mounting: DvlMounting::default(),
        depth_sigma_m: 0.1,
        depth_min_interval_s: 0.0,
        eml_sigma_m_s,
        mag: None,
        rpm_velocity: None,
        acoustic: None,
        lbl: None,
        usbl: None,
        gate_probability: Some(0.999),
        gate_reset_after: 0,
    }
}

/// The filter with the noise densities of the scenario's IMU grade, and `aiding`.
fn settings_for(scenario: &Scenario, aiding: Aiding) -> Settings {
    let (g, a) = (scenario.imu.gyro.triad(), scenario.imu.accel.triad());
    let filter = Filter {
        noise: ImuNoise {
            gyro_noise_density: g.noise_density,
            accel_noise_density: a.noise_density,
            gyro_bias_walk: g.bias_instability * (2.0 / g.bias_correlation_s).sqrt(),
            accel_bias_walk: a.bias_instability * (2.0 / a.bias_correlation_s).sqrt(),
        },
        height_damping: None,
        current_walk: 0.0,
        dvl_bias_walk: 0.0,
        dvl_bias_correlation_s: None,
        considered: [false; hindsight::filters::ins::error_state::N],
    };
    Settings {
        filter,
        propagation: Propagation {
            covariance_interval_s: 0.1,
            imu_gap_s: 0.1,
            gap_noise: ImuNoise {
                gyro_noise_density: 0.0,
                accel_noise_density: 0.0,
                gyro_bias_walk: 0.0,
                accel_bias_walk: 0.0,
            },
        },
        aiding,
    }
}

/// The scenario's mission origin (latitude, longitude), rad.
fn origin_rad(scenario: &Scenario) -> (f64, f64) {
    (
        scenario.mission.origin_latitude_deg.to_radians(),
        scenario.mission.origin_longitude_deg.to_radians(),
    )
}

/// The truth's first sample with set errors: `north_m` of position, `tilt_deg` added to roll
/// and taken from pitch, `heading_deg` added to yaw; horizontal position variance
/// `horizontal_var_m2`, bias sigmas 1.5 times the scenario's.
fn initial_from_truth(
    t0: &Truth,
    scenario: &Scenario,
    north_m: f64,
    tilt_deg: f64,
    heading_deg: f64,
    horizontal_var_m2: f64,
) -> Estimate {
    let (g, a) = (scenario.imu.gyro.triad(), scenario.imu.accel.triad());
    let rho_n = geodesy::meridian_radius_m(t0.latitude_deg.to_radians());
    let deg2 = |d: f64| d.to_radians().powi(2);
    let (gb, ab) = ((1.5 * g.bias).powi(2), (1.5 * a.bias).powi(2));
    Estimate {
        nav: NavState {
            lat_rad: t0.latitude_deg.to_radians() + north_m / rho_n,
            lon_rad: t0.longitude_deg.to_radians(),
            height_m: -t0.down_m,
            vel_ned_m_s: t0.velocity_ned.into(),
            ned_from_body: UnitQuaternion::from_euler_angles(
                t0.attitude[0] + tilt_deg.to_radians(),
                t0.attitude[1] - tilt_deg.to_radians(),
                t0.attitude[2] + heading_deg.to_radians(),
            ),
        },
        gyro_bias: Vector3::zeros(),
        accel_bias: Vector3::zeros(),
        // The DVL's calibration (0.5 %, 1 deg, 2 mm/s) and the water (2 %, 0.2 m/s).
        dvl: Default::default(),
        water: Default::default(),
        // The z gyro's scale factor (the scenario's, 1.5 times, as the biases).
        gyro_scale_z: 0.0,
        sound_speed_scale: 0.0,
        cov: ErrorMatrix::from_diagonal(&SVector::<f64, N>::from_fn(|i, _| {
            [
                horizontal_var_m2,
                horizontal_var_m2,
                1.0,
                0.01,
                0.01,
                0.01,
                deg2(0.5),
                deg2(0.5),
                deg2(3.0),
                gb,
                gb,
                gb,
                ab,
                ab,
                ab,
                0.005f64.powi(2),
                deg2(1.0),
                deg2(1.0),
                0.002f64.powi(2),
                0.002f64.powi(2),
                0.002f64.powi(2),
                0.02f64.powi(2),
                0.04,
                0.04,
                (1.5e-6 * scenario.imu.gyro.scale_ppm).powi(2),
                // The speed of sound's scale (no acoustic ranges here: it stays there).
                0.005f64.powi(2),
            ][i]
        })),
    }
}

#[test]
fn forward_filter_and_smoother_follow_the_survey() {
    let scenario = Scenario::built_in("survey").unwrap();
    let log = common::simulated_log(&scenario, 1);
    let truth = log.messages::<Truth>("/truth").unwrap();
    let output_stamps: Vec<i64> = truth.iter().map(|t| t.stamp_ns).collect();
    let streams = Streams {
        altimeter: &[],
        mag: &[],
        fixes: &[],
        ..Streams::of(&log)
    };
    let settings = settings_for(&scenario, aiding(Some(0.05)));
    let aids = settings.aiding.table(&streams, origin_rad(&scenario));
    let inputs = Inputs {
        imu: streams.imu,
        aids: &aids,
        output_stamps_ns: &output_stamps,
        progress: None,
        keep: hindsight::filters::ins::driver::Keep::Records,
    };

    let initial = initial_from_truth(&truth[0], &scenario, 3.0, 0.2, 2.0, 25.0);
    let run = run_forward(&settings, &inputs, initial);
    let smoothed = smooth(&run.records).unwrap();
    let records = run.records.to_vec().unwrap();
    assert_eq!(smoothed.len(), records.len());

    // Score both solutions at every truth stamp (each has its epoch).
    let (mut fwd, mut smo) = (Vec::new(), Vec::new());
    let mut k = 0;
    for t in truth {
        while records[k].stamp_ns < t.stamp_ns {
            k += 1;
        }
        assert_eq!(records[k].stamp_ns, t.stamp_ns);
        fwd.push((t.stamp_ns, horizontal_error(t, &records[k].posterior)));
        smo.push(horizontal_error(t, &smoothed[k].point));
        assert!(records[k].posterior_cov.unpack().cholesky().is_some());
        assert!(smoothed[k].sigma.iter().all(|s| s.is_finite() && *s > 0.0));
    }
    let rms = |v: &mut dyn Iterator<Item = f64>| {
        let (s, n) = v.fold((0.0, 0usize), |(s, n), e| (s + e * e, n + 1));
        (s / n as f64).sqrt()
    };
    let fwd_rms = rms(&mut fwd.iter().map(|e| e.1));
    let smo_rms = rms(&mut smo.iter().copied());
    let distance: f64 = truth
        .windows(2)
        .map(|w| (w[1].north_m - w[0].north_m).hypot(w[1].east_m - w[0].east_m))
        .sum();
    // The forward error just before the GNSS fixes of the final surfacing.
    let gnss = streams.gnss;
    let mid = truth[truth.len() / 2].stamp_ns;
    let end_fix = gnss.iter().find(|g| g.stamp_ns > mid).unwrap().stamp_ns;
    let before_end_fix = fwd.iter().rev().find(|e| e.0 < end_fix).unwrap().1;
    let dvl_nis: Vec<f64> = run
        .residuals
        .iter()
        .filter(|r| r.sensor == Sensor::Dvl)
        .map(|r| r.nis)
        .collect();
    let rejected = run.residuals.iter().filter(|r| !r.accepted).count();
    println!(
        "survey: {distance:.0} m travelled; forward RMS {fwd_rms:.2} m, before the end GNSS {before_end_fix:.2} m \
         ({:.3} % of distance); smoothed RMS {smo_rms:.2} m; {} epochs; DVL mean NIS {:.2} (3 expected); {rejected} rejected",
        100.0 * before_end_fix / distance,
        run.records.len(),
        dvl_nis.iter().sum::<f64>() / dvl_nis.len() as f64
    );
    let eml_used = run
        .residuals
        .iter()
        .filter(|r| r.sensor == Sensor::SpeedLog)
        .count();
    assert!(eml_used > 5000, "EM-log updates: {eml_used}");
    // Issue #4's survey criteria.
    assert!(
        before_end_fix < 0.003 * distance,
        "{before_end_fix} m of {distance} m"
    );
    assert!(
        smo_rms <= 0.5 * fwd_rms,
        "smoothed {smo_rms} m vs forward {fwd_rms} m"
    );
    assert!(smo_rms < 2.0, "{smo_rms} m");
}

/// USBL-like position fixes alone (no DVL, no GNSS, no EM log) hold the INS on a short
/// survey; without them the same run drifts.
#[test]
fn position_fixes_bound_the_error_without_dvl() {
    let text = hindsight::sim::scenario::BUILT_IN
        .iter()
        .find(|(n, _)| *n == "survey-short")
        .unwrap()
        .1;
    let scenario = Scenario::from_toml(&format!(
        "{text}\n[fixes]\nusbl_every_s = 10.0\nusbl_sigma_m = 2.0\n"
    ))
    .unwrap();
    let log = common::simulated_log(&scenario, 4);
    let truth = log.messages::<Truth>("/truth").unwrap();
    let fixes = log
        .messages::<hindsight::contract::PositionFix>("/position_fix")
        .unwrap();
    assert!(fixes.len() > 30);
    let settings = settings_for(&scenario, aiding(None));
    let initial = initial_from_truth(&truth[0], &scenario, 0.0, 0.0, 2.0, 4.0);
    let stamps: Vec<i64> = truth.iter().map(|t| t.stamp_ns).collect();
    let run_with = |fixes: &[hindsight::contract::PositionFix]| {
        let streams = Streams {
            imu: log.messages::<Imu>("/imu").unwrap(),
            depth: log.messages::<Depth>("/depth").unwrap(),
            fixes,
            ..Streams::default()
        };
        let aids = settings.aiding.table(&streams, origin_rad(&scenario));
        let inputs = Inputs {
            imu: streams.imu,
            aids: &aids,
            output_stamps_ns: &stamps,
            progress: None,
            keep: hindsight::filters::ins::driver::Keep::Records,
        };
        let run = run_forward(&settings, &inputs, initial);
        let records = run.records.to_vec().unwrap();
        let mut k = 0;
        let mut sq = 0.0;
        for t in truth {
            while records[k].stamp_ns < t.stamp_ns {
                k += 1;
            }
            sq += horizontal_error(t, &records[k].posterior).powi(2);
        }
        let used = run
            .residuals
            .iter()
            .filter(|r| r.sensor == Sensor::PositionFix && r.accepted)
            .count();
        ((sq / truth.len() as f64).sqrt(), used)
    };
    let (with_fixes, used) = run_with(fixes);
    let (without, _) = run_with(&[]);
    println!("survey-short, no DVL: horizontal RMS {with_fixes:.2} m with {used} USBL fixes (2 m), {without:.2} m without");
    assert_eq!(used, fixes.len());
    // Bounded at the fixes' scale (2 m each, every 10 s; the first minute converges from a
    // 2 deg heading error), while the unaided run drifts by hundreds of metres.
    assert!(with_fixes < 2.0 * 2.0, "{with_fixes} m");
    assert!(with_fixes < 0.5 * without, "{with_fixes} m vs {without} m");
}

/// Readings whose measurement covariance is not positive definite (as a writer's bad
/// sigma, or a covariance that lost its definiteness, would give).
struct NotPositiveDefinite {
    stamps_ns: Vec<i64>,
}

impl hindsight::filters::ins::aid_table::Aid for NotPositiveDefinite {
    fn sensor(&self) -> Sensor {
        Sensor::Depth
    }
    fn len(&self) -> usize {
        self.stamps_ns.len()
    }
    fn stamp_ns(&self, i: usize) -> i64 {
        self.stamps_ns[i]
    }
    fn measure(
        &self,
        _: usize,
        _: &hindsight::filters::ins::aid_table::Epoch<'_>,
    ) -> Option<hindsight::filters::ins::aid_table::Update> {
        let mut h = nalgebra::SMatrix::<f64, 1, N>::zeros();
        h[(0, 2)] = 1.0;
        Some(hindsight::filters::ins::aid_table::Update::One(
            hindsight::filters::ins::aid_table::Measurement {
                y: nalgebra::SVector::<f64, 1>::new(0.1),
                h,
                r: nalgebra::SMatrix::<f64, 1, 1>::new(-1e6),
            },
        ))
    }
}

/// An update whose innovation covariance is not positive definite is skipped and counted,
/// and the run goes on to its end, as it would without those readings.
#[test]
fn an_update_that_is_not_positive_definite_is_skipped_and_the_run_goes_on() {
    let scenario = Scenario::built_in("survey-short").unwrap();
    let log = common::simulated_log(&scenario, 2);
    let truth = log.messages::<Truth>("/truth").unwrap();
    let streams = Streams {
        altimeter: &[],
        mag: &[],
        fixes: &[],
        ..Streams::of(&log)
    };
    let settings = settings_for(&scenario, aiding(None));
    let run = |bad: bool| {
        let mut aids = settings.aiding.table(&streams, origin_rad(&scenario));
        let t0 = streams.imu[0].stamp_ns;
        let stamps_ns: Vec<i64> = (1..100).map(|k| t0 + k * 1_000_000_000 + 3).collect();
        let count = stamps_ns.len();
        if bad {
            aids.push(Box::new(NotPositiveDefinite { stamps_ns }));
        }
        let inputs = Inputs {
            imu: streams.imu,
            aids: &aids,
            output_stamps_ns: &[],
            progress: None,
            keep: hindsight::filters::ins::driver::Keep::Navigation,
        };
        let initial = initial_from_truth(&truth[0], &scenario, 0.0, 0.0, 0.0, 1.0);
        (run_forward(&settings, &inputs, initial), count)
    };
    let ((clean, _), (with_bad, count)) = (run(false), run(true));
    assert_eq!(with_bad.not_positive_definite[Sensor::Depth], count);
    assert_eq!(clean.not_positive_definite[Sensor::Depth], 0);
    // Their stamps add epochs of their own (the propagation steps split there); the end is
    // the same to the rounding.
    let (a, b) = (
        clean.navigation.last().unwrap(),
        with_bad.navigation.last().unwrap(),
    );
    assert_eq!(a.stamp_ns, b.stamp_ns);
    let metres = (a.nav.lat_rad - b.nav.lat_rad).abs() * 6.4e6
        + (a.nav.lon_rad - b.nav.lon_rad).abs() * 6.4e6
        + (a.nav.height_m - b.nav.height_m).abs();
    assert!(metres < 1e-3, "{a:?} {b:?}");
    assert!((a.nav.vel_ned_m_s - b.nav.vel_ned_m_s).norm() < 1e-6);
    assert_eq!(with_bad.residuals.len(), clean.residuals.len());
}
