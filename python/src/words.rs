//! The command line's text as a call from Python says it ([`Said`]): its
//! flags as the keywords of the call (`--continue` is `vary=`, `--rtol
//! 1e-3` is `rtol=1e-3`), and the files it wrote into a temporary
//! directory, deleted when the call returns, as the attributes of the
//! returned object that hold the same tables.

use std::path::Path;

/// How a keyword takes the value a flag is followed by in a message.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    /// A number: `--rtol 1e-3` is `rtol=1e-3`.
    Number,
    /// A choice, a string in Python: `--integrator radau5` is
    /// `integrator="radau5"`.
    Choice,
    /// Anything else: `--wrt` is `wrt=`, the value left as it stands.
    Other,
}

/// The command line's flags that a call from Python gives by a keyword:
/// the flag (without `--`), the keyword, and how it takes a value.
const FLAGS: &[(&str, &str, Kind)] = &[
    ("set", "set", Kind::Other),
    ("continue", "vary", Kind::Other),
    ("switch", "switch", Kind::Other),
    ("wrt", "wrt", Kind::Other),
    ("over", "over", Kind::Other),
    ("maximize", "maximize", Kind::Other),
    ("minimize", "minimize", Kind::Other),
    ("subject-to", "subject_to", Kind::Other),
    ("max-evaluations", "max_evaluations", Kind::Number),
    ("grid", "grid", Kind::Number),
    ("list", "grid", Kind::Other),
    ("metric", "metrics", Kind::Other),
    ("jobs", "jobs", Kind::Number),
    ("out", "out", Kind::Other),
    ("every", "every", Kind::Number),
    ("t-end", "t_end", Kind::Number),
    ("dt", "dt", Kind::Number),
    ("rtol", "rtol", Kind::Number),
    ("atol", "atol", Kind::Number),
    ("max-steps", "max_steps", Kind::Number),
    ("max-output-mb", "max_output_mb", Kind::Number),
    ("integrator", "integrator", Kind::Choice),
    ("formulation", "formulation", Kind::Choice),
    ("projection", "projection", Kind::Choice),
    ("period", "period", Kind::Number),
    ("energy", "energy", Kind::Number),
    ("at", "at", Kind::Number),
    ("input", "input", Kind::Other),
    ("gait", "gait", Kind::Other),
    ("range", "range", Kind::Other),
    ("body", "body", Kind::Other),
    ("shape", "shape", Kind::Other),
    ("momentum", "momentum", Kind::Other),
    ("data", "data", Kind::Other),
    ("columns", "columns", Kind::Other),
    ("states", "states", Kind::Number),
    ("seed", "seed", Kind::Number),
];

/// The attributes of what each function returns that hold the tables its
/// command writes: `(function, file, where the table is)`.
const TABLES: &[(&str, &str, &str)] = &[
    ("analyze", "periodic.csv", ".periodic"),
    ("analyze", "equilibria.csv", ".equilibria"),
    ("analyze", "branch.csv", ".branch"),
    ("analyze", "branches.csv", ".diagram"),
    ("analyze", "growth.csv", ".growth"),
    ("geometry", "connection.csv", ".connection"),
    ("geometry", "curvature.csv", ".curvature"),
    ("geometry", "momentum.csv", ".momentum"),
    ("geometry", "gait.csv", ".gait"),
    ("geometry", "gait-path.csv", ".tables[\"gait_path\"]"),
    ("linearize", "A.csv", ".A"),
    ("linearize", "B.csv", ".B"),
    ("linearize", "eigenvalues.csv", ".eigenvalues"),
    ("linearize", "state.csv", ".state"),
    ("sensitivity", "sensitivity.csv", "the returned DataFrame"),
    ("fit", "fit.csv", "the returned DataFrame"),
    ("optimize", "optimum.csv", "the returned DataFrame"),
    ("optimize", "history.csv", "its .attrs[\"history\"]"),
    ("optimize", "grid.csv", "its .attrs[\"grid\"]"),
];

