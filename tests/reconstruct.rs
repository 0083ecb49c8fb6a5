//! Issue #4's acceptance on simulated logs (fixed seeds), through the library entry point
//! the `reconstruct` command uses: initialisation from the log, forward filter, smoother,
//! scored against `/truth`.

use crate::common;
use hindsight::config::Section;
use hindsight::contract::{Dvl, GnssFix, Imu, Truth};
use hindsight::filters::ins::aid_table::Sensor;
use hindsight::ingest::Log;
use hindsight::recon::alignment::start::{HeadingSource, PositionSource};
use hindsight::recon::clock::suggest_dvl_offset;
use hindsight::recon::config::Config;
use hindsight::recon::score::{scores, Scores};
use hindsight::recon::stats::{sensor_stats, warnings, RunWarning};
use hindsight::recon::{run_configured as reconstruct, Reconstruction, Streams};
use hindsight::sim::scenario::Scenario;

fn run(log: &Log, streams: &Streams<'_>, config: &Config) -> Reconstruction {
    reconstruct(streams, &log.mission().unwrap(), config).unwrap()
}

use common::output_errors as errors;

fn score(truth: &[Truth], r: &Reconstruction) -> (Scores, Scores) {
    let (f, s) = errors(truth, r);
    (scores(&f).unwrap(), scores(&s).unwrap())
}

/// The sensor noise of the `survey` scenario, as an engineer would write it from the data
/// sheets (the file says how).
const SURVEY_CONFIG: &str = include_str!("../configs/survey.toml");

#[test]
fn survey_accuracy_and_consistency() {
    let log = common::simulated_log(&Scenario::built_in("survey").unwrap(), 1);
    let streams = Streams::of(&log);
    let config = Config::from_toml(SURVEY_CONFIG).unwrap();
    let r = run(&log, &streams, &config);
    assert!(matches!(r.init.position, PositionSource::Gnss { .. }));
    assert_eq!(r.init.heading, HeadingSource::Magnetometer);

    let (fwd_err, _) = errors(streams.truth, &r);
    let (fwd, smo) = score(streams.truth, &r);
    let distance: f64 = streams
        .truth
        .windows(2)
        .map(|w| (w[1].north_m - w[0].north_m).hypot(w[1].east_m - w[0].east_m))
        .sum();
    // The forward error just before the first GNSS fix of the final surfacing.
    let mid = streams.truth[streams.truth.len() / 2].stamp_ns;
    let end_fix = streams
        .gnss
        .iter()
        .find(|g| g.stamp_ns > mid)
        .unwrap()
        .stamp_ns;
    let before_end_fix = fwd_err
        .iter()
        .rev()
        .find(|e| e.stamp_ns < end_fix)
        .unwrap()
        .horizontal_m();
    println!(
        "survey: {distance:.0} m; forward RMS {:.2} m, {before_end_fix:.2} m ({:.3} %) before the end GNSS; \
         smoothed RMS {:.2} m; NEES inside 95 %: forward {:.1} % (horizontal {:.1} %), smoothed {:.1} % ({:.1} %)",
        fwd.horizontal_rms_m,
        100.0 * before_end_fix / distance,
        smo.horizontal_rms_m,
        100.0 * fwd.nees_position_inside_95,
        100.0 * fwd.nees_horizontal_inside_95,
        100.0 * smo.nees_position_inside_95,
        100.0 * smo.nees_horizontal_inside_95,
    );
    assert!(smo.horizontal_rms_m <= 0.5 * fwd.horizontal_rms_m);
    assert!(smo.horizontal_rms_m < 2.0);
    assert!(before_end_fix < 0.003 * distance);
    // Consistency: position NEES (3-D) inside the two-sided 95 % bounds at 90 % of epochs.
    assert!(fwd.nees_position_inside_95 >= 0.9);
    assert!(smo.nees_position_inside_95 >= 0.9);
    // Normalised innovations of each sensor: mean within 0.25 of 0 and variance within
    // [0.6, 1.4] (the DVL's scale and bias and the EM log's scale are not white, which the
    // tolerance allows for).
    for s in sensor_stats(&r.run.residuals) {
        println!(
            "  {:<6} {} used, {} rejected, normalised mean {:+.3}, variance {:.3}",
            s.sensor,
            s.count - s.rejected,
            s.rejected,
            s.normalised_mean,
            s.normalised_variance
        );
        assert!(s.normalised_mean.abs() < 0.25, "{s:?}");
        assert!((0.6..=1.4).contains(&s.normalised_variance), "{s:?}");
        assert!(s.rejected as f64 <= 0.005 * s.count as f64, "{s:?}");
    }
}

