//! Arrow tables of decoded streams. The one place where column names and types are made:
//! `stamp_ns` as timestamp[ns, UTC], one column per scalar field, vectors as `_x/_y/_z`
//! (Euler triples as `_roll/_pitch/_yaw`), units in each field's metadata under `unit`.

use crate::align::latest_index_at;
use crate::contract::{PropKind, PropValue};
use crate::ingest::{Samples, Stream};
use crate::time::NS_PER_S;
use arrow_array::builder::{BooleanBuilder, Float64Builder, StringBuilder};
use arrow_array::{ArrayRef, Float64Array, RecordBatch, TimestampNanosecondArray};
use arrow_schema::{ArrowError, DataType, Field, Schema, TimeUnit};
use std::collections::HashMap;
use std::sync::Arc;

/// Arrow type of every time column.
pub fn timestamp_type() -> DataType {
    DataType::Timestamp(TimeUnit::Nanosecond, Some("UTC".into()))
}

fn with_unit(field: Field, unit: &str) -> Field {
    if unit.is_empty() {
        field
    } else {
        field.with_metadata(HashMap::from([("unit".to_string(), unit.to_string())]))
    }
}

fn timestamps(name: &str, values: Vec<i64>) -> (Field, ArrayRef) {
    (
        Field::new(name, timestamp_type(), false),
        Arc::new(TimestampNanosecondArray::from(values).with_timezone("UTC")),
    )
}

/// Columns of every property of `samples`, one row per entry of `rows` (`None`: a null row).
///
/// `prefix` is prepended to each column name. Columns are nullable when some row is `None` or
/// the property itself is nullable.
pub fn property_columns(
    samples: &dyn Samples,
    rows: &[Option<usize>],
    prefix: &str,
) -> Vec<(Field, ArrayRef)> {
    let any_missing = rows.iter().any(Option::is_none);
    let mut out = Vec::new();
    for (p, prop) in samples.properties().iter().enumerate() {
        let nullable = any_missing || prop.kind == PropKind::OptF64;
        for (c, name) in prop.column_names().into_iter().enumerate() {
            let name = format!("{prefix}{name}");
            let column: ArrayRef = match prop.kind {
                PropKind::F64 | PropKind::Vec3 | PropKind::OptF64 => {
                    let mut b = Float64Builder::with_capacity(rows.len());
                    for r in rows {
                        b.append_option(r.and_then(|i| samples.get(i, p).component(c)));
                    }
                    Arc::new(b.finish())
                }
                PropKind::Bool => {
                    let mut b = BooleanBuilder::with_capacity(rows.len());
                    for r in rows {
                        b.append_option(r.and_then(|i| match samples.get(i, p) {
                            PropValue::Bool(v) => Some(v),
                            _ => None,
                        }));
                    }
                    Arc::new(b.finish())
                }
                PropKind::Str => {
                    let mut b = StringBuilder::new();
                    for r in rows {
                        b.append_option(r.and_then(|i| match samples.get(i, p) {
                            PropValue::Str(v) => Some(v),
                            _ => None,
                        }));
                    }
                    Arc::new(b.finish())
                }
            };
            let dtype = column.data_type().clone();
            out.push((
                with_unit(Field::new(name, dtype, nullable), prop.unit),
                column,
            ));
        }
    }
    out
}

fn batch(columns: Vec<(Field, ArrayRef)>) -> Result<RecordBatch, ArrowError> {
    let (fields, arrays): (Vec<Field>, Vec<ArrayRef>) = columns.into_iter().unzip();
    RecordBatch::try_new(Arc::new(Schema::new(fields)), arrays)
}

/// Rows `range` of one stream: `stamp_ns`, `log_time_ns`, then every field.
pub fn stream_batch(
    stream: &Stream,
    range: std::ops::Range<usize>,
) -> Result<RecordBatch, ArrowError> {
    let rows: Vec<Option<usize>> = range.clone().map(Some).collect();
    let samples = stream.samples.as_ref();
    let mut columns = vec![
        timestamps(
            "stamp_ns",
            range.clone().map(|i| samples.stamp_ns(i)).collect(),
        ),
        timestamps(
            "log_time_ns",
            range
                .map(|i| i64::try_from(stream.log_time_ns[i]).unwrap_or(i64::MAX))
                .collect(),
        ),
    ];
    columns.extend(property_columns(samples, &rows, ""));
    batch(columns)
}

/// Every row of one stream, a batch of at most [`super::parquet::ROWS_PER_BATCH`] rows at a
/// time (one empty batch for an empty stream, which carries the schema).
pub fn stream_batches(stream: &Stream) -> Result<Vec<RecordBatch>, ArrowError> {
    let n = stream.samples.len();
    if n == 0 {
        return Ok(vec![stream_batch(stream, 0..0)?]);
    }
    let step = super::parquet::ROWS_PER_BATCH;
    (0..n)
        .step_by(step)
        .map(|start| stream_batch(stream, start..(start + step).min(n)))
        .collect()
}

/// Column-name prefix of a topic: `/nav/dvl` -> `nav_dvl_`.
pub fn topic_prefix(topic: &str) -> String {
    let cleaned: String = topic
        .trim_start_matches('/')
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if cleaned.is_empty() {
        "topic_".into()
    } else {
        format!("{cleaned}_")
    }
}

/// The common clock of an aligned table: multiples of `period_ns` covering every stream.
pub fn aligned_clock(streams: &[Stream], period_ns: i64) -> Vec<i64> {
    let spans = streams.iter().filter_map(|s| {
        let n = s.samples.len();
        (n > 0).then(|| (s.samples.stamp_ns(0), s.samples.stamp_ns(n - 1)))
    });
    let (first, last) = spans.fold((i64::MAX, i64::MIN), |(a, b), (f, l)| (a.min(f), b.max(l)));
    if first > last || period_ns <= 0 {
        return Vec::new();
    }
    let start = first.div_euclid(period_ns) * period_ns
        + if first.rem_euclid(period_ns) == 0 {
            0
        } else {
            period_ns
        };
    (0..)
        .map(|k| start + k * period_ns)
        .take_while(|&t| t <= last)
        .collect()
}

/// Every stream sampled at the clock times: for each stream its latest message at or before
/// each time (null before its first message) and `<topic>_age_s`, that message's age.
pub fn aligned_batch(streams: &[Stream], clock_ns: &[i64]) -> Result<RecordBatch, ArrowError> {
    let mut columns = vec![timestamps("stamp_ns", clock_ns.to_vec())];
    let mut used = HashMap::<String, usize>::new();
    for stream in streams {
        let mut prefix = topic_prefix(&stream.topic);
        let seen = used.entry(prefix.clone()).or_insert(0);
        *seen += 1;
        if *seen > 1 {
            prefix = format!("{prefix}{}_", seen);
        }
        let samples = stream.samples.as_ref();
        let latest: Vec<Option<(usize, i64)>> = clock_ns
            .iter()
            .map(|&t| latest_index_at(samples, t))
            .collect();
        let ages = Float64Array::from_iter(
            latest
                .iter()
                .map(|l| l.map(|(_, age)| age as f64 / NS_PER_S as f64)),
        );
        columns.push((
            with_unit(
                Field::new(format!("{prefix}age_s"), DataType::Float64, true),
                "s",
            ),
            Arc::new(ages),
        ));
        let rows: Vec<Option<usize>> = latest.iter().map(|l| l.map(|(i, _)| i)).collect();
        columns.extend(property_columns(samples, &rows, &prefix));
    }
    batch(columns)
}
