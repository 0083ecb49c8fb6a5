//! Arrow tables of `hindsight identify`: coefficients, their correlation, the EKF's history
//! and the fit.

use super::columns::Columns;
use crate::identify::record::Record;
use crate::identify::Identification;
use crate::vehicle::heave_pitch::{HeavePitch, NAMES, UNITS};
use arrow_array::{BooleanArray, RecordBatch};
use arrow_schema::{ArrowError, DataType, Field};
use std::sync::Arc;

/// `coefficients.parquet`: one row per coefficient.
pub fn coefficients_batch(
    id: &Identification,
    model: &HeavePitch,
    fixed: &[Option<f64>; 10],
) -> Result<RecordBatch, ArrowError> {
    let r = &id.refined;
    let sigma = |cov: &nalgebra::SMatrix<f64, 10, 10>, i: usize| cov[(i, i)].sqrt();
    let poorly: Vec<bool> = (0..10)
        .map(|i| {
            id.assessment
                .iter()
                .any(|d| d.name == NAMES[i] && d.poorly_determined)
        })
        .collect();
    let mut c = Columns::default();
    c.text("name", NAMES.to_vec());
    c.number("estimate", "1", r.coefficients.iter().copied().collect());
    c.number(
        "sigma",
        "1",
        (0..10).map(|i| sigma(&r.covariance, i)).collect(),
    );
    c.number("initial", "1", id.start.iter().copied().collect());
    c.number(
        "ekf_estimate",
        "1",
        id.ekf.coefficients.iter().copied().collect(),
    );
    c.number(
        "ekf_sigma",
        "1",
        (0..10).map(|i| sigma(&id.ekf.covariance, i)).collect(),
    );
    c.number(
        "dimensional",
        "see unit",
        (0..10)
            .map(|i| r.coefficients[i] * model.scale(i))
            .collect(),
    );
    c.number(
        "dimensional_sigma",
        "see unit",
        (0..10)
            .map(|i| sigma(&r.covariance, i) * model.scale(i))
            .collect(),
    );
    c.text("unit", UNITS.to_vec());
    c.push(
        Field::new("fixed", DataType::Boolean, false),
        Arc::new(BooleanArray::from(
            fixed.iter().map(Option::is_some).collect::<Vec<_>>(),
        )),
    );
    c.push(
        Field::new("poorly_determined", DataType::Boolean, false),
        Arc::new(BooleanArray::from(poorly)),
    );
    c.finish()
}

/// `correlation.parquet`: the refined estimates' correlation matrix (row `name`, one column
/// per coefficient).
pub fn correlation_batch(id: &Identification) -> Result<RecordBatch, ArrowError> {
    let corr = crate::identify::identifiability::correlation(&id.refined.covariance);
    let mut c = Columns::default();
    c.text("name", NAMES.to_vec());
    for (j, name) in NAMES.iter().enumerate() {
        c.number(name, "1", (0..10).map(|i| corr[(i, j)]).collect());
    }
    c.finish()
}

/// `coefficient_history.parquet`: the EKF's estimate and sigma through the pass.
pub fn history_batch(id: &Identification, records: &[Record]) -> Result<RecordBatch, ArrowError> {
    let h = &id.ekf.history;
    let rows = h.len() * 10;
    let mut stamps = Vec::with_capacity(rows);
    let (mut logs, mut names) = (Vec::with_capacity(rows), Vec::with_capacity(rows));
    let (mut values, mut sigmas) = (Vec::with_capacity(rows), Vec::with_capacity(rows));
    for p in h {
        for (i, name) in NAMES.iter().enumerate() {
            stamps.push(records[p.log].start_stamp_ns + (p.t_s * 1e9).round() as i64);
            logs.push(records[p.log].name.as_str());
            names.push(*name);
            values.push(p.value[i]);
            sigmas.push(p.sigma[i]);
        }
    }
    let mut c = Columns::default();
    c.stamps(stamps);
    c.text("log", logs);
    c.text("name", names);
    c.number("value", "1", values);
    c.number("sigma", "1", sigmas);
    c.finish()
}

