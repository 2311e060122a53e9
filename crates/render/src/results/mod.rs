//! Run results, one typed schema: what the runs write and the tools read back, through the
//! same types. A key that is missing or of the wrong type is an error naming the file and the
//! key, never a 0 in a report.
//!
//! - [`Summary`]: `summary.json` of every run: `osw render` (one mode on one GPU) and `osw run`
//!   (the switch: the display's statistics, the nodes' stage times merged in by `osw run`).
//! - [`DisplayFrame`], [`NodeFrame`]: the frames of a switch run as its display and its nodes
//!   saw them (`stats.csv`, `node-a.csv`, `node-b.csv`).
//! - [`ExactFrame`]: exact visibility (`exact.csv`); [`Input`]: what a run was made from.
//! - [`Compare`]: `compare.json` (`osw compare`); [`Report`]: `report.json` (`osw report`).
//! - [`csv`]: per-frame rows as CSV, a column per field.

mod compare;
pub mod csv;
mod display;
mod exact;
mod input;
mod node;
mod report;
mod summary;

pub use compare::{Compare, Culling, Popping};
pub use display::{DisplayFrame, STAGES, Stage, latency_floor_ms};
pub use exact::ExactFrame;
pub use input::Input;
pub use node::{Duty, NodeFrame, duty_median_ms};
pub use report::{Entry, Report, Traffic};
pub use summary::{Details, RenderSummary, Summary, SwitchSummary, textures_key};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A results file that cannot be read as its type, or written: the file and what is wrong.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct ResultsError {
    pub path: String,
    pub message: String,
}

impl ResultsError {
    pub fn new(path: &Path, message: impl std::fmt::Display) -> ResultsError {
        ResultsError { path: path.display().to_string(), message: message.to_string() }
    }
}

/// Reads a JSON file of type `T`.
pub fn read_json<T: DeserializeOwned>(path: &Path) -> Result<T, ResultsError> {
    let text = std::fs::read_to_string(path).map_err(|e| ResultsError::new(path, e))?;
    serde_json::from_str(&text).map_err(|e| ResultsError::new(path, e))
}

/// Writes `value` as pretty JSON.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), ResultsError> {
    let text = serde_json::to_string_pretty(value).map_err(|e| ResultsError::new(path, e))?;
    std::fs::write(path, text).map_err(|e| ResultsError::new(path, e))
}

/// For `Option` fields that must be present, `null` or not: serde takes a missing `Option`
/// field for `None` unless it has its own deserializer.
pub(crate) fn required<'de, D: serde::Deserializer<'de>, T: serde::Deserialize<'de>>(d: D) -> Result<Option<T>, D::Error> {
    Option::deserialize(d)
}
