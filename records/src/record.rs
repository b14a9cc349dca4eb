//! The in-memory record: channels sampled together, as a reader returns it
//! and a writer takes it.

use std::path::PathBuf;

use crate::error::RecordError;
use crate::spec::{ChannelSpec, direction_label};

/// One sampled signal.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// Name used to select the channel (CSV header without unit; UFF ID
    /// line 1, or `node:direction` if that is empty).
    pub name: String,
    /// Physical unit, e.g. `N` or `m/s^2`, if the file states one.
    pub unit: Option<String>,
    /// UFF response node.
    pub node: Option<i64>,
    /// UFF response direction: 1..6 = +X,+Y,+Z,+RX,+RY,+RZ, negative for
    /// minus, 0 scalar.
    pub direction: Option<i32>,
    /// UFF ID line 1 (function description), if not empty or `NONE`.
    pub id_line: Option<String>,
    /// Samples; every channel of a record has the same number.
    pub values: Vec<f64>,
    /// Where each sample was written in a text file (for messages that
    /// name a line); `None` for binary files and records built in memory.
    pub lines: Option<SampleLines>,
}

/// The text lines holding a channel's samples, so that a check can name the
/// line of a suspicious sample.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum SampleLines {
    /// One sample per line: sample `i` is on line `first_line + i` (CSV).
    Rows {
        /// 1-based line of sample 0.
        first_line: usize,
    },
    /// Several values per line (UFF58 ASCII): `starts[k] = (v, line)` says
    /// that value `v` of the data block is the first one on `line`. Sample
    /// `i` is value `stride * i + offset` (stride 2, offset 1 for (x, y)
    /// pairs of uneven abscissae; stride 1, offset 0 otherwise).
    Values {
        /// `(first value index, 1-based line)`, ascending.
        starts: Vec<(usize, usize)>,
        /// Values per sample.
        stride: usize,
        /// Position of the sample's value within its group.
        offset: usize,
    },
}

impl SampleLines {
    /// The 1-based line holding sample `i`.
    pub fn line_of(&self, i: usize) -> Option<usize> {
        match self {
            SampleLines::Rows { first_line } => Some(first_line + i),
            SampleLines::Values {
                starts,
                stride,
                offset,
            } => {
                let v = stride * i + offset;
                let k = starts.partition_point(|&(first, _)| first <= v);
                k.checked_sub(1).map(|k| starts[k].1)
            }
        }
    }
}

/// File layout a record was read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Delimited text; `delimiter` is `b','`, `b';'` or `b'\t'`.
    Csv {
        /// The field separator.
        delimiter: u8,
    },
    /// UFF dataset 58, ASCII.
    Uff58Ascii,
    /// UFF dataset 58, binary (`58b`).
    Uff58Binary,
}

/// A set of channels sampled together: sample `i` of every channel was
/// taken at `start_s + i * dt_s`.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordFile {
    /// The file read (or to be written).
    pub path: PathBuf,
    /// The layout it was read from.
    pub format: Format,
    /// Sampling interval in seconds (finite, positive).
    pub dt_s: f64,
    /// Time of the first sample in seconds.
    pub start_s: f64,
    /// The channels, in file order.
    pub channels: Vec<Channel>,
}

/// How to read records.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadOptions {
    /// Sampling rate for files without a time axis (a CSV file without a
    /// time column). If the file has one, the two must agree.
    pub fs_hz: Option<f64>,
}

impl ReadOptions {
    /// Options with a sampling rate for files without a time axis.
    pub fn with_fs_hz(fs_hz: f64) -> Self {
        ReadOptions { fs_hz: Some(fs_hz) }
    }

    pub(crate) fn validate(&self) -> Result<(), RecordError> {
        match self.fs_hz {
            Some(fs) if !(fs.is_finite() && fs > 0.0) => Err(RecordError::InvalidOptions {
                reason: format!("fs_hz must be a positive number, got {fs}"),
            }),
            _ => Ok(()),
        }
    }
}

impl Channel {
    /// One-line description for listings: `#2 acc1 [m/s^2] (node 2 +X)`.
    pub(crate) fn describe(&self, index: usize) -> String {
        let mut s = format!("#{} {}", index + 1, self.name);
        if let Some(u) = &self.unit {
            s.push_str(&format!(" [{u}]"));
        }
        if let (Some(n), Some(d)) = (self.node, self.direction) {
            s.push_str(&format!(" (node {n} {})", direction_label(d)));
        }
        if let Some(id) = &self.id_line
            && id != &self.name
        {
            s.push_str(&format!(" id '{id}'"));
        }
        s
    }
}

