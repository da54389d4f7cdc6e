//! A small Markdown table builder: a header, an alignment per column, rows.

use std::fmt::Write as _;

/// A Markdown (GitHub) table.
///
/// ```
/// let mut t = crossaudit::report::MdTable::new(&["model", "mean"], "lr");
/// t.row(["world".to_string(), "0.1".to_string()]);
/// assert_eq!(t.render(), "| model | mean |\n|---|---:|\n| world | 0.1 |\n");
/// ```
#[derive(Debug, Clone)]
pub struct MdTable {
    header: String,
    rule: String,
    rows: Vec<String>,
}

impl MdTable {
    /// A table with these column names; `align` has one letter per column,
    /// `l` (left) or `r` (right).
    pub fn new(columns: &[&str], align: &str) -> MdTable {
        let rule: String = align.chars().map(|a| if a == 'r' { "---:|" } else { "---|" }).collect();
        MdTable { header: format!("| {} |", columns.join(" | ")), rule: format!("|{rule}"), rows: Vec::new() }
    }

    /// Appends a row; a cell may itself hold `a | b` to fill several columns.
    pub fn row<I: IntoIterator<Item = String>>(&mut self, cells: I) {
        self.rows.push(format!("| {} |", cells.into_iter().collect::<Vec<_>>().join(" | ")));
    }

    /// The table, one line per row, each ending in a newline.
    pub fn render(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "{}", self.header);
        let _ = writeln!(s, "{}", self.rule);
        for r in &self.rows {
            let _ = writeln!(s, "{r}");
        }
        s
    }
}
