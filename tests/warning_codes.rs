//! Every kind of warning a run can raise: its code, its message, its data as JSON values and
//! the guide's entry for programs that match the code. A kind added to the library's enums
//! and left out here fails to compile (`every_kind_is_listed`).

use hindsight::filters::ins::aid_table::Sensor;
use hindsight::recon::alignment::heading::{HeadingDisagreement, HeadingSource, SourceHeading};
use hindsight::recon::clock::OffsetSuggestion;
use hindsight::recon::consistency::NeesCheck;
use hindsight::recon::consistency::Verdict;
use hindsight::recon::pipeline;
use hindsight::recon::plan::Why;
use hindsight::recon::stats::{Flagged, RunWarning};
use hindsight::recon::tune::TuningWarning;
use hindsight::reconstruction::Warning;

/// One warning of every kind, with its code. A kind added to the enums and left out here
/// is caught by the exhaustive match in `every_kind_is_listed`.
fn one_of_each() -> Vec<(Warning, &'static str)> {
    let mut all = of_the_plan_and_tuning();
    all.extend(of_the_forward_pass());
    all
}

/// The plan's, the start's, the magnetometer's, self-tuning's, the NEES verdict's and
/// the outputs'.
fn of_the_plan_and_tuning() -> Vec<(Warning, &'static str)> {
    let pipeline = Warning::Pipeline;
    use pipeline::Warning as P;
    vec![
        (
            pipeline(P::ForcedOnRefused {
                part: "dvl_lever_arm",
                why: Why::PriorZero,
            }),
            "forced_on_refused",
        ),
        (
            pipeline(P::AidRefused {
                sensor: Sensor::RpmVelocity,
                why: "no DVL".into(),
            }),
            "aid_refused",
        ),
        (
            pipeline(P::AidLeftOut {
                sensor: Sensor::Lbl,
                why: "3 ranges to beacon `E` were left out".into(),
            }),
            "aid_left_out",
        ),
        (
            pipeline(P::Retuned {
                tuned_from_deg: 10.0,
                checked_deg: 20.0,
            }),
            "retuned",
        ),
        (
            pipeline(P::DvlClock {
                mean_nis: 8.0,
                suggestion: Some(OffsetSuggestion {
                    offset_s: 1.0,
                    mean_nis: 1.1,
                    mean_nis_unshifted: 8.0,
                }),
            }),
            "dvl_clock",
        ),
        (
            pipeline(P::DvlClock {
                mean_nis: 8.0,
                suggestion: None,
            }),
            "dvl_clock",
        ),
        (
            pipeline(P::Tuning(TuningWarning::NoNoiseModelRan)),
            "no_noise_model_ran",
        ),
        (
            pipeline(P::Tuning(TuningWarning::NoiseStillRising {
                rounds: 6,
                model: "tactical".into(),
            })),
            "noise_still_rising",
        ),
        (
            pipeline(P::Tuning(TuningWarning::InstabilityBeyondStill {
                sensor: "gyro",
                tuned: 3.0,
                bound: 1.0,
                unit: "deg/h",
                correlation_s: 300.0,
                still_s: 60.0,
            })),
            "instability_beyond_still",
        ),
        (
            pipeline(P::MagSaturated {
                from_ns: 0,
                to_ns: 1_000_000_000,
                readings: 10,
            }),
            "mag_saturated",
        ),
        (
            pipeline(P::MagNotCalibrated {
                why: "no turn".into(),
                magnitude_variation: 0.05,
                correlation_s: 600.0,
            }),
            "mag_not_calibrated",
        ),
        (
            Warning::OverConfident(NeesCheck {
                solution: "forward",
                horizontal_inside_95: 0.4,
                horizontal_above_95: 0.5,
                verdict: Verdict::OverConfident,
            }),
            "over_confident",
        ),
        (
            Warning::HeldInMemory {
                why: "disk full".into(),
            },
            "held_in_memory",
        ),
    ]
}

