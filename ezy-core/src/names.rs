//! How ezy names things in messages and columns (it imports nothing of
//! the crate). Numbers as a person writes them ([`fmt_value`]) and lists
//! of names cut to a readable length ([`name_list`]).

/// A number as a person would write it: plain for ordinary magnitudes,
/// scientific below 1e-3 and from 1e6 (`1e-320`, not 320 digits).
pub fn fmt_value(v: f64) -> String {
    if v != 0.0 && v.is_finite() && (v.abs() < 1e-3 || v.abs() >= 1e6) { format!("{v:e}") } else { format!("{v}") }
}

/// A value located to within `width` (a bisection's last bracket) as a
/// person would write it, to the decimal place of the bracket's leading
/// digit: `0.63806389` for 0.6380638897418974 within 6e-9, `9.81` for
/// 9.810000000003 within 3e-11 ([`fmt_value`] of the value so rounded).
/// Every digit where `width` is 0 or not finite.
pub fn fmt_located(v: f64, width: f64) -> String {
    if !(width > 0.0 && width.is_finite() && v.is_finite()) || v == 0.0 {
        return fmt_value(v);
    }
    let (e_v, e_w) = (v.abs().log10().floor(), width.log10().floor());
    let digits = (e_v - e_w + 1.0).clamp(1.0, 17.0) as usize;
    let r: f64 = format!("{:.*e}", digits - 1, v).parse().unwrap_or(v);
    fmt_value(r)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_located_value_is_written_to_its_brackets_digits() {
        assert_eq!(fmt_located(0.6380638897418974, 6e-9), "0.63806389");
        assert_eq!(fmt_located(9.810000000003, 3e-11), "9.81");
        assert_eq!(fmt_located(-1234.5678, 0.01), "-1234.57");
        assert_eq!(fmt_located(0.6380638897418974, 0.0), "0.6380638897418974");
        assert_eq!(fmt_located(0.5, f64::NAN), "0.5");
        assert_eq!(fmt_located(3.0, 10.0), "3");
        assert_eq!(fmt_located(1e-5 + 1e-12, 1e-14), "1.0000001e-5");
    }
}
