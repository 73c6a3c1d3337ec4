//! Every quantity ezy's analyses write, defined once: for each CSV file
//! `ezy analyze`, `ezy sensitivity`, `ezy optimize`, `ezy gait-optimize`,
//! `ezy plan` and `ezy geometry` write, its columns with their unit, their definition in words and as
//! a formula, the frame and time they are taken at, and the source
//! (data, [`TABLES`]). The command line's reports, the Python package's
//! `describe()` and the guide's Quantities page read it; a column is
//! found by its exact name or a pattern ([`lookup`]).
//!
//! A pattern names its variable parts in angle brackets: `<state>` a
//! coordinate or its rate (`x1`, `x1d`), `<parameter>` a parameter as
//! the command line names it (`motor.omega`, `M0`), `<hinge>` a hinge's
//! (a shape coordinate's) name, `<k>` a whole number from 1,
//! `<quantity>` a differentiated gait quantity ([`DIFFERENTIATED`]),
//! `<objective>` an optimization's objective (`gait.<name>` or a run's
//! metric), `<metric>` a run's metric (`final(x1)`, `mean(x1d, 50,
//! 60)`), `<factor>` a factor of the momentum equation (a shape rate
//! `<hinge>d` or a momentum component), and `<a|b|c>` one of the words
//! listed.

mod analysis;
mod design;
mod geometry;

/// One column of a table: its name (exact, or a pattern, see the
/// module's documentation) and what it means.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Column {
    /// The column's name as the CSV header writes it, or its pattern
    /// (`mu<k>_re`, `d<quantity>/d<parameter>`).
    pub name: &'static str,
    /// Its unit as the code writes units (`m/s`, `rad`, `W`, `m/J`), `""`
    /// for a number without one, or words where it is the unit of
    /// another quantity (`as <parameter>`).
    pub unit: &'static str,
    /// What it is, in words.
    pub meaning: &'static str,
    /// Its definition as a formula (plain text), or `""` where the words
    /// are the definition.
    pub formula: &'static str,
    /// The frame it is expressed in and the time it is taken at (`""` for
    /// a number that has neither: a count, a label).
    pub frame: &'static str,
    /// Where the definition comes from (a paper or book and its section),
    /// or `""`.
    pub source: &'static str,
}

/// A CSV file an analysis writes: its name, the command that writes it,
/// what a row is, and its columns.
#[derive(Debug, Clone, Copy)]
pub struct Table {
    /// The file's name (`periodic.csv`).
    pub file: &'static str,
    /// The command that writes it (`ezy analyze`).
    pub command: &'static str,
    /// When it is written and what a row holds.
    pub about: &'static str,
    /// Its columns, in groups in the order the file has them (a group
    /// shared by tables, such as the gait's quantities, is listed once
    /// in the code).
    pub groups: &'static [&'static [Column]],
}

impl Table {
    /// Every column entry, in order.
    pub fn columns(&self) -> impl Iterator<Item = &'static Column> + '_ {
        self.groups.iter().flat_map(|g| g.iter())
    }
}

/// Every table, in the order the guide lists them: `ezy analyze`'s,
/// `ezy sensitivity`'s, `ezy optimize`'s, `ezy gait-optimize`'s, `ezy
/// plan`'s, `ezy geometry`'s.
pub const TABLES: &[Table] = &[
    analysis::PERIODIC,
    analysis::EQUILIBRIA,
    analysis::BRANCH,
    analysis::BORN,
    analysis::BRANCHES,
    analysis::GROWTH,
    design::SENSITIVITY,
    design::OPTIMUM,
    design::HISTORY,
    design::GRID,
    design::GAIT_OPTIMUM,
    design::GAIT_HISTORY,
    design::PLAN,
    design::PLAN_SUMMARY,
    geometry::CONNECTION,
    geometry::CURVATURE,
    geometry::MOMENTUM,
    geometry::GAIT,
    geometry::GAIT_PATH,
];

/// The quantities of a gait that `ezy analyze --wrt` differentiates
/// (`d<quantity>/d<parameter>` in `periodic.csv`), in the order it
/// writes them.
pub const DIFFERENTIATED: [&str; 8] =
    ["period", "mean_speed", "mean_forward_speed", "dx", "dy", "dheading", "mean_power", "efficiency"];

