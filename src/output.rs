//! The trajectory table: written to `trajectory.csv` as the run goes (to a
//! temporary file renamed on success, so a failed run never leaves a
//! truncated file that looks complete) and kept in memory for the figures.
//!
//! Columns: `t`; the coordinates in model order; their velocities in the
//! same order (`<coord>d`); `T` (kinetic energy [J]); `W` (work of the
//! applied forces [J]); `<point>.x`, `<point>.y` for every named point [m];
//! one column per effect (`tau_<hinge>` [N m] for a hinge motor); `res_phi`
//! (`max|C(q)|` [m]) and `res_vel` (`max|G(q) qd|` [m/s]).

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use ezy_core::{Dynamics, Model, Observer, Sample};

/// Errors writing the table.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A file could not be created, written or renamed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The CSV writer failed.
    #[error("{path}: {source}")]
    Csv {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: csv::Error,
    },
}

/// The column names for model `M` with the given effect columns.
pub fn columns<M: Model>(effect_columns: &[String]) -> Vec<String> {
    let info = &M::INFO;
    let mut cols = vec!["t".to_string()];
    cols.extend(info.coords.iter().map(|c| c.to_string()));
    cols.extend(info.coords.iter().map(|c| format!("{c}d")));
    cols.push("T".into());
    cols.push("W".into());
    for p in info.points {
        cols.push(format!("{}.x", p.name));
        cols.push(format!("{}.y", p.name));
    }
    cols.extend(effect_columns.iter().cloned());
    cols.push("res_phi".into());
    cols.push("res_vel".into());
    cols
}

/// Most rows kept in memory for the figures; beyond it every other row is
/// dropped and the sampling interval doubles.
pub const FIGURE_ROWS: usize = 20_000;

/// The in-memory table: column names and row-major values.
#[derive(Debug, Clone, Default)]
pub struct Table {
    /// Column names.
    pub columns: Vec<String>,
    /// Values, `columns.len()` per row.
    pub data: Vec<f64>,
}

impl Table {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        if self.columns.is_empty() { 0 } else { self.data.len() / self.columns.len() }
    }
    /// Index of a column.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }
    /// The values of column `k`.
    pub fn column(&self, k: usize) -> impl Iterator<Item = f64> + '_ {
        self.data.iter().skip(k).step_by(self.columns.len()).copied()
    }
}

/// Writes samples to CSV and keeps them for figures.
pub struct CsvObserver {
    path: PathBuf,
    tmp: PathBuf,
    writer: csv::Writer<BufWriter<File>>,
    /// The rows kept for the figures: every `keep`-th row written, at most
    /// [`FIGURE_ROWS`] (the CSV streams every row; memory does not grow
    /// with the horizon).
    pub table: Table,
    keep: u64,
    written: u64,
    row: Vec<f64>,
    points: Vec<f64>,
    progress: Option<crate::progress::Progress>,
}

impl CsvObserver {
    /// Creates `path`'s temporary sibling and writes the header; `rows` is
    /// the expected number of rows (the table is preallocated).
    ///
    /// # Errors
    /// [`OutputError`] if the file cannot be created or written.
    pub fn create(
        path: &Path,
        columns: Vec<String>,
        progress: Option<crate::progress::Progress>,
        rows: usize,
    ) -> Result<Self, OutputError> {
        let tmp = path.with_extension("csv.partial");
        let file = File::create(&tmp).map_err(|source| OutputError::Io { path: tmp.clone(), source })?;
        let mut writer = csv::Writer::from_writer(BufWriter::new(file));
        writer.write_record(&columns).map_err(|source| OutputError::Csv { path: tmp.clone(), source })?;
        let n = columns.len();
        Ok(Self {
            path: path.to_path_buf(),
            tmp,
            writer,
            table: Table { columns, data: Vec::with_capacity(rows.min(FIGURE_ROWS + 1) * n) },
            keep: 1,
            written: 0,
            row: Vec::with_capacity(n),
            points: Vec::new(),
            progress,
        })
    }

    /// Flushes and renames the temporary file to its final name.
    ///
    /// # Errors
    /// [`OutputError`] if flushing or renaming fails.
    pub fn finish(mut self) -> Result<Table, OutputError> {
        if let Some(p) = self.progress.take() {
            p.finish();
        }
        self.writer.flush().map_err(|source| OutputError::Io { path: self.tmp.clone(), source })?;
        drop(self.writer);
        std::fs::rename(&self.tmp, &self.path).map_err(|source| OutputError::Io { path: self.path.clone(), source })?;
        Ok(self.table)
    }

    /// Removes the temporary file (after a failed run).
    pub fn abandon(self) {
        if let Some(p) = &self.progress {
            p.finish();
        }
        drop(self.writer);
        let _ = std::fs::remove_file(&self.tmp);
    }
}

impl<M: Model> Observer<M> for CsvObserver {
    type Error = OutputError;

    fn observe(&mut self, sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), OutputError> {
        let info = &M::INFO;
        self.points.resize(2 * info.points.len(), 0.0);
        sys.model.points(s.q, &mut self.points);
        self.row.clear();
        self.row.push(s.t);
        self.row.extend_from_slice(s.q);
        self.row.extend_from_slice(s.qd);
        self.row.push(s.kinetic_energy);
        self.row.push(s.work);
        self.row.extend_from_slice(&self.points);
        self.row.extend(sys.effects.iter().map(|e| e.output(s.t)));
        self.row.push(s.residual_position);
        self.row.push(s.residual_velocity);
        let mut buf = ryu::Buffer::new();
        for &v in &self.row {
            self.writer
                .write_field(buf.format(v))
                .map_err(|source| OutputError::Csv { path: self.tmp.clone(), source })?;
        }
        self.writer
            .write_record(None::<&[u8]>)
            .map_err(|source| OutputError::Csv { path: self.tmp.clone(), source })?;
        if self.written.is_multiple_of(self.keep) {
            if self.table.rows() >= FIGURE_ROWS {
                let n = self.table.columns.len();
                let kept: Vec<f64> = self.table.data.chunks(n).step_by(2).flatten().copied().collect();
                self.table.data = kept;
                self.keep *= 2;
            }
            if self.written.is_multiple_of(self.keep) {
                self.table.data.extend_from_slice(&self.row);
            }
        }
        self.written += 1;
        Ok(())
    }

    fn progress(&mut self, t: f64) {
        if let Some(p) = &mut self.progress {
            p.update(t);
        }
    }
}