impl RecordFile {
    /// Number of samples per channel.
    pub fn len(&self) -> usize {
        self.channels.first().map_or(0, |c| c.values.len())
    }

    /// Whether the record has no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sampling rate, Hz.
    pub fn fs_hz(&self) -> f64 {
        1.0 / self.dt_s
    }

    /// Time of sample `i` in seconds.
    pub fn time_s(&self, i: usize) -> f64 {
        self.start_s + i as f64 * self.dt_s
    }

    /// Channel descriptions as listed in error messages.
    pub fn channel_list(&self) -> Vec<String> {
        self.channels
            .iter()
            .enumerate()
            .map(|(i, c)| c.describe(i))
            .collect()
    }

    /// The channel selected by `spec`; the error lists what is available.
    pub fn channel(&self, spec: &ChannelSpec) -> Result<&Channel, RecordError> {
        self.channel_index(spec).map(|i| &self.channels[i])
    }

    /// Position (0-based) of the channel selected by `spec`.
    pub fn channel_index(&self, spec: &ChannelSpec) -> Result<usize, RecordError> {
        let all = 0..self.channels.len();
        let matches: Vec<usize> = match spec {
            ChannelSpec::Index(k) => all.filter(|&i| i + 1 == *k).collect(),
            ChannelSpec::Name(n) => {
                // The whole text first: UFF names may end in "(...)" too.
                let names: Vec<String> = self
                    .channels
                    .iter()
                    .map(|c| c.name.to_lowercase())
                    .collect();
                let whole = n.trim().to_lowercase();
                let exact: Vec<usize> = all.clone().filter(|&i| names[i] == whole).collect();
                if exact.is_empty() {
                    let bare = crate::csv::split_unit(n).0.to_lowercase();
                    all.filter(|&i| names[i] == bare).collect()
                } else {
                    exact
                }
            }
            ChannelSpec::NodeDir { node, direction } => all
                .filter(|&i| {
                    self.channels[i].node == Some(*node)
                        && self.channels[i].direction == Some(*direction)
                })
                .collect(),
            ChannelSpec::IdLine(s) => {
                let want = s.trim().to_lowercase();
                let ids: Vec<Option<String>> = self
                    .channels
                    .iter()
                    .map(|c| c.id_line.as_ref().map(|t| t.trim().to_lowercase()))
                    .collect();
                let exact: Vec<usize> = all
                    .clone()
                    .filter(|&i| ids[i].as_deref() == Some(want.as_str()))
                    .collect();
                if exact.is_empty() {
                    all.filter(|&i| ids[i].as_deref().is_some_and(|id| id.contains(&want)))
                        .collect()
                } else {
                    exact
                }
            }
        };
        match matches.as_slice() {
            [i] => Ok(*i),
            [] => Err(RecordError::ChannelNotFound {
                path: self.path.clone(),
                spec: spec.to_string(),
                available: self.channel_list(),
            }),
            many => Err(RecordError::AmbiguousChannel {
                path: self.path.clone(),
                spec: spec.to_string(),
                matches: many.iter().map(|&i| self.channels[i].describe(i)).collect(),
            }),
        }
    }

    /// Checks what every reader guarantees: at least one channel, equal
    /// non-zero lengths, finite values, finite positive `dt_s`, finite
    /// `start_s`. Returns the reason for refusal.
    pub(crate) fn consistency_problem(&self) -> Option<String> {
        if self.channels.is_empty() {
            return Some("the record has no channels".into());
        }
        if !(self.dt_s.is_finite() && self.dt_s > 0.0) {
            return Some(format!("dt_s = {} is not a positive number", self.dt_s));
        }
        if !self.start_s.is_finite() {
            return Some(format!("start_s = {} is not finite", self.start_s));
        }
        let n = self.len();
        if n == 0 {
            return Some("the channels have no samples".into());
        }
        for (i, ch) in self.channels.iter().enumerate() {
            if ch.values.len() != n {
                return Some(format!(
                    "channel #{} '{}' has {} samples, channel #1 has {n}",
                    i + 1,
                    ch.name,
                    ch.values.len()
                ));
            }
            if let Some(k) = ch.values.iter().position(|v| !v.is_finite()) {
                return Some(format!(
                    "channel #{} '{}' sample {} is {}",
                    i + 1,
                    ch.name,
                    k + 1,
                    ch.values[k]
                ));
            }
        }
        None
    }
}
