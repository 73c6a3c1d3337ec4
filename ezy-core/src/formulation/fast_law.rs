//! A run's failure explained by the force law too fast for it: the
//! step size collapsed, the budget spent or a fixed step blown up, where
//! an effect's time scale is below what the run resolves.

use crate::error::SimError;
use crate::names::fmt_value;

impl SimError {
    /// The failure with the force law named that is faster than the run
    /// can follow, when one is: the step size of an adaptive method
    /// collapsed ([`SimError::StepSizeTooSmall`]) or spent its budget, or a
    /// fixed-step run blew up ([`SimError::NonFinite`],
    /// [`SimError::Diverged`]). The law's time scale
    /// ([`crate::effects::Effect::time_scale`], `sqrt(m / k)` or `m / c`)
    /// is compared with the shortest a run resolves: a fixed step `dt`
    /// resolves down to `dt / 2` (explicit Euler is stable on the negative
    /// real axis up to `h |lambda| = 2`, RK4 to 2.785), an adaptive method
    /// down to `10 t_end / max_steps` (an explicit method of order 5 to 8
    /// takes about ten steps per time scale at the tolerances runs use, so
    /// a faster law needs more steps than the budget). A failure without
    /// such a law is returned as it is. (A spring of 1e17 N/m on the
    /// four-bar, time scale 2.4e-9 s against 1e-8 s for 0.1 s in 1e8 steps,
    /// used to stop with "the step size fell" and nothing more.)
    pub fn with_fast_law(
        self,
        effects: &[crate::effects::Effect],
        mass: &[f64],
        settings: &crate::settings::RunSettings,
    ) -> Self {
        let adaptive = settings.method.is_adaptive();
        let applies = match &self {
            SimError::StepSizeTooSmall { .. } => true,
            SimError::Budget { what, .. } => adaptive && *what == "steps",
            SimError::NonFinite { .. } | SimError::Diverged { .. } => !adaptive,
            _ => false,
        };
        if !applies {
            return self;
        }
        let (resolved, why) = if adaptive {
            let budget = settings.max_steps.unwrap_or(crate::settings::DEFAULT_MAX_STEPS) as f64;
            (10.0 * settings.t_end / budget, "ten steps per time scale within the run's step budget")
        } else {
            (settings.dt / 2.0, "half the step dt")
        };
        let fastest = effects
            .iter()
            .filter_map(|e| e.time_scale(mass).map(|ts| (e, ts)))
            .min_by(|a, b| a.1.seconds.total_cmp(&b.1.seconds));
        match fastest {
            Some((e, ts)) if ts.seconds < resolved => SimError::Caused {
                error: Box::new(self),
                cause: format!(
                    "the effect `{}` is faster than the run can follow: its {} = {} on a mass or inertia of {} gives a time scale of {:.1e} s, below {:.1e} s ({why}); check its `{}`",
                    e.name,
                    ts.key,
                    fmt_value(ts.value),
                    fmt_value(ts.mass),
                    ts.seconds,
                    resolved,
                    ts.key
                ),
            },
            _ => self,
        }
    }
}
