//! Parquet files from Arrow batches (zstd-compressed, Arrow schema embedded).

use arrow_array::RecordBatch;
use arrow_schema::{Schema, SchemaRef};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::WriterProperties;
use parquet::schema::types::ColumnPath;
use std::io::Write;

/// Rows per record batch and row group when writing a stream.
pub const ROWS_PER_BATCH: usize = 64 * 1024;

/// Error of a Parquet write.
pub type ParquetError = parquet::errors::ParquetError;

/// A Parquet file being written a batch at a time (all of one schema).
pub struct TableWriter<W: Write + Send> {
    inner: ArrowWriter<W>,
}

impl<W: Write + Send> TableWriter<W> {
    /// A writer of batches of `schema` to `out`.
    pub fn new(out: W, schema: SchemaRef) -> Result<Self, ParquetError> {
        let props = properties(&schema);
        Ok(TableWriter {
            inner: ArrowWriter::try_new(out, schema, Some(props))?,
        })
    }

    pub fn write(&mut self, batch: &RecordBatch) -> Result<(), ParquetError> {
        self.inner.write(batch)
    }

    /// Writes the footer and hands the output back.
    pub fn finish(self) -> Result<W, ParquetError> {
        self.inner.into_inner()
    }
}

/// Dictionaries only for text columns: a float column's values hardly repeat, and trying
/// (then falling back) costs more than the rest of the write.
fn properties(schema: &Schema) -> WriterProperties {
    let text_columns = schema
        .fields()
        .iter()
        .filter(|f| {
            matches!(
                f.data_type(),
                arrow_schema::DataType::Utf8 | arrow_schema::DataType::Dictionary(..)
            )
        })
        .map(|f| ColumnPath::from(f.name().as_str()))
        .collect::<Vec<_>>();
    text_columns
        .into_iter()
        .fold(
            WriterProperties::builder().set_dictionary_enabled(false),
            |b, column| b.set_column_dictionary_enabled(column, true),
        )
        .set_compression(Compression::ZSTD(ZstdLevel::default()))
        .set_created_by(concat!("hindsight ", env!("CARGO_PKG_VERSION")).to_string())
        // A row group is held in memory until it is written: bounded, so that a day-long
        // mission's tables stream out.
        .set_max_row_group_row_count(Some(2 * ROWS_PER_BATCH))
        .build()
}

/// Writes batches (all of one schema) produced by `next_batch` until it returns `None`.
pub fn write_batches<W: Write + Send>(
    out: W,
    first: RecordBatch,
    mut next_batch: impl FnMut() -> Option<Result<RecordBatch, arrow_schema::ArrowError>>,
) -> Result<W, ParquetError> {
    let mut writer = TableWriter::new(out, first.schema())?;
    writer.write(&first)?;
    while let Some(batch) = next_batch() {
        writer.write(&batch?)?;
    }
    writer.finish()
}
