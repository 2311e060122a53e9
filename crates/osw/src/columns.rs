//! The CSV files osw writes (stats.csv, node-a.csv, exact.csv) read back by column name.

use anyhow::{Context, bail};
use std::path::Path;

/// A CSV file's numeric columns by header name; a cell that is not a number reads as NaN.
pub struct Columns {
    names: Vec<String>,
    rows: Vec<Vec<f64>>,
}

impl Columns {
    pub fn read(path: &Path) -> anyhow::Result<Columns> {
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let mut lines = text.lines();
        let names: Vec<String> = lines.next().with_context(|| format!("{}: empty", path.display()))?.split(',').map(String::from).collect();
        let rows = lines.map(|l| l.split(',').map(|c| c.parse().unwrap_or(f64::NAN)).collect::<Vec<f64>>()).collect::<Vec<_>>();
        if let Some(k) = rows.iter().position(|r| r.len() != names.len()) {
            bail!("{}: row {} has {} cells, the header {}", path.display(), k + 2, rows[k].len(), names.len());
        }
        Ok(Columns { names, rows })
    }

    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Column `name`, or an error naming the file's columns.
    pub fn get(&self, name: &str) -> anyhow::Result<Vec<f64>> {
        let k = self
            .names
            .iter()
            .position(|n| n == name)
            .with_context(|| format!("no column {name:?} (columns: {})", self.names.join(", ")))?;
        Ok(self.rows.iter().map(|r| r[k]).collect())
    }
}

pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}
