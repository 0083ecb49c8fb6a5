//! The integration tests, one crate: each file of `tests/` is a module here, so they link
//! once and run side by side. Run one file's tests with its name as the filter:
//! `cargo test --release --test all tuning::`.

mod common;

mod acoustic;
mod acoustic_raw;
mod acoustic_ros;
mod alignment;
mod attitude_cli;
mod bad_input;
mod batch;
mod broad_attitude;
mod cli;
mod console;
mod contract_schemas;
mod default_run;
mod docs;
mod dvl_calibration;
mod dynamic_scenarios;
mod em_log;
mod foreign_bags;
mod foreign_writer;
mod fuzz;
mod fuzz_inputs;
mod gating;
mod house;
mod identify;
mod identify_cli;
mod identify_design;
mod identify_six_dof;
mod import_csv;
mod inertial_exactness;
mod ingest;
mod ins_forward;
mod library_entry;
mod long_dive;
mod model_aided;
mod pool_attitude;
mod real_logs;
mod reconstruct;
mod reconstruct_cli;
mod report;
mod ros2;
mod ros2_foreign;
mod simulate;
mod study;
mod survey_27h;
mod tuning;
mod vehicle_manoeuvres;
mod vehicle_model;
mod velocity_filters;
mod warning_codes;
