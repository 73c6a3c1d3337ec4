//! The trajectory table: written to `trajectory.csv` as the run goes (into
//! the run's [`Transaction`], committed with the figures only when the whole
//! run succeeded, so a failed or interrupted run never leaves a truncated
//! file that looks complete) and kept in memory for the figures.
//!
//! Columns: `t`; the coordinates in model order; their velocities in the
//! same order (`<coord>d`); then the optional groups the scene's
//! `output.include` asks for, in this order (see [`OutputGroup`]): energy
//! (`T`, `W`, `W_<effect>` \[J\]), points (`<point>.x`, `<point>.y` \[m\]),
//! point velocities (`<point>.vx`, `<point>.vy` \[m/s\]), effects
//! (`tau_<effect>` \[N m\] or `F_<effect>` \[N\]), constraint forces
//! (`F_<hinge>.x`, `F_<hinge>.y`, `F_<skate>` \[N\]), accelerations
//! (`<coord>dd`), residuals (`res_phi`
//! = `max|C(q)|` \[m\], `res_vel` = `max|G(q) qd|` \[m/s\]).

use std::fs::File;
use std::path::PathBuf;

use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Model, Observer, OutputGroup, Sample, Scene, SimError};

use crate::transaction::{Transaction, TransactionError};

/// Errors writing the table.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A file could not be written (the path is the file's final name).
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The constraint forces could not be computed at an output time.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The CSV writer failed (the path is the file's final name).
    #[error("{}: {source}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: csv::Error,
    },
    /// Creating the file in the run's transaction failed, or a signal
    /// stopped the run.
    #[error(transparent)]
    Transaction(#[from] TransactionError),
}

/// Assembles one output row from a sample: `t`, `q`, `qd`, then exactly the
/// groups the scene asks for (see [`OutputGroup`]); a group not asked for
/// is not computed.
pub struct RowBuilder<M: Model> {
    /// Column names, from [`Scene::columns`].
    pub columns: Vec<String>,
    energy: bool,
    points: bool,
    point_velocities: bool,
    effects: bool,
    forces: bool,
    accelerations: bool,
    residuals: bool,
    /// A copy of the dynamics for the multipliers and accelerations at
    /// output times (constraint forces or accelerations asked for).
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
        let forces = scene.includes(OutputGroup::ConstraintForces);
        let accelerations = scene.includes(OutputGroup::Accelerations);
        let probe = (forces || accelerations).then(|| {
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
            point_velocities: scene.includes(OutputGroup::PointVelocities),
            effects: scene.includes(OutputGroup::Effects),
            forces,
            accelerations,
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
        if self.point_velocities {
            sys.model.point_velocities(s.q, s.qd, &mut self.point_buf);
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
            if self.forces {
                row.extend(p.sys.lambda().iter().map(|l| -l));
            }
            if self.accelerations {
                row.extend_from_slice(&p.dy[nq..2 * nq]);
            }
        }
        if self.residuals {
            row.push(s.residual_position);
            row.push(s.residual_velocity);
        }
        Ok(())
    }
}

/// Bytes the CSV writer gathers before a write to the file.
const CSV_BUFFER: usize = 1 << 16;

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

/// What sees every output row as it is written (a sweep's metrics):
/// the sample and the row.
pub type Tap<'a> = &'a mut dyn FnMut(&Sample<'_>, &[f64]);

/// Writes samples to CSV and keeps them for figures.
pub struct CsvObserver<'a, M: Model> {
    /// The final path (errors name it).
    path: PathBuf,
    /// The output directory (an interruption names it).
    dir: PathBuf,
    writer: csv::Writer<File>,
    /// The rows kept for the figures: every `keep`-th row written, at most
    /// [`FIGURE_ROWS`] (the CSV streams every row; memory does not grow
    /// with the horizon).
    pub table: Table,
    keep: u64,
    written: u64,
    row: Vec<f64>,
    builder: RowBuilder<M>,
    progress: Option<crate::progress::Progress>,
    tap: Option<Tap<'a>>,
}

impl<'a, M: Model> CsvObserver<'a, M> {
    /// Creates the table `name` (`trajectory.csv`) in the transaction `tx`
    /// (the first file of the transaction, so the last one committed) and
    /// writes the header; `rows` is the expected number of rows (the table
    /// is preallocated).
    ///
    /// # Errors
    /// [`OutputError`] if the file cannot be created or written.
    pub fn create(
        tx: &mut Transaction,
        name: &str,
        builder: RowBuilder<M>,
        progress: Option<crate::progress::Progress>,
        rows: usize,
    ) -> Result<Self, OutputError> {
        let columns = builder.columns.clone();
        let path = tx.path(name);
        let file = tx.create(name)?;
        // the writer's own buffer, 64 KiB: one write call per ~3,000 numbers
        let mut writer = csv::WriterBuilder::new().buffer_capacity(CSV_BUFFER).from_writer(file);
        writer.write_record(&columns).map_err(|source| OutputError::Csv { path: path.clone(), source })?;
        let n = columns.len();
        Ok(Self {
            path,
            dir: tx.dir().to_path_buf(),
            writer,
            table: Table { columns, data: Vec::with_capacity(rows.min(FIGURE_ROWS + 1) * n) },
            keep: 1,
            written: 0,
            row: Vec::with_capacity(n),
            builder,
            progress,
            tap: None,
        })
    }

    /// Shows every row, as written, to `tap` too.
    #[must_use]
    pub fn with_tap(mut self, tap: Tap<'a>) -> Self {
        self.tap = Some(tap);
        self
    }

    /// Flushes and syncs the file (its transaction commits it) and returns
    /// the rows kept for the figures.
    ///
    /// # Errors
    /// [`OutputError`] if flushing or syncing fails (a full disk).
    pub fn finish(mut self) -> Result<Table, OutputError> {
        if let Some(p) = self.progress.take() {
            p.finish();
        }
        let io = |source| OutputError::Io { path: self.path.clone(), source };
        let file = self.writer.into_inner().map_err(|e| io(e.into_error()))?;
        crate::transaction::sync(&file, &self.path)?;
        Ok(self.table)
    }

    /// Stops writing (after a failed run); the transaction, dropped
    /// uncommitted, removes the file.
    pub fn abandon(self) {
        if let Some(p) = &self.progress {
            p.finish();
        }
    }
}

impl<M: Model> Observer<M> for CsvObserver<'_, M> {
    type Error = OutputError;

    fn observe(&mut self, sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), OutputError> {
        crate::transaction::check_interrupt(&self.dir, Some(s.t), None)?;
        self.builder.fill(sys, s, &mut self.row)?;
        let mut buf = ryu::Buffer::new();
        for &v in &self.row {
            self.writer
                .write_field(buf.format(v))
                .map_err(|source| OutputError::Csv { path: self.path.clone(), source })?;
        }
        self.writer
            .write_record(None::<&[u8]>)
            .map_err(|source| OutputError::Csv { path: self.path.clone(), source })?;
        if let Some(tap) = &mut self.tap {
            tap(s, &self.row);
        }
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

    /// Stops the run if a signal arrived (see [`crate::transaction`]).
    fn poll(&mut self, t: f64) -> Result<(), OutputError> {
        Ok(crate::transaction::check_interrupt(&self.dir, Some(t), None)?)
    }

    fn progress(&mut self, t: f64) {
        if let Some(p) = &mut self.progress {
            p.update(t);
        }
    }

    fn note(&mut self, text: &str) {
        match &self.progress {
            Some(p) => p.println(&format!("note: {text}")),
            None => {
                eprintln!("note: {text}");
            }
        }
    }
}