/// The quantities of a gait an optimization takes (`gait.<name>`), as
/// `design::optimize::GaitQuantity` names them.
pub const GAIT_QUANTITIES: [&str; 9] =
    ["mean_speed", "mean_forward_speed", "displacement", "dx", "dy", "dheading", "mean_power", "efficiency", "period"];

/// The names a pattern's variable parts are matched against: a list left
/// empty matches any name without `/` (the caller does not know it).
#[derive(Debug, Clone, Copy, Default)]
pub struct Names<'a> {
    /// The state's names: the coordinates and their rates (`x1`, `x1d`).
    pub state: &'a [String],
    /// The parameters, as the command line names them (`motor.omega`).
    pub parameters: &'a [String],
    /// The hinges (the shape coordinates).
    pub hinges: &'a [String],
    /// A plan's inputs, as `ezy plan --input` names them (`push.fx`).
    pub inputs: &'a [String],
}

/// The table written to `file` (`periodic.csv`; `branch-3.csv` is
/// `branch-<k>.csv`'s), `None` for a file no analysis writes.
pub fn table(file: &str) -> Option<&'static Table> {
    let born = file
        .strip_prefix("branch-")
        .and_then(|r| r.strip_suffix(".csv"))
        .is_some_and(|k| !k.is_empty() && k.bytes().all(|c| c.is_ascii_digit()));
    let file = if born { "branch-<k>.csv" } else { file };
    TABLES.iter().find(|t| t.file == file)
}

