//! What an optimization asks for: a gait's quantity or a function of a
//! run, minimized or maximized, and bounds on others.

use std::sync::Arc;

use crate::analysis::AnalysisError;
use crate::analysis::periodic::PeriodicOrbit;
use crate::sensitivity::Sensitivities;
use crate::sensitivity::gait::GaitSensitivities;

/// A quantity of a gait (the periodic orbit of a periodically driven
/// scene), by the name `periodic.csv` gives it (`gait.<name>` on the
/// command line). Each is defined, with its unit, frame and time, in the
/// quantities table ([`GaitQuantity::entry`], [`crate::quantities`]):
/// the gait is taken at the forcing's phase 0, the reference body is the
/// model's first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GaitQuantity {
    /// `mean_speed`: the reference body's `|displacement| / T` \[m/s\].
    MeanSpeed,
    /// `mean_forward_speed`: the displacement along its heading at the
    /// period's start over `T` \[m/s\].
    MeanForwardSpeed,
    /// `displacement`: `|displacement|` per period \[m\].
    Displacement,
    /// `dx`: the forward displacement per period \[m\].
    Dx,
    /// `dy`: the lateral displacement per period \[m\].
    Dy,
    /// `dheading`: the heading change per period \[rad\].
    HeadingChange,
    /// `mean_power`: the actuators' mean input power \[W\].
    MeanPower,
    /// `efficiency`: mean speed per mean input power \[m/J\].
    Efficiency,
    /// `period`: the period `T` \[s\].
    Period,
}

impl GaitQuantity {
    /// Every quantity, in the order of their names' list.
    pub const ALL: [Self; 9] = [
        Self::MeanSpeed,
        Self::MeanForwardSpeed,
        Self::Displacement,
        Self::Dx,
        Self::Dy,
        Self::HeadingChange,
        Self::MeanPower,
        Self::Efficiency,
        Self::Period,
    ];

    /// The name (`mean_speed`, ..., as in `periodic.csv`).
    pub fn name(self) -> &'static str {
        match self {
            Self::MeanSpeed => "mean_speed",
            Self::MeanForwardSpeed => "mean_forward_speed",
            Self::Displacement => "displacement",
            Self::Dx => "dx",
            Self::Dy => "dy",
            Self::HeadingChange => "dheading",
            Self::MeanPower => "mean_power",
            Self::Efficiency => "efficiency",
            Self::Period => "period",
        }
    }

    /// Its entry in the quantities table (`gait.<name>` of
    /// `optimum.csv`): unit, definition, formula, frame and time.
    pub fn entry(self) -> Option<&'static crate::quantities::Column> {
        let name = format!("gait.{}", self.name());
        crate::quantities::lookup("optimum.csv", &name, &crate::quantities::Names::default()).filter(|c| c.name == name)
    }

    /// Its unit (`m/s`, `W`, ...), from the quantities table.
    pub fn unit(self) -> &'static str {
        self.entry().map_or("", |c| c.unit)
    }

    /// The quantity named `name` (`None` for another name).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|q| q.name() == name)
    }

    /// The names of every quantity, comma-separated.
    pub fn names() -> String {
        Self::ALL.map(Self::name).join(", ")
    }

    /// Its value on `orbit` and its derivatives with respect to the
    /// parameters `g` differentiated (as many as `g.parameters`).
    pub(crate) fn of(self, orbit: &PeriodicOrbit, g: &GaitSensitivities) -> (f64, Vec<f64>) {
        let np = g.parameters.len();
        match self {
            Self::MeanSpeed => (orbit.mean_speed(), g.d_mean_speed.clone()),
            Self::MeanForwardSpeed => (orbit.mean_forward_speed(), g.d_mean_forward_speed.clone()),
            Self::Displacement => {
                // |d| = mean speed * T
                let (v, t) = (orbit.mean_speed(), orbit.period);
                (v * t, (0..np).map(|j| g.d_mean_speed[j] * t + v * g.d_period[j]).collect())
            }
            Self::Dx => (orbit.displacement[0], g.d_displacement.iter().map(|d| d[0]).collect()),
            Self::Dy => (orbit.displacement[1], g.d_displacement.iter().map(|d| d[1]).collect()),
            Self::HeadingChange => (orbit.heading_change, g.d_heading_change.clone()),
            Self::MeanPower => (g.mean_power, g.d_mean_power.clone()),
            Self::Efficiency => (g.efficiency, g.d_efficiency.clone()),
            Self::Period => (orbit.period, g.d_period.clone()),
        }
    }
}

/// A function of a run and its sensitivities: its value and its
/// gradient with respect to the run's parameters (as many as
/// `Sensitivities::parameters`, in their order), or why it cannot be
/// computed.
pub type RunFunction = dyn Fn(&Sensitivities) -> Result<(f64, Vec<f64>), String> + Send + Sync;

/// A function of the design's parameters alone (no run, no gait): its
/// value and its gradient with respect to them (as many as the design's
/// parameters, in their order), for a bound on the parameters' own
/// combination (a gait's shape at an instant, linear in its Fourier
/// coefficients: [`crate::design::gait::DriveGait::range`]).
pub type ValuesFunction = dyn Fn(&[f64]) -> (f64, Vec<f64>) + Send + Sync;