/// Seed 003's run: the DVL loses the bottom for 4 minutes but keeps reporting noise with
/// `valid = true` and no altitude. hindsight checks the echo sounder's altitude against the
/// DVL's range and gates what is left; a filter that trusts every DVL reading is lost.
#[test]
fn dive_27min_out_of_range_dvl_is_detected() {
    let log = common::simulated_log(&Scenario::built_in("dive-27min").unwrap(), 3);
    let streams = Streams::of(&log);
    let config = Config::from_toml(include_str!("../configs/dive-27min.toml")).unwrap();
    let r = run(&log, &streams, &config);
    let mut trusting = config.clone();
    trusting.dvl.check_range = false;
    trusting.gate.probability = 1.0;
    let naive = run(&log, &streams, &trusting);
    let (h_fwd, h_smo) = score(streams.truth, &r);
    let (n_fwd, _) = score(streams.truth, &naive);
    let dvl = sensor_stats(&r.run.residuals)
        .into_iter()
        .find(|s| s.sensor == Sensor::Dvl)
        .unwrap();
    println!(
        "dive-27min: {} DVL readings out of range, {} gated; hindsight forward RMS {:.1} m (smoothed {:.1} m), \
         trusting filter {:.1} m",
        r.run.unused[Sensor::Dvl], dvl.rejected, h_fwd.horizontal_rms_m, h_smo.horizontal_rms_m, n_fwd.horizontal_rms_m
    );
    // 4 minutes at 5 Hz out of range (and a few readings at the trench edges).
    assert!(
        (1200..1260).contains(&r.run.unused[Sensor::Dvl]),
        "{}",
        r.run.unused[Sensor::Dvl]
    );
    assert_eq!(naive.run.unused[Sensor::Dvl], 0);
    assert!(h_fwd.horizontal_rms_m < 0.1 * n_fwd.horizontal_rms_m);
    // What is left: the heading error of gyrocompassing an intermediate IMU over 8 km.
    assert!(h_fwd.horizontal_rms_m < 50.0);
}

