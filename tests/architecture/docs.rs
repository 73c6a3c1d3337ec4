//! docs/dev/architecture.md's floor tables, generated from `tables.rs`:
//! between a crate's two markers the page holds what [`table`] writes;
//! the test fails where it differs, and `EZY_BLESS=1` rewrites it.

use crate::rules::Rules;
use crate::tables::CRATES;

/// The page, relative to the tree.
pub const PAGE: &str = "docs/dev/architecture.md";

fn begin(rules: &Rules) -> String {
    format!(
        "<!-- the floors of {}: generated from tests/architecture/tables.rs by\n     EZY_BLESS=1 cargo test --release --test architecture -->",
        rules.name
    )
}

fn end(rules: &Rules) -> String {
    format!("<!-- end of the floors of {} -->", rules.name)
}

/// A crate's table as markdown: one row per module, bottom up, then its
/// doors and knots, each with its reason.
pub fn table(rules: &Rules) -> String {
    let mut rows: Vec<_> = rules.floors.iter().enumerate().collect();
    rows.sort_by_key(|(k, f)| (f.floor, *k));
    let mut s = String::from("| floor | module | holds |\n|---|---|---|\n");
    for (_, f) in rows {
        s.push_str(&format!("| {} | `{}` | {} |\n", f.floor, f.module, f.holds));
    }
    for d in rules.doors {
        s.push_str(&format!("\nOutside the floors, `{}`: {}.\n", d.module, d.reason));
    }
    for k in rules.knots {
        s.push_str(&format!(
            "\nNaming `{}` does not count toward the circle rule of its folder's files: {}.\n",
            k.item, k.reason
        ));
    }
    s
}

/// `page` with every crate's table put between its markers, or what is
/// missing.
pub fn generate(page: &str) -> Result<String, String> {
    let mut out = page.to_string();
    for rules in CRATES {
        let (b, e) = (begin(rules), end(rules));
        let Some(start) = out.find(&b) else {
            return Err(format!("{PAGE} has no marker for {}'s table: add the two lines\n{b}\n{e}", rules.name));
        };
        let Some(stop) = out[start..].find(&e).map(|k| start + k) else {
            return Err(format!("{PAGE}: the table of {} has no end marker `{e}`", rules.name));
        };
        out.replace_range(start..stop + e.len(), &format!("{b}\n\n{}\n{e}", table(rules)));
    }
    Ok(out)
}

#[test]
fn the_floor_tables_of_the_architecture_page_are_the_test_s() {
    let path = crate::tree().join(PAGE);
    let page = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let wanted = generate(&page).unwrap_or_else(|e| panic!("{e}"));
    if std::env::var_os("EZY_BLESS").is_some() {
        if wanted != page {
            std::fs::write(&path, &wanted).unwrap();
        }
        return;
    }
    assert!(
        wanted == page,
        "{PAGE}'s floor tables differ from tests/architecture/tables.rs: regenerate them with `EZY_BLESS=1 cargo test --release --test architecture`"
    );
}

#[test]
fn a_table_is_written_bottom_up_with_its_reasons() {
    let t = table(&crate::tables::CORE);
    let lines: Vec<&str> = t.lines().collect();
    assert_eq!(
        lines[..3],
        [
            "| floor | module | holds |",
            "|---|---|---|",
            "| 0 | `names` | how numbers and names are written in messages and columns |"
        ]
    );
    assert!(t.contains("Outside the floors, `__private`: "), "{t}");
    assert!(t.contains("Naming `effects::law::Law` does not count"), "{t}");
    // the markers are found, and what lies outside them is kept
    let page = format!("intro\n{}\nold\n{}\noutro\n", begin(&crate::tables::LANG), end(&crate::tables::LANG));
    let err = generate(&page).unwrap_err();
    assert!(err.contains("no marker for ezy-derive's table"), "{err}");
}