/// `fit.parquet`: one row per sample of every log, measured (null where no reading) and
/// re-simulated w, theta, q, depth, and the plane.
pub fn fit_batch(id: &Identification, records: &[Record]) -> Result<RecordBatch, ArrowError> {
    let mut c = Columns::default();
    let mut stamps = Vec::new();
    let mut logs = Vec::new();
    let mut cols: [Vec<Option<f64>>; 4] = Default::default();
    let mut sims: [Vec<f64>; 4] = Default::default();
    let mut plane = Vec::new();
    for (r, fit) in records.iter().zip(&id.fits) {
        let mut w = vec![None; r.t_s.len()];
        for &(k, v) in &r.w_m_s {
            w[k] = Some(v);
        }
        let mut d = vec![None; r.t_s.len()];
        for &(k, v) in &r.depth_m {
            d[k] = Some(v);
        }
        for k in 0..r.t_s.len() {
            stamps.push(r.start_stamp_ns + (r.t_s[k] * 1e9).round() as i64);
            logs.push(r.name.as_str());
            cols[0].push(w[k]);
            cols[1].push(Some(r.theta_rad[k]));
            cols[2].push(Some(r.q_rad_s[k]));
            cols[3].push(d[k]);
            let s = fit.simulated[k];
            sims[0].push(s[0]);
            sims[1].push(s[1]);
            sims[2].push(s[2]);
            sims[3].push(s[3]);
            plane.push(r.plane_rad[k]);
        }
    }
    c.stamps(stamps);
    c.text("log", logs);
    let names = [
        ("w", "m/s"),
        ("theta", "rad"),
        ("q", "rad/s"),
        ("depth", "m"),
    ];
    let [m0, m1, m2, m3] = cols;
    let [s0, s1, s2, s3] = sims;
    for ((name, unit), (measured, simulated)) in
        names.iter().zip([(m0, s0), (m1, s1), (m2, s2), (m3, s3)])
    {
        let suffix = match *name {
            "w" => "_m_s",
            "theta" => "_rad",
            "q" => "_rad_s",
            _ => "_m",
        };
        c.optional(&format!("{name}_measured{suffix}"), unit, measured);
        c.number(&format!("{name}_simulated{suffix}"), unit, simulated);
    }
    c.number("stern_plane_rad", "rad", plane);
    c.finish()
}

/// `coefficients.parquet` of a 6-DOF identification: one row per identified coefficient
/// (SI, as the model uses it).
pub fn six_dof_coefficients_batch(
    id: &crate::identify::six_dof::SixDofIdentification,
) -> Result<RecordBatch, ArrowError> {
    let n = id.names.len();
    let sigma: Vec<f64> = (0..n).map(|i| id.covariance[(i, i)].sqrt()).collect();
    let determination = |i: usize| id.assessment.iter().find(|d| d.name == id.names[i]);
    let mut c = Columns::default();
    c.text("name", id.names.iter().map(String::as_str).collect());
    c.number("estimate", "SI", id.coefficients.clone());
    c.number("sigma", "SI", sigma.clone());
    c.number("initial", "SI", id.start.clone());
    c.number("file_value", "SI", id.file.clone());
    c.number(
        "relative_sigma",
        "1",
        (0..n)
            .map(|i| sigma[i] / id.coefficients[i].abs().max(f64::MIN_POSITIVE))
            .collect(),
    );
    c.optional_text(
        "most_correlated",
        (0..n)
            .map(|i| {
                determination(i).and_then(|d| d.most_correlated.as_ref().map(|m| m.0.as_str()))
            })
            .collect(),
    );
    c.number(
        "correlation",
        "1",
        (0..n)
            .map(|i| {
                determination(i)
                    .and_then(|d| d.most_correlated.as_ref().map(|m| m.1))
                    .unwrap_or(0.0)
            })
            .collect(),
    );
    c.push(
        Field::new("poorly_determined", DataType::Boolean, false),
        Arc::new(BooleanArray::from(
            (0..n)
                .map(|i| determination(i).is_some_and(|d| d.poorly_determined))
                .collect::<Vec<_>>(),
        )),
    );
    c.finish()
}
