//! `osw plot`: columns of a CSV file (a line per row) against one of them, as PNG and SVG:
//! for what the scripts tabulate (the soak's memory per lap).

use crate::plot::{Chart, Series, write};
use anyhow::{Context, bail};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A CSV file with a header line.
    #[arg(long)]
    csv: PathBuf,
    /// The column on the x axis.
    #[arg(long)]
    x: String,
    /// The columns plotted against it, each a line.
    #[arg(long, value_delimiter = ',', required = true)]
    y: Vec<String>,
    #[arg(long, default_value = "")]
    title: String,
    /// The y axis's label [default: the columns' names].
    #[arg(long)]
    y_label: Option<String>,
    /// Output stem: STEM.png and STEM.svg.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(&a.csv).with_context(|| a.csv.display().to_string())?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().with_context(|| format!("{}: empty", a.csv.display()))?.split(',').collect();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .with_context(|| format!("{}: no column {name:?} (it has {})", a.csv.display(), header.join(", ")))
    };
    let x = column(&a.x)?;
    let ys: Vec<usize> = a.y.iter().map(|y| column(y)).collect::<anyhow::Result<_>>()?;
    let rows: Vec<Vec<&str>> = lines.filter(|l| !l.is_empty()).map(|l| l.split(',').collect()).collect();
    let number = |row: usize, c: usize| -> anyhow::Result<f64> {
        let cell = rows[row].get(c).copied().unwrap_or("");
        cell.parse().with_context(|| format!("{}: line {}: {:?} in column {} is not a number", a.csv.display(), row + 2, cell, header[c]))
    };
    if rows.is_empty() {
        bail!("{}: no rows", a.csv.display());
    }
    let mut series = Vec::new();
    for (&c, name) in ys.iter().zip(&a.y) {
        let points = (0..rows.len()).map(|r| Ok((number(r, x)?, number(r, c)?))).collect::<anyhow::Result<Vec<_>>>()?;
        series.push(Series { name: name.clone(), points, point_labels: Vec::new(), bold: false });
    }
    let y_label = a.y_label.unwrap_or_else(|| a.y.join(", "));
    write(&Chart { title: &a.title, x: &a.x, y: &y_label, series }, &a.out)?;
    out!("plot: {} rows → {}.png, .svg", rows.len(), a.out.display());
    Ok(())
}
