//! Per-frame rows as CSV: a header of the row type's field names (in their order), then a line
//! per row. Read back into the same type by header name, so a renamed or missing column is an
//! error naming it.

use super::ResultsError;
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::{Map, Value};
use std::path::Path;

/// `rows` as CSV; `T::default()` names the columns when there are no rows.
pub fn to_string<T: Serialize + Default>(rows: &[T]) -> String {
    let header: Vec<String> = match serde_json::to_value(T::default()) {
        Ok(Value::Object(m)) => m.keys().cloned().collect(),
        _ => Vec::new(),
    };
    let mut out = header.join(",");
    out.push('\n');
    for r in rows {
        if let Ok(Value::Object(m)) = serde_json::to_value(r) {
            let cells: Vec<String> = header.iter().map(|k| cell(&m[k])).collect();
            out.push_str(&cells.join(","));
            out.push('\n');
        }
    }
    out
}

fn cell(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Null => String::new(),
        v => v.to_string(),
    }
}

pub fn write<T: Serialize + Default>(path: &Path, rows: &[T]) -> Result<(), ResultsError> {
    std::fs::write(path, to_string(rows)).map_err(|e| ResultsError::new(path, e))
}

pub fn read<T: DeserializeOwned>(path: &Path) -> Result<Vec<T>, ResultsError> {
    let text = std::fs::read_to_string(path).map_err(|e| ResultsError::new(path, e))?;
    parse(&text).map_err(|e| ResultsError::new(path, e))
}

/// The rows of CSV `text`; a cell is a number where it reads as one, empty for a missing value
/// (as [`to_string`] writes `None`), else a string.
pub fn parse<T: DeserializeOwned>(text: &str) -> Result<Vec<T>, String> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().ok_or("empty: no header")?.split(',').collect();
    lines
        .enumerate()
        .map(|(k, line)| {
            let cells: Vec<&str> = line.split(',').collect();
            if cells.len() != header.len() {
                return Err(format!("line {}: {} cells, the header has {}", k + 2, cells.len(), header.len()));
            }
            let row: Map<String, Value> = header.iter().zip(cells).map(|(h, c)| (h.to_string(), value(c))).collect();
            serde_json::from_value(Value::Object(row)).map_err(|e| format!("line {}: {e}", k + 2))
        })
        .collect()
}

fn value(c: &str) -> Value {
    if c.is_empty() {
        return Value::Null;
    }
    if let Ok(n) = c.parse::<u64>() {
        return n.into();
    }
    if let Ok(n) = c.parse::<i64>() {
        return n.into();
    }
    match c.parse::<f64>().ok().and_then(serde_json::Number::from_f64) {
        Some(n) => Value::Number(n),
        None => Value::String(c.to_owned()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::results::{Duty, NodeFrame};

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
    fn a_renamed_column_or_a_ragged_line_is_an_error_naming_it() {
        let text = to_string(&[NodeFrame::default()]);
        let e = parse::<NodeFrame>(&text.replace("bytes_to_peer", "bytes_to_the_peer")).unwrap_err();
        assert!(e.contains("line 2") && e.contains("missing field `bytes_to_peer`"), "{e}");
        let e = parse::<NodeFrame>(&format!("{text}1,HC\n")).unwrap_err();
        assert!(e.contains("line 3"), "{e}");
        let e = parse::<NodeFrame>(&text.replace("SOLO", "BOTH")).unwrap_err();
        assert!(e.contains("BOTH"), "{e}");
    }
}