/// How the text of one command run for a Python call is said to the
/// caller: the call's function, the temporary directory its files went
/// to when no `out=` kept them, and the scene file written there for a
/// scene made in Python (said as the scene's name).
pub(crate) struct Said<'a> {
    /// The function called (`"analyze"`), the command's name.
    pub(crate) function: &'a str,
    /// The temporary directory, deleted when the call returns.
    pub(crate) temp: Option<&'a Path>,
    /// The scene file written into `temp` and the scene's name.
    pub(crate) scene: Option<(String, String)>,
    /// Whether what the command prints is a report (with the files it
    /// wrote and notes that may name flags).
    pub(crate) report: bool,
}

impl Said<'_> {
    /// A call of `function` whose command writes no file and prints no
    /// report but its output (`equations`, `check`).
    pub(crate) fn plain(function: &str) -> Said<'_> {
        Said { function, temp: None, scene: None, report: false }
    }

    /// What the command printed: a report said as [`Said::text`] says
    /// it, another output (equations, a check's table) as it is.
    pub(crate) fn report(&self, text: &str) -> String {
        if self.report { self.text(text) } else { text.to_string() }
    }

    /// An error's message or a report, as Python's caller reads it: no
    /// flag, no file that is gone (see the module's doc).
    pub(crate) fn text(&self, text: &str) -> String {
        let mut text = text.to_string();
        if let Some((file, name)) = &self.scene {
            text = text.replace(file.as_str(), &format!("`{name}`"));
        }
        let temp = self.temp.map(|t| t.display().to_string());
        let (mut kept, mut lost) = (Vec::new(), Vec::new());
        let mut lines = Vec::new();
        for line in text.lines() {
            let wrote = line.trim_start().strip_prefix("wrote ");
            match (wrote, &temp) {
                (Some(path), Some(temp)) if path.starts_with(temp.as_str()) => {
                    let file = Path::new(path).file_name().map_or(path.into(), |f| f.to_string_lossy().into_owned());
                    match self.table(&file) {
                        Some(at) => kept.push(at),
                        None => lost.push(file),
                    }
                }
                (Some(_), _) => lines.push(line.to_string()),
                (None, temp) => {
                    let mut line = temp.as_ref().map_or_else(|| line.to_string(), |t| gone(line, t));
                    // a table named by its file: the attribute that holds it
                    for (_, file, at) in TABLES.iter().filter(|(f, _, _)| *f == self.function) {
                        line = line.replace(&format!(" {file}"), &format!(" `{at}`"));
                    }
                    lines.push(line);
                }
            }
        }
        let mut text = keywords(&lines.join("\n"));
        if !kept.is_empty() {
            let list = kept.join(", ");
            let list =
                if kept.iter().all(|k| k.starts_with('.')) { format!("{list} of the returned object") } else { list };
            let (what, them) =
                if kept.len() == 1 { ("table", "it as a CSV file") } else { ("tables", "them as CSV files") };
            text.push_str(&format!("\n{what}: {list} (not written to disk; give out=DIR to write {them})"));
        }
        if !lost.is_empty() {
            text.push_str(&format!(
                "\ndrawn into a temporary directory and deleted with it: {} (give out=DIR to keep them)",
                lost.join(", ")
            ));
        }
        text
    }

    /// Where a Python caller finds the table the command wrote as `file`
    /// (a branch born, `branch-K.csv`, is `.branches[K]`).
    fn table(&self, file: &str) -> Option<String> {
        let born = file.strip_prefix("branch-").and_then(|r| r.strip_suffix(".csv"));
        if let (Some(k), "analyze") = (born, self.function)
            && !k.is_empty()
            && k.bytes().all(|c| c.is_ascii_digit())
        {
            return Some(format!(".branches[{k}]"));
        }
        TABLES.iter().find(|(f, n, _)| *f == self.function && *n == file).map(|(_, _, at)| at.to_string())
    }
}