/// A quantity an optimization minimizes, maximizes or bounds.
#[derive(Clone)]
pub enum Quantity {
    /// A quantity of the scene's gait: its periodic orbit is found at
    /// each point (from the last one's), the derivatives by the implicit
    /// function theorem ([`crate::Problem::gait_sensitivities`]).
    Gait(GaitQuantity),
    /// A function of a run: the run and its sensitivities at each point
    /// ([`crate::Problem::sensitivities_with`]).
    Run {
        /// Its name in the output (`final(x1)`).
        name: String,
        /// The value and gradient from the run.
        function: Arc<RunFunction>,
    },
    /// A function of the parameters' values alone, evaluated without a
    /// run.
    Values {
        /// Its name in the output (`D(t = 0.5 s)`).
        name: String,
        /// The value and gradient from the parameters' values.
        function: Arc<ValuesFunction>,
    },
}

impl std::fmt::Debug for Quantity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

impl Quantity {
    /// A function of a run named `name` (a user's own objective: the run's
    /// state and sensitivities in, value and gradient out).
    pub fn run(
        name: impl Into<String>,
        function: impl Fn(&Sensitivities) -> Result<(f64, Vec<f64>), String> + Send + Sync + 'static,
    ) -> Self {
        Self::Run { name: name.into(), function: Arc::new(function) }
    }

    /// A function of the parameters' values named `name`: value and
    /// gradient from the values.
    pub fn values(
        name: impl Into<String>,
        function: impl Fn(&[f64]) -> (f64, Vec<f64>) + Send + Sync + 'static,
    ) -> Self {
        Self::Values { name: name.into(), function: Arc::new(function) }
    }

    /// The name: `gait.<quantity>`, or the run's or the values' function's.
    pub fn name(&self) -> String {
        match self {
            Self::Gait(q) => format!("gait.{}", q.name()),
            Self::Run { name, .. } | Self::Values { name, .. } => name.clone(),
        }
    }

    /// `gait.<quantity>`.
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for another name, listing the gait's
    /// quantities.
    pub fn gait(name: &str) -> Result<Self, AnalysisError> {
        name.strip_prefix("gait.").and_then(GaitQuantity::from_name).map(Self::Gait).ok_or_else(|| {
            AnalysisError::Request {
                reason: format!("`{name}` is not a gait's quantity; known: gait.{{{}}}", GaitQuantity::names()),
            }
        })
    }
}

/// Whether an optimization minimizes or maximizes its objective.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sense {
    /// The smallest value within the bounds and constraints.
    Minimize,
    /// The largest.
    Maximize,
}

/// A bound on a quantity: `quantity <= bound` (`upper`) or `>= bound`.
#[derive(Debug, Clone)]
pub struct Constraint {
    /// The quantity bounded.
    pub quantity: Quantity,
    /// `<=` (true) or `>=` (false).
    pub upper: bool,
    /// The bound, in the quantity's unit.
    pub bound: f64,
}

impl Constraint {
    /// `gait.mean_power <= 1`.
    pub fn text(&self) -> String {
        format!(
            "{} {} {}",
            self.quantity.name(),
            if self.upper { "<=" } else { ">=" },
            crate::names::fmt_value(self.bound)
        )
    }

    /// How far `value` violates it (0 when it holds), in the quantity's unit.
    pub fn violation(&self, value: f64) -> f64 {
        if self.upper { (value - self.bound).max(0.0) } else { (self.bound - value).max(0.0) }
    }
}

/// An optimization's request: the objective, its sense, the constraints.
#[derive(Debug, Clone)]
pub struct Goal {
    /// What is minimized or maximized.
    pub objective: Quantity,
    /// Which.
    pub sense: Sense,
    /// Bounds on other quantities (or the objective itself).
    pub constraints: Vec<Constraint>,
}

impl Goal {
    /// The objective first, then each constraint's quantity.
    pub(crate) fn quantities(&self) -> Vec<&Quantity> {
        std::iter::once(&self.objective).chain(self.constraints.iter().map(|c| &c.quantity)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::GaitQuantity;

    /// Every gait quantity has its entry in the quantities table under its
    /// own name, with the unit its documentation gives, and the table's
    /// list of names is this one's.
    #[test]
    fn every_gait_quantity_is_in_the_table_with_its_unit() {
        let units = ["m/s", "m/s", "m", "m", "m", "rad", "W", "m/J", "s"];
        for (q, unit) in GaitQuantity::ALL.into_iter().zip(units) {
            let entry = q.entry().unwrap_or_else(|| panic!("gait.{} is not in the table", q.name()));
            assert_eq!(entry.unit, unit, "{}", q.name());
            assert_eq!(q.unit(), unit);
        }
        assert_eq!(GaitQuantity::ALL.map(GaitQuantity::name), crate::quantities::GAIT_QUANTITIES);
    }
}
