//! How ezy names things in messages and columns (it imports nothing of
//! the crate). Numbers as a person writes them ([`fmt_value`]) and lists
//! of names cut to a readable length ([`name_list`]).

/// A number as a person would write it: plain for ordinary magnitudes,
/// scientific below 1e-3 and from 1e6 (`1e-320`, not 320 digits).
pub fn fmt_value(v: f64) -> String {
    if v != 0.0 && v.is_finite() && (v.abs() < 1e-3 || v.abs() >= 1e6) { format!("{v:e}") } else { format!("{v}") }
}

/// At most this many names in a message listing coordinates or constraints
/// ([`name_list`]).
pub const LISTED: usize = 30;

/// `names` joined by commas: the first [`LISTED`] of them and a count of
/// the rest (a family of ten thousand links is not listed whole).
pub fn name_list<S: AsRef<str>>(names: impl IntoIterator<Item = S>) -> String {
    let mut out = String::new();
    let mut more = 0usize;
    for (k, n) in names.into_iter().enumerate() {
        if k < LISTED {
            if k > 0 {
                out.push_str(", ");
            }
            out.push_str(n.as_ref());
        } else {
            more += 1;
        }
    }
    if more > 0 {
        out.push_str(&format!(" and {more} more"));
    }
    out
}
/// The name of the velocity of coordinate `coord`: `<coord>d` (`x1d`).
pub fn velocity_name(coord: &str) -> String {
    format!("{coord}d")
}

/// The name of the work state \[J\] of the effect or drive `name`: `W_<name>`.
pub fn work_name(name: &str) -> String {
    format!("W_{name}")
}
