//! A per-cell Parquet file has rows and column names, not lines: every
//! error about one names its row (the first cell is row 1), where the
//! same error about its CSV twin names the line (the header is line 1,
//! so line L holds row L - 1). Before, a Parquet file's errors named the
//! lines of the CSV text it was read through, one more than its rows.
//! And a file that carries the index pandas wrote with it (a column
//! `__index_level_0__` in Parquet, a first column without a name in a
//! CSV) is refused with what to write instead.

use std::error::Error;
use std::path::Path;

use crate::common::{crossaudit, root, said};

/// The quickstart's committed cells (640 rows, lines 2 to 641), edited.
fn cells() -> Result<Vec<String>, Box<dyn Error>> {
    let text = std::fs::read_to_string(root().join("results/quickstart/cells.csv"))?;
    Ok(text.lines().map(String::from).collect())
}

/// [`cells`] with `field` of line `k + 1` (the `k`-th cell) set to `value`.
fn edited(k: usize, field: &str, value: &str) -> Result<Vec<String>, Box<dyn Error>> {
    let mut lines = cells()?;
    let at = lines[0].split(',').position(|h| h == field).ok_or("no such column")?;
    let mut f: Vec<&str> = lines[k].split(',').collect();
    f[at] = value;
    lines[k] = f.join(",");
    Ok(lines)
}

/// `lines` as a CSV and as its Parquet twin (the same columns, written by
/// the crate's writer) in `dir`, each analysed under the quickstart's
/// design: what each says, CSV first.
fn both(dir: &Path, lines: &[String]) -> Result<(String, String), Box<dyn Error>> {
    let text = lines.join("\n") + "\n";
    let parquet = crossaudit::io::parquet::csv_to_parquet(text.as_bytes())?;
    Ok((refused(&dir.join("cells.csv"), text.as_bytes())?, refused(&dir.join("cells.parquet"), &parquet)?))
}

/// What `analyze` says of `bytes` written as `file`, which it refuses,
/// writing no report.
fn refused(file: &Path, bytes: &[u8]) -> Result<String, Box<dyn Error>> {
    std::fs::write(file, bytes)?;
    let out = file.with_extension("report");
    let o = crossaudit(&["analyze", "designs/quickstart.design", "--cells", path(file)?, "--out", path(&out)?]);
    let text = said(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(!out.join("report.md").exists(), "{text}");
    Ok(text)
}

#[test]
fn a_parquet_files_errors_name_its_rows_where_its_csv_twins_name_lines() -> Result<(), Box<dyn Error>> {
    let dir = tempfile::tempdir()?;
    // A duplicate of the sixth cell (line 7) as the last row (line 642):
    // found by the analysis, which names both rows.
    let mut lines = cells()?;
    lines.push(lines[6].clone());
    let (csv, parquet) = both(dir.path(), &lines)?;
    assert!(csv.contains("cells.csv: line 642: duplicate cell") && csv.contains("first seen on line 7"), "{csv}");
    assert!(parquet.contains("cells.parquet: row 641: duplicate cell"), "{parquet}");
    assert!(parquet.contains("first seen on row 6") && !parquet.contains("line"), "{parquet}");
    // A speed the design does not label, in the eighth cell: the analysis.
    let (csv, parquet) = both(dir.path(), &edited(8, "speed", "warp")?)?;
    assert!(csv.contains("cells.csv: line 9, field `speed`: \"warp\" is not in the design"), "{csv}");
    assert!(parquet.contains("cells.parquet: row 8, field `speed`: \"warp\" is not in the design"), "{parquet}");
    // No starts in the fortieth cell: the reader, through the file's text
    // (the columns' reader gives such a file up to it).
    let (csv, parquet) = both(dir.path(), &edited(40, "n_starts", "0")?)?;
    assert!(csv.contains("cells.csv: line 41, field `n_starts`: must be at least 1"), "{csv}");
    assert!(parquet.contains("cells.parquet: row 40, field `n_starts`: must be at least 1"), "{parquet}");
    // A count written as a float (pandas writes an integer column so once
    // it held a missing value): refused, with how to write it. In Parquet
    // the whole column is then one of doubles, refused at its first row.
    let (csv, parquet) = both(dir.path(), &edited(40, "n_starts", "25.0")?)?;
    assert!(
        csv.contains("cells.csv: line 41, field `n_starts`: is not a non-negative integer: a whole number"),
        "{csv}"
    );
    assert!(csv.contains("`df[column].astype(int)`"), "{csv}");
    assert!(parquet.contains("cells.parquet: row 1, field `n_starts`") && parquet.contains("astype(int)"), "{parquet}");
    // A velocity left empty in the tenth cell though others have one: the
    // reader names both places.
    let (csv, parquet) = both(dir.path(), &edited(10, "velocity_rmse_mps", "")?)?;
    assert!(
        csv.contains("line 11, field `velocity_rmse_mps`: is empty") && csv.contains("line 2 has a value"),
        "{csv}"
    );
    let (field, valued) = ("row 10, field `velocity_rmse_mps`: is empty", "row 1 has a value");
    assert!(parquet.contains(field) && parquet.contains(valued) && !parquet.contains("line"), "{parquet}");
    Ok(())
}

#[test]
fn the_index_pandas_wrote_into_a_cells_file_is_named_with_what_to_write_instead() -> Result<(), Box<dyn Error>> {
    let dir = tempfile::tempdir()?;
    // `df.to_parquet(path)` of a frame whose index is not 0, 1, 2, ...
    // (rows filtered or shuffled) stores the index as a last column named
    // `__index_level_0__`; `df.to_csv(path)` writes it first, unnamed.
    let lines = cells()?;
    let indexed: Vec<String> = lines
        .iter()
        .enumerate()
        .map(|(k, l)| if k == 0 { format!("{l},__index_level_0__") } else { format!("{l},{}", 3 * k) })
        .collect();
    let (_, parquet) = both(dir.path(), &indexed)?;
    assert!(parquet.contains("cells.parquet: wrong column names"), "{parquet}");
    assert!(parquet.contains("write the file with `to_parquet(path, index=False)`"), "{parquet}");
    let unnamed: Vec<String> = lines
        .iter()
        .enumerate()
        .map(|(k, l)| if k == 0 { format!(",{l}") } else { format!("{},{l}", 3 * k) })
        .collect();
    let csv = refused(&dir.path().join("cells.csv"), (unnamed.join("\n") + "\n").as_bytes())?;
    assert!(csv.contains("cells.csv: line 1: wrong header"), "{csv}");
    assert!(csv.contains("write the file with `to_csv(path, index=False)`"), "{csv}");
    // Another extra column gets no such advice.
    let extra: Vec<String> = lines.iter().map(|l| format!("{l},x")).collect();
    let (csv, parquet) = both(dir.path(), &extra)?;
    assert!(!csv.contains("index=False") && !parquet.contains("index=False"), "{csv}\n{parquet}");
    Ok(())
}

fn path(p: &Path) -> Result<&str, Box<dyn Error>> {
    Ok(p.to_str().ok_or("a path that is not UTF-8")?)
}
