//! Per-frame rows as CSV (the `csv` crate): a header of the row type's field names, in their
//! order, then a line per row. Read back into the same type by header name, so a renamed or
//! missing column is an error naming it, as is a ragged line; a cell with a comma is quoted.

use super::ResultsError;
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::path::Path;

/// `rows` as CSV; `T::default()` names the columns when there are no rows.
pub fn to_string<T: Serialize + Default>(rows: &[T]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    // Plain data into a Vec: the writes cannot fail.
    if rows.is_empty() {
        w.serialize(T::default()).expect("a row serialises");
        let text = String::from_utf8(w.into_inner().expect("a Vec takes every write")).expect("CSV of UTF-8 fields");
        return text.lines().next().map_or(String::new(), |h| format!("{h}\n"));
    }
    for r in rows {
        w.serialize(r).expect("a row serialises");
    }
    String::from_utf8(w.into_inner().expect("a Vec takes every write")).expect("CSV of UTF-8 fields")
}

pub fn write<T: Serialize + Default>(path: &Path, rows: &[T]) -> Result<(), ResultsError> {
    std::fs::write(path, to_string(rows)).map_err(|e| ResultsError::new(path, e))
}

/// Rows written to a file as they come, for a process that runs for hours: nothing is kept in
/// memory. The header comes with the first row, or with [`Rows::finish`] when there was none.
pub struct Rows<T> {
    path: std::path::PathBuf,
    w: csv::Writer<std::fs::File>,
    any: bool,
    row: std::marker::PhantomData<T>,
}

impl<T: Serialize + Default> Rows<T> {
    pub fn create(path: &Path) -> Result<Rows<T>, ResultsError> {
        let file = std::fs::File::create(path).map_err(|e| ResultsError::new(path, e))?;
        Ok(Rows { path: path.to_path_buf(), w: csv::Writer::from_writer(file), any: false, row: std::marker::PhantomData })
    }

    pub fn push(&mut self, row: &T) -> Result<(), ResultsError> {
        self.any = true;
        self.w.serialize(row).and_then(|()| Ok(self.w.flush()?)).map_err(|e| ResultsError::new(&self.path, e))
    }

    pub fn finish(mut self) -> Result<(), ResultsError> {
        if !self.any {
            return write::<T>(&self.path, &[]);
        }
        self.w.flush().map_err(|e| ResultsError::new(&self.path, e))
    }
}

pub fn read<T: DeserializeOwned>(path: &Path) -> Result<Vec<T>, ResultsError> {
    let text = std::fs::read_to_string(path).map_err(|e| ResultsError::new(path, e))?;
    parse(&text).map_err(|e| ResultsError::new(path, e))
}

/// What is wrong with a CSV table.
#[derive(Debug, thiserror::Error)]
pub enum CsvError {
    #[error("empty: no header")]
    NoHeader,
    /// `line` counted from 1 with the header.
    #[error("line {line}: {what}")]
    Row { line: u64, what: String },
}

/// The rows of CSV `text`; an empty cell is a missing value (as [`to_string`] writes `None`).
/// Errors name the line.
pub fn parse<T: DeserializeOwned>(text: &str) -> Result<Vec<T>, CsvError> {
    let mut r = csv::Reader::from_reader(text.as_bytes());
    if r.headers().map_err(|e| row_error(&e))?.is_empty() {
        return Err(CsvError::NoHeader);
    }
    r.deserialize().map(|row| row.map_err(|e| row_error(&e))).collect()
}

/// A CSV error and the line it is on.
fn row_error(e: &csv::Error) -> CsvError {
    let line = e.position().map_or(0, |p| p.line());
    let what = match e.kind() {
        csv::ErrorKind::Deserialize { err, .. } => err.kind().to_string(),
        csv::ErrorKind::UnequalLengths { expected_len, len, .. } => format!("{len} cells, the header has {expected_len}"),
        _ => e.to_string(),
    };
    CsvError::Row { line, what }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::results::{Duty, NodeFrame};

    #[test]
    fn rows_written_as_they_come_read_back_as_a_whole_file_would() {
        let d = tempfile::tempdir().unwrap();
        let rows = [NodeFrame { frame: 0, ms: 1.5, ..Default::default() }, NodeFrame { frame: 1, duty: Duty::Or, ..Default::default() }];
        let path = d.path().join("rows.csv");
        let mut w = Rows::create(&path).unwrap();
        for r in &rows {
            w.push(r).unwrap();
        }
        w.finish().unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), to_string(&rows));
        let empty = d.path().join("empty.csv");
        Rows::<NodeFrame>::create(&empty).unwrap().finish().unwrap();
        assert_eq!(std::fs::read_to_string(&empty).unwrap(), to_string::<NodeFrame>(&[]));
    }

    #[test]
    fn rows_read_back_as_written() {
        let rows = [
            NodeFrame { frame: 0, duty: Duty::Solo, ms: 12.25, bytes_to_peer: 90, ..Default::default() },
            NodeFrame { frame: 1, duty: Duty::Or, ms: 3.0, rss_kb: 1 << 40, ..Default::default() },
        ];
        let text = to_string(&rows);
        assert!(text.starts_with("frame,role,ms,"), "{text}");
        assert!(text.contains(",SOLO,12.25,"), "{text}");
        let back: Vec<NodeFrame> = parse(&text).unwrap();
        assert_eq!(format!("{back:?}"), format!("{rows:?}"));
        assert_eq!(parse::<NodeFrame>(&to_string::<NodeFrame>(&[])).unwrap().len(), 0);
    }

    #[test]
    fn a_cell_with_a_comma_or_a_quote_reads_back_whole() {
        #[derive(serde::Serialize, serde::Deserialize, Default, Debug, PartialEq)]
        struct Named {
            frame: u64,
            name: String,
            ms: Option<f64>,
        }
        let rows = [Named { frame: 1, name: "a, \"b\"".into(), ms: None }, Named { frame: 2, name: "c".into(), ms: Some(0.5) }];
        assert_eq!(parse::<Named>(&to_string(&rows)).unwrap(), rows);
    }

    #[test]
    fn a_renamed_column_or_a_ragged_line_is_an_error_naming_it() {
        let text = to_string(&[NodeFrame::default()]);
        let e = parse::<NodeFrame>(&text.replace("bytes_to_peer", "bytes_to_the_peer")).unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("missing field `bytes_to_peer`"), "{e}");
        let e = parse::<NodeFrame>(&format!("{text}1,HC\n")).unwrap_err().to_string();
        assert!(e.contains("line 3"), "{e}");
        let e = parse::<NodeFrame>(&text.replace("SOLO", "BOTH")).unwrap_err().to_string();
        assert!(e.contains("BOTH"), "{e}");
    }
}
