//! The trajectory table: written to `trajectory.csv` as the run goes (to a
//! temporary file renamed on success, so a failed run never leaves a
//! truncated file that looks complete) and kept in memory for the figures.
//!
//! Columns: `t`; the coordinates in model order; their velocities in the
//! same order (`<coord>d`); then the optional groups the scene's
//! `output.include` asks for, in this order (see [`OutputGroup`]): energy
//! (`T`, `W`, `W_<effect>` \[J\]), points (`<point>.x`, `<point>.y` \[m\]),
//! effects (`tau_<effect>` \[N m\] or `F_<effect>` \[N\]), constraint forces
//! (`F_<hinge>.x`, `F_<hinge>.y`, `F_<skate>` \[N\]), residuals (`res_phi`
//! = `max|C(q)|` \[m\], `res_vel` = `max|G(q) qd|` \[m/s\]).

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Model, Observer, OutputGroup, Sample, Scene, SimError};

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
    /// The constraint forces could not be computed at an output time.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The CSV writer failed.
    #[error("{path}: {source}")]
    Csv {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: csv::Error,
    },
}

/// Assembles one output row from a sample: `t`, `q`, `qd`, then exactly the
/// groups the scene asks for (see [`OutputGroup`]); a group not asked for
/// is not computed.
pub struct RowBuilder<M: Model> {
    /// Column names, from [`Scene::columns`].
    pub columns: Vec<String>,
    energy: bool,
    points: bool,
    effects: bool,
    residuals: bool,
    /// A copy of the dynamics for the multipliers at output times
    /// (constraint forces asked for).
    probe: Option<Box<ForceProbe<M>>>,
    point_buf: Vec<f64>,
    f_scratch: Vec<f64>,
}

/// Solves the KKT system at an output sample for the constraint forces.
struct ForceProbe<M: Model> {
    sys: Dynamics<M>,
    y: Vec<f64>,
    dy: Vec<f64>,
}

impl<M: Model> RowBuilder<M> {
    /// The row layout of `scene` for the run `sys`.
    pub fn new(scene: &Scene, sys: &Dynamics<M>) -> Self {
        let probe = scene.includes(OutputGroup::ConstraintForces).then(|| {
            let mut copy =
                Dynamics::new(sys.model.clone(), sys.effects.clone(), KktMethod::Auto).with_drives(sys.drives.clone());
            copy.baumgarte = sys.baumgarte;
            let ny = copy.ny();
            Box::new(ForceProbe { sys: copy, y: vec![0.0; ny], dy: vec![0.0; ny] })
        });
        Self {
            columns: scene.columns(&sys.info),
            energy: scene.includes(OutputGroup::Energy),
            points: scene.includes(OutputGroup::Points),
            effects: scene.includes(OutputGroup::Effects),
            residuals: scene.includes(OutputGroup::Residuals),
            probe,
            point_buf: vec![0.0; 2 * sys.info.points.len()],
            f_scratch: vec![0.0; sys.nq()],
        }
    }

    /// Fills `row` for sample `s` of the run `sys`.
    ///
    /// # Errors
    /// [`SimError`] if the KKT solve for the constraint forces fails.
    pub fn fill(&mut self, sys: &Dynamics<M>, s: &Sample<'_>, row: &mut Vec<f64>) -> Result<(), SimError> {
        row.clear();
        row.push(s.t);
        row.extend_from_slice(s.q);
        row.extend_from_slice(s.qd);
        if self.energy {
            row.push(s.kinetic_energy);
            row.push(s.work);
            row.extend_from_slice(s.works);
        }
        if self.points {
            sys.model.points(s.q, &mut self.point_buf);
            row.extend_from_slice(&self.point_buf);
        }
        if self.effects {
            self.f_scratch.fill(0.0);
            for e in &sys.effects {
                row.push(e.apply(s.t, s.q, s.qd, &mut self.f_scratch).1);
            }
        }
        if let Some(p) = &mut self.probe {
            let nq = sys.nq();
            p.y[..nq].copy_from_slice(s.q);
            p.y[nq..2 * nq].copy_from_slice(s.qd);
            p.sys.rhs(s.t, &p.y, &mut p.dy)?;
            // M qdd = f - G^T lambda: the constraint force on the
            // coordinates is -G^T lambda, so a hinge row `r_a - r_b` pushes
            // body a with -lambda and a skate row (unit normal n) with -lambda n.
            row.extend(p.sys.lambda().iter().map(|l| -l));
        }
        if self.residuals {
            row.push(s.residual_position);
            row.push(s.residual_velocity);
        }
        Ok(())
    }
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
pub struct CsvObserver<M: Model> {
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
    builder: RowBuilder<M>,
    progress: Option<crate::progress::Progress>,
}

impl<M: Model> CsvObserver<M> {
    /// Creates `path`'s temporary sibling and writes the header; `rows` is
    /// the expected number of rows (the table is preallocated).
    ///
    /// # Errors
    /// [`OutputError`] if the file cannot be created or written.
    pub fn create(
        path: &Path,
        builder: RowBuilder<M>,
        progress: Option<crate::progress::Progress>,
        rows: usize,
    ) -> Result<Self, OutputError> {
        let columns = builder.columns.clone();
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
            builder,
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

impl<M: Model> Observer<M> for CsvObserver<M> {
    type Error = OutputError;

    fn observe(&mut self, sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), OutputError> {
        self.builder.fill(sys, s, &mut self.row)?;
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