/// `line` with each path into `temp`, a directory now deleted, said as
/// such.
fn gone(line: &str, temp: &str) -> String {
    let mut out = String::new();
    let mut rest = line;
    while let Some(at) = rest.find(temp) {
        out.push_str(&rest[..at]);
        let end = rest[at..].find(|c: char| c.is_whitespace() || ",;`'\")".contains(c)).map_or(rest.len(), |e| at + e);
        out.push_str("a temporary file (deleted; out=DIR keeps it)");
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}

/// `text` with the command line's flags said as Python's keywords:
/// `--continue` as `vary=`, `--rtol 1e-3` as `rtol=1e-3`, `--integrator
/// radau5` as `integrator="radau5"`, `` `ezy analyze` `` as
/// `` `ezy.analyze` ``, and a refusal of the argument parser without its
/// advice to read `--help`. A flag no keyword gives stays as it is.
pub(crate) fn keywords(text: &str) -> String {
    let text = text.strip_prefix("error: ").unwrap_or(text);
    let text = text.replace("\n\nFor more information, try '--help'.", "");
    // the parser's `'--period <T>'`: the flag alone
    let mut plain = String::new();
    let mut rest = text.as_str();
    while let Some(at) = rest.find("'--") {
        let close = rest[at + 1..].find('\'').map(|c| at + 1 + c);
        match close {
            Some(close) => {
                plain.push_str(&rest[..at]);
                let inner = &rest[at + 1..close];
                plain.push_str(inner.split(" <").next().unwrap_or(inner));
                rest = &rest[close + 1..];
            }
            None => break,
        }
    }
    plain.push_str(rest);
    // a sweep's name that is an axis or a set
    plain = plain.replace("--set/axis", "the grid's axis or --set");
    for command in ezy::python_commands() {
        plain = plain.replace(&format!("`ezy {command}`"), &format!("`ezy.{command}`"));
    }
    flags(&plain)
}

/// `text` with each flag of [`FLAGS`] said as its keyword.
fn flags(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(at) = rest.find("--") {
        let before = rest[..at].chars().last().or_else(|| out.chars().last());
        out.push_str(&rest[..at]);
        let after = &rest[at + 2..];
        let len =
            after.find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')).unwrap_or(after.len());
        let name = &after[..len];
        let found = FLAGS.iter().find(|(f, _, _)| *f == name);
        let Some(&(_, keyword, kind)) = found.filter(|_| !before.is_some_and(|c| c.is_alphanumeric() || c == '-'))
        else {
            out.push_str("--");
            rest = after;
            continue;
        };
        let tail = &after[len..];
        let (said, used) = value(keyword, kind, tail);
        out.push_str(&said);
        rest = &tail[used..];
    }
    out.push_str(rest);
    out
}

/// The keyword `keyword` with the value that follows it in `tail`, if one
/// reads as its value (a number, a choice's word, a placeholder such as
/// `QUANTITY`): the text said, and how much of `tail` it took.
fn value(keyword: &str, kind: Kind, tail: &str) -> (String, usize) {
    let Some(next) = tail.strip_prefix(' ') else { return (format!("`{keyword}=`"), 0) };
    if next.starts_with("= ") {
        return (format!("`{keyword}`"), 0);
    }
    let token = next.split(char::is_whitespace).next().unwrap_or("");
    let token = token.trim_end_matches([':', ',', ';', ')', '.']);
    let number = token.starts_with(|c: char| c.is_ascii_digit())
        || (token.starts_with(['-', '.']) && token[1..].starts_with(|c: char| c.is_ascii_digit()));
    let placeholder = token.len() > 1 && token.chars().all(|c| c.is_ascii_uppercase() || c == '_');
    let word = !token.is_empty() && token.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_');
    match kind {
        _ if placeholder => (format!("`{keyword}={token}`"), 1 + token.len()),
        Kind::Number | Kind::Other if number => (format!("`{keyword}={token}`"), 1 + token.len()),
        Kind::Choice if word => (format!("`{keyword}=\"{token}\"`"), 1 + token.len()),
        _ => (format!("`{keyword}=`"), 0),
    }
}

/// A run's message in the library's spelling (a scene file's keys:
/// `` `method = dop853` ``) as `ezy.run`'s keywords say it:
/// `` `integrator="dop853"` ``, `` `formulation="dae"` ``.
pub(crate) fn run_keywords(text: &str) -> String {
    let mut text = text.to_string();
    for (key, keyword) in [("method", "integrator"), ("formulation", "formulation")] {
        let open = format!("`{key} = ");
        let mut out = String::new();
        let mut rest = text.as_str();
        while let Some(at) = rest.find(&open) {
            let after = &rest[at + open.len()..];
            let Some(close) = after.find('`') else { break };
            out.push_str(&rest[..at]);
            out.push_str(&format!("`{keyword}=\"{}\"`", &after[..close]));
            rest = &after[close + 1..];
        }
        out.push_str(rest);
        text = out;
    }
    text
}
