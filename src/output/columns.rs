//! Columns being assembled into an Arrow batch: names carry frame and unit, and each number
//! column's unit is also in its field metadata under `unit`.

use super::tables::timestamp_type;
use arrow_array::{
    ArrayRef, BooleanArray, Float64Array, RecordBatch, StringArray, TimestampNanosecondArray,
    UInt64Array,
};
use arrow_schema::{ArrowError, DataType, Field, Schema};
use std::collections::HashMap;
use std::sync::Arc;

/// Columns being assembled into one batch.
#[derive(Default)]
pub(crate) struct Columns {
    fields: Vec<Field>,
    arrays: Vec<ArrayRef>,
}

impl Columns {
    pub(crate) fn push(&mut self, field: Field, array: ArrayRef) {
        self.fields.push(field);
        self.arrays.push(array);
    }

    pub(crate) fn stamps(&mut self, values: Vec<i64>) {
        self.push(
            Field::new("stamp_ns", timestamp_type(), false),
            Arc::new(TimestampNanosecondArray::from(values).with_timezone("UTC")),
        );
    }

    pub(crate) fn text(&mut self, name: &str, values: Vec<&str>) {
        self.push(
            Field::new(name, DataType::Utf8, false),
            Arc::new(StringArray::from(values)),
        );
    }

    /// Text that may be missing (null).
    pub(crate) fn optional_text(&mut self, name: &str, values: Vec<Option<&str>>) {
        self.push(
            Field::new(name, DataType::Utf8, true),
            Arc::new(StringArray::from(values)),
        );
    }

    /// A yes/no that may be missing (null).
    pub(crate) fn optional_flag(&mut self, name: &str, values: Vec<Option<bool>>) {
        self.push(
            Field::new(name, DataType::Boolean, true),
            Arc::new(BooleanArray::from(values)),
        );
    }

    /// A count or other whole number, never missing.
    pub(crate) fn count(&mut self, name: &str, values: Vec<u64>) {
        self.push(
            Field::new(name, DataType::UInt64, false),
            Arc::new(UInt64Array::from(values)),
        );
    }

    pub(crate) fn number(&mut self, name: &str, unit: &str, values: Vec<f64>) {
        let field = Field::new(name, DataType::Float64, false)
            .with_metadata(HashMap::from([("unit".to_string(), unit.to_string())]));
        self.push(field, Arc::new(Float64Array::from(values)));
    }

    pub(crate) fn optional(&mut self, name: &str, unit: &str, values: Vec<Option<f64>>) {
        let field = Field::new(name, DataType::Float64, true)
            .with_metadata(HashMap::from([("unit".to_string(), unit.to_string())]));
        self.push(field, Arc::new(Float64Array::from(values)));
    }

    pub(crate) fn finish(self) -> Result<RecordBatch, ArrowError> {
        RecordBatch::try_new(Arc::new(Schema::new(self.fields)), self.arrays)
    }
}