/// The forward pass's.
fn of_the_forward_pass() -> Vec<(Warning, &'static str)> {
    let dvl = Flagged {
        sensor: Sensor::Dvl,
        mean_nis: 9.0,
        dims: 3,
        rejected_pct: 12.0,
    };
    let heading = |source, heading_deg| SourceHeading {
        source,
        heading_deg,
        sigma_deg: 2.0,
    };
    let run = |w| Warning::Pipeline(pipeline::Warning::Run(w));
    vec![
        (
            run(RunWarning::ImuNoisier { sensors: vec![dvl] }),
            "imu_noisier",
        ),
        (
            run(RunWarning::InnovationsTooLarge(dvl)),
            "innovations_too_large",
        ),
        (
            run(RunWarning::Rejected {
                sensor: Sensor::Dvl,
                rejected: 3,
                count: 100,
            }),
            "rejected",
        ),
        (run(RunWarning::GateReopened { times: 2 }), "gate_reopened"),
        (
            run(RunWarning::LongRejectedRun {
                sensor: Sensor::Dvl,
                readings: 50,
            }),
            "long_rejected_run",
        ),
        (
            run(RunWarning::StuckReadings {
                sensor: Sensor::Dvl,
                readings: 5,
            }),
            "stuck_readings",
        ),
        (
            run(RunWarning::NotPositiveDefinite {
                sensor: Sensor::Depth,
                readings: 1,
            }),
            "not_positive_definite",
        ),
        (
            run(RunWarning::ImuGap {
                from_ns: 0,
                seconds: 0.5,
            }),
            "imu_gap",
        ),
        (run(RunWarning::DeclinationUnknown), "declination_unknown"),
        (
            run(RunWarning::HeadingDisagreement(
                HeadingDisagreement::Sources {
                    first: heading(HeadingSource::Magnetometer, 10.0),
                    second: heading(HeadingSource::Mission, 60.0),
                    apart_deg: 50.0,
                    allowed_deg: 8.5,
                },
            )),
            "heading_disagreement",
        ),
        (
            run(RunWarning::HeadingDisagreement(
                HeadingDisagreement::StartAndInMotion {
                    start: heading(HeadingSource::Given, 10.0),
                    in_motion: heading(HeadingSource::InMotion, 60.0),
                },
            )),
            "heading_disagreement",
        ),
        (
            run(RunWarning::MagDisturbed { readings: 4 }),
            "mag_disturbed",
        ),
        (
            run(RunWarning::UnaidedVelocity {
                from_ns: 0,
                seconds: 120.0,
                share: 0.2,
            }),
            "unaided_velocity",
        ),
    ]
}

#[test]
fn every_kind_is_listed() {
    // Adding a kind to one of the enums fails to compile here until it is listed above.
    for (w, _) in one_of_each() {
        match w {
            Warning::Pipeline(p) => match p {
                pipeline::Warning::ForcedOnRefused { .. }
                | pipeline::Warning::AidRefused { .. }
                | pipeline::Warning::AidLeftOut { .. }
                | pipeline::Warning::Retuned { .. }
                | pipeline::Warning::DvlClock { .. }
                | pipeline::Warning::MagSaturated { .. }
                | pipeline::Warning::MagNotCalibrated { .. } => {}
                pipeline::Warning::Tuning(t) => match t {
                    TuningWarning::NoNoiseModelRan
                    | TuningWarning::NoiseStillRising { .. }
                    | TuningWarning::InstabilityBeyondStill { .. } => {}
                },
                pipeline::Warning::Run(r) => match r {
                    RunWarning::ImuNoisier { .. }
                    | RunWarning::InnovationsTooLarge(_)
                    | RunWarning::Rejected { .. }
                    | RunWarning::GateReopened { .. }
                    | RunWarning::LongRejectedRun { .. }
                    | RunWarning::StuckReadings { .. }
                    | RunWarning::NotPositiveDefinite { .. }
                    | RunWarning::ImuGap { .. }
                    | RunWarning::DeclinationUnknown
                    | RunWarning::HeadingDisagreement(_)
                    | RunWarning::MagDisturbed { .. }
                    | RunWarning::UnaidedVelocity { .. } => {}
                },
            },
            Warning::OverConfident(_) | Warning::HeldInMemory { .. } => {}
        }
    }
}

/// Every kind has its code, a message, its data as JSON values (numbers as numbers), and
/// a code the guide lists for programs to match.
#[test]
fn every_code_is_written_and_documented() {
    let guide = include_str!("../docs/guide/reconstruct.md");
    for (w, code) in one_of_each() {
        assert_eq!(w.code(), code, "{w:?}");
        let json = serde_json::to_value(&w).expect("serialises");
        assert_eq!(json["code"], code);
        assert_eq!(json["message"].as_str(), Some(w.to_string().as_str()));
        assert!(!w.to_string().is_empty());
        assert!(
            guide.contains(&format!("`{code}`")),
            "{code} is not in the guide"
        );
    }
    let of = |code: &str| {
        let (w, _) = one_of_each().into_iter().find(|(_, c)| *c == code).unwrap();
        serde_json::to_value(&w).unwrap()
    };
    let rejected = of("rejected");
    assert_eq!(rejected["sensor"], "dvl");
    assert_eq!(rejected["rejected"], 3);
    assert_eq!(of("instability_beyond_still")["tuned"], 3.0);
    assert_eq!(
        of("heading_disagreement")["first"]["source"],
        "magnetometer"
    );
}