/// Bad input, each handled: no IMU, the IMU stopping for 10 s, DVL stamps 2 s late, a GNSS
/// fix 1 km off.
#[test]
fn bad_input_is_reported_or_handled() {
    let log = common::simulated_log(&Scenario::built_in("survey-short").unwrap(), 1);
    let streams = Streams::of(&log);
    let mission = log.mission().unwrap();
    let config = Config::default();
    let clean = run(&log, &streams, &config);
    let (clean_fwd, clean_smo) = score(streams.truth, &clean);

    // No IMU: a clear error.
    let no_imu = Streams {
        imu: &[],
        ..streams
    };
    let e = reconstruct(&no_imu, &mission, &config).unwrap_err();
    assert!(e.to_string().contains("no IMU data on /imu"), "{e}");

    // The IMU stops for 10 s mid-mission: bridged, the covariance grows over the gap.
    let t_mid = streams.imu[streams.imu.len() / 2].stamp_ns;
    let gap_end = t_mid + 10_000_000_000;
    let imu: Vec<Imu> = streams
        .imu
        .iter()
        .filter(|m| m.stamp_ns <= t_mid || m.stamp_ns >= gap_end)
        .cloned()
        .collect();
    let gapped = run(
        &log,
        &Streams {
            imu: &imu,
            ..streams
        },
        &config,
    );
    assert_eq!(gapped.run.imu_gaps.len(), 1);
    let g = gapped.run.imu_gaps[0];
    assert_eq!((g.from_ns, g.to_ns), (t_mid, gap_end));
    let sigma_at = |t: i64| {
        let s = gapped
            .forward
            .to_vec()
            .unwrap()
            .into_iter()
            .rev()
            .find(|s| s.stamp_ns <= t)
            .unwrap();
        s.sigma[3].hypot(s.sigma[4])
    };
    let (before, during) = (sigma_at(t_mid), sigma_at(gap_end - 100_000_000));
    assert!(during > 1.5 * before, "velocity sigma {before} -> {during}");
    let (gap_fwd, gap_smo) = score(streams.truth, &gapped);
    println!(
        "IMU gap 10 s: velocity sigma {before:.3} -> {during:.3} m/s; forward RMS {:.2} m (clean {:.2}), \
         smoothed {:.2} m (clean {:.2}); warnings: {:?}",
        gap_fwd.horizontal_rms_m,
        clean_fwd.horizontal_rms_m,
        gap_smo.horizontal_rms_m,
        clean_smo.horizontal_rms_m,
        warnings(&gapped.run, &gapped.init, &sensor_stats(&gapped.run.residuals))
    );
    assert!(gap_smo.horizontal_rms_m < clean_smo.horizontal_rms_m + 1.0);
    assert!(warnings(
        &gapped.run,
        &gapped.init,
        &sensor_stats(&gapped.run.residuals)
    )
    .iter()
    .any(|w| matches!(w, RunWarning::ImuGap { seconds, .. } if (seconds - 10.0).abs() < 0.005)));

    // DVL stamps 2 s late: the innovations say so, and the offset option repairs it.
    let late: Vec<Dvl> = streams
        .dvl
        .iter()
        .map(|d| Dvl {
            stamp_ns: d.stamp_ns + 2_000_000_000,
            ..d.clone()
        })
        .collect();
    let lagged = run(
        &log,
        &Streams {
            dvl: &late,
            ..streams
        },
        &config,
    );
    let dvl_stats = |r: &Reconstruction| {
        sensor_stats(&r.run.residuals)
            .into_iter()
            .find(|s| s.sensor == Sensor::Dvl)
            .unwrap()
    };
    let (lag_fwd, _) = score(streams.truth, &lagged);
    let (lagged_dvl, clean_dvl) = (dvl_stats(&lagged), dvl_stats(&clean));
    println!(
        "DVL 2 s late: mean NIS {:.2} (clean {:.2}), {} rejected (clean {}), forward RMS {:.2} m (clean {:.2}); warnings: {:?}",
        lagged_dvl.mean_nis,
        clean_dvl.mean_nis,
        lagged_dvl.rejected,
        clean_dvl.rejected,
        lag_fwd.horizontal_rms_m,
        clean_fwd.horizontal_rms_m,
        warnings(&lagged.run, &lagged.init, &sensor_stats(&lagged.run.residuals))
    );
    assert!(warnings(
        &lagged.run,
        &lagged.init,
        &sensor_stats(&lagged.run.residuals)
    )
    .iter()
    .any(|w| matches!(w, RunWarning::InnovationsTooLarge(x) if x.sensor == Sensor::Dvl)));
    assert!(
        !warnings(&clean.run, &clean.init, &sensor_stats(&clean.run.residuals))
            .iter()
            .any(|w| w.to_string().starts_with("dvl:"))
    );
    // The offset search finds the 2 s, and the clean run needs none.
    let lagged_streams = Streams {
        dvl: &late,
        ..streams
    };
    let suggestion =
        suggest_dvl_offset(&lagged_streams, &mission, &config, Default::default()).unwrap();
    println!("offset search: {suggestion:?}");
    assert!((suggestion.offset_s + 2.0).abs() <= 0.1, "{suggestion:?}");
    assert_eq!(
        suggest_dvl_offset(&streams, &mission, &config, Default::default()),
        None
    );

    // A GNSS fix 1 km north of the truth at the final surfacing: rejected and counted, and
    // the solution does not move.
    let mut gnss: Vec<GnssFix> = streams.gnss.to_vec();
    let k = gnss.len() - 5;
    gnss[k].latitude_deg += 1000.0 / 111_000.0;
    let outlier = run(
        &log,
        &Streams {
            gnss: &gnss,
            ..streams
        },
        &config,
    );
    let rejected: Vec<_> = outlier
        .run
        .residuals
        .iter()
        .filter(|r| r.sensor == Sensor::Gnss && !r.accepted)
        .collect();
    assert_eq!(rejected.len(), 1);
    assert_eq!(rejected[0].stamp_ns, gnss[k].stamp_ns);
    // Exactly as if the fix had not been there.
    gnss.remove(k);
    let without = run(
        &log,
        &Streams {
            gnss: &gnss,
            ..streams
        },
        &config,
    );
    let (out_fwd, out_smo) = score(streams.truth, &outlier);
    let (wo_fwd, wo_smo) = score(streams.truth, &without);
    assert_eq!(out_fwd, wo_fwd);
    assert_eq!(out_smo, wo_smo);
    assert!(out_smo.horizontal_rms_m < clean_smo.horizontal_rms_m + 0.1);
}

/// `[imu] estimate_biases = false` (seed 000's pure SDINS): the biases and the gyro's scale
/// factor never move from zero, their uncertainty stays in the covariance (a consider
/// state's variance is not reduced by any update), and the solution is still consistent.
#[test]
fn biases_not_estimated_are_carried_but_never_moved() {
    let log = common::simulated_log(&Scenario::built_in("survey").unwrap(), 1);
    let streams = Streams::of(&log);
    let mut config = Config::from_toml(SURVEY_CONFIG).unwrap();
    let estimated = run(&log, &streams, &config);
    config.imu.estimate_biases = false;
    let held = run(&log, &streams, &config);
    let moved = |r: &Reconstruction| {
        r.forward
            .iter()
            .map(Result::unwrap)
            .map(|s| {
                s.point
                    .gyro_bias
                    .amax()
                    .max(s.point.accel_bias.amax())
                    .max(s.point.gyro_scale_z.abs())
            })
            .fold(0.0, f64::max)
    };
    assert!(moved(&estimated) > 0.0, "the default estimates the biases");
    assert_eq!(moved(&held), 0.0);
    // Without updates to them, the biases' sigma can only grow (their walk).
    let first = held.forward.first().unwrap().unwrap().sigma;
    let last = held.forward.last().unwrap().unwrap().sigma;
    for i in 9..15 {
        assert!(
            last[i] >= first[i] * (1.0 - 1e-9),
            "state {i}: {} -> {}",
            first[i],
            last[i]
        );
    }
    let (f, _) = score(streams.truth, &held);
    assert!(f.nees_horizontal_inside_95 > 0.8, "{f:?}");
}