/// The entry of column `column` of table `file` (`periodic.csv`,
/// `drift_speed`): the entry of that exact name, else the pattern that
/// matches it with its variable parts among `names` and has the most
/// literal text (`A_<u|v|w>_<hinge>` before `<hinge>`), the first of
/// those in ties; `None` for a table or a column not known.
pub fn lookup(file: &str, column: &str, names: &Names<'_>) -> Option<&'static Column> {
    let t = table(file)?;
    if let Some(exact) = t.columns().find(|c| c.name == column) {
        return Some(exact);
    }
    let literal = |c: &Column| c.name.split('<').map(|p| p.split_once('>').map_or(p, |(_, l)| l).len()).sum::<usize>();
    t.columns().filter(|c| c.name.contains('<') && matches(c.name, column, names)).fold(None, |best, c| match best {
        Some(b) if literal(b) >= literal(c) => Some(b),
        _ => Some(c),
    })
}

/// Whether `text` fits `pattern` (its literal parts exactly, each
/// `<...>` part by the names it takes, as the module says).
pub fn matches(pattern: &str, text: &str, names: &Names<'_>) -> bool {
    let Some(open) = pattern.find('<') else { return pattern == text };
    let (literal, rest) = pattern.split_at(open);
    let Some(text) = text.strip_prefix(literal) else { return false };
    let Some(close) = rest.find('>') else { return false };
    let (part, rest) = (&rest[1..close], &rest[close + 1..]);
    text.char_indices()
        .map(|(i, _)| i)
        .skip(1)
        .chain(std::iter::once(text.len()))
        .any(|i| accepts(part, &text[..i], names) && matches(rest, &text[i..], names))
}

/// Whether `text` is a value of the variable part `part` (`state`,
/// `k`, `u|v|w`, ...).
fn accepts(part: &str, text: &str, names: &Names<'_>) -> bool {
    let among = |list: &[String]| {
        if list.is_empty() { !text.is_empty() && !text.contains('/') } else { list.iter().any(|n| n == text) }
    };
    let metric = |s: &str| {
        ["final(", "mean(", "max(", "min(", "event_time(", "event_count("].iter().any(|f| s.starts_with(f))
            && s.ends_with(')')
    };
    match part {
        _ if part.contains('|') => part.split('|').any(|w| w == text),
        "k" => !text.starts_with('0') && !text.is_empty() && text.bytes().all(|b| b.is_ascii_digit()),
        "state" => among(names.state),
        "parameter" => among(names.parameters),
        "hinge" => among(names.hinges),
        "input" => among(names.inputs),
        "coefficient" => text.rsplit_once('.').is_some_and(|(h, c)| {
            accepts("hinge", h, names)
                && (c == "a0"
                    || c.strip_prefix('a').or_else(|| c.strip_prefix('b')).is_some_and(|k| accepts("k", k, names)))
        }),
        "quantity" => DIFFERENTIATED.contains(&text),
        "metric" => metric(text),
        "objective" => text.strip_prefix("gait.").is_some_and(|q| GAIT_QUANTITIES.contains(&q)) || metric(text),
        "factor" => {
            ["p_u", "p_v", "p_w"].contains(&text) || text.strip_suffix('d').is_some_and(|h| accepts("hinge", h, names))
        }
        _ => false,
    }
}

/// The text of a table's columns: one line per column, its name, unit in
/// brackets, meaning, and frame and time (`describe()` in Python).
pub fn describe(t: &Table) -> String {
    let mut s = format!("{} ({}): {}\n", t.file, t.command, t.about);
    for c in t.columns() {
        let unit = if c.unit.is_empty() { String::new() } else { format!(" [{}]", c.unit) };
        let frame = if c.frame.is_empty() { String::new() } else { format!(" ({})", c.frame) };
        s.push_str(&format!("  {}{unit}: {}{frame}\n", c.name, c.meaning));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| (*s).to_string()).collect()
    }

    /// Exact names come before patterns, and a pattern's parts match only
    /// the names given.
    #[test]
    fn columns_are_found_by_name_and_by_pattern() {
        let (state, params, hinges) = (names(&["x1", "x1d"]), names(&["motor.omega"]), names(&["B"]));
        let n = Names { state: &state, parameters: &params, hinges: &hinges, inputs: &[] };
        let unit = |file: &str, col: &str| lookup(file, col, &n).map(|c| c.unit);
        assert_eq!(unit("periodic.csv", "drift_speed"), Some("m/s"));
        assert_eq!(unit("periodic.csv", "dx_world"), Some("m"));
        assert_eq!(lookup("periodic.csv", "x1", &n).unwrap().name, "<state>");
        assert_eq!(lookup("periodic.csv", "mu12_im", &n).unwrap().name, "mu<k>_im");
        assert_eq!(lookup("periodic.csv", "dmean_speed/dmotor.omega", &n).unwrap().name, "d<quantity>/d<parameter>");
        assert_eq!(lookup("periodic.csv", "theta_B", &n).unwrap().name, "theta_<hinge>");
        assert_eq!(lookup("periodic.csv", "turns_x1", &n).unwrap().name, "turns_<state>");
        assert_eq!(
            lookup("history.csv", "dgait.mean_speed/dmotor.omega", &n).unwrap().name,
            "d<objective>/d<parameter>"
        );
        assert_eq!(lookup("momentum.csv", "p_u:Bd*p_u", &n).unwrap().name, "p_<u|v|w>:<factor>*<factor>");
        // without the names, any name fits a variable part, the most specific pattern first
        let any = Names::default();
        assert_eq!(lookup("connection.csv", "A_u_B", &any).unwrap().name, "A_<u|v|w>_<hinge>");
        assert_eq!(lookup("connection.csv", "B", &any).unwrap().name, "<hinge>");
        for (file, col) in [
            ("periodic.csv", "y9"),
            ("periodic.csv", "mu0_re"),
            ("periodic.csv", "dspeed/dmotor.omega"),
            ("momentum.csv", "p_u:Cd*p_u"),
            ("nope.csv", "t"),
        ] {
            assert!(lookup(file, col, &n).is_none(), "{file} {col}");
        }
    }

    /// Every table has columns, no name twice, each with a meaning, and
    /// a pattern's variable parts are known ones.
    #[test]
    fn every_entry_is_complete() {
        for t in TABLES {
            let cols: Vec<&Column> = t.columns().collect();
            assert!(!cols.is_empty(), "{}", t.file);
            for (k, c) in cols.iter().enumerate() {
                assert!(!c.meaning.is_empty(), "{} {}", t.file, c.name);
                assert!(cols[..k].iter().all(|d| d.name != c.name), "{}: {} twice", t.file, c.name);
                let mut rest = c.name;
                while let Some(i) = rest.find('<') {
                    let end = rest[i..].find('>').map(|e| i + e).expect(c.name);
                    let part = &rest[i + 1..end];
                    assert!(
                        part.contains('|')
                            || [
                                "k",
                                "state",
                                "parameter",
                                "hinge",
                                "quantity",
                                "metric",
                                "objective",
                                "factor",
                                "input",
                                "coefficient"
                            ]
                            .contains(&part),
                        "{}: {}",
                        t.file,
                        c.name
                    );
                    rest = &rest[end + 1..];
                }
            }
        }
    }
}
