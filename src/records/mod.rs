//! Record files: sampled force and acceleration channels of impact tests.
//!
//! Readers take what a modal analyzer exported (CSV, Universal File Format
//! dataset 58 in ASCII or binary) or what frameid's simulator wrote, and
//! either return clean channels — equal length, finite values, one uniform
//! sampling interval — or a [`RecordError`] that names the file, the place
//! in it and the problem. The format is recognised from the content, not
//! the file name. Writers replace their target atomically (temporary file
//! in the same directory, then rename), so a failed write never leaves a
//! half-written file behind.

mod csv;
mod error;
mod numfmt;
mod timeaxis;
mod uff;

use std::fmt;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::str::FromStr;

pub use self::csv::parse_csv;
pub use self::error::{CampaignMismatch, IoOp, Location, Problem, RecordError};
pub use self::uff::{Uff58Encoding, parse_uff58};

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
}

/// File layout a record was read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Delimited text; `delimiter` is `b','`, `b';'` or `b'\t'`.
    Csv {
        delimiter: u8,
    },
    Uff58Ascii,
    Uff58Binary,
}

/// A set of channels sampled together: sample `i` of every channel was
/// taken at `start_s + i * dt_s`.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordFile {
    pub path: PathBuf,
    pub format: Format,
    /// Sampling interval in seconds (finite, positive).
    pub dt_s: f64,
    /// Time of the first sample in seconds.
    pub start_s: f64,
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
    pub fn with_fs_hz(fs_hz: f64) -> Self {
        ReadOptions { fs_hz: Some(fs_hz) }
    }

    fn validate(&self) -> Result<(), RecordError> {
        match self.fs_hz {
            Some(fs) if !(fs.is_finite() && fs > 0.0) => Err(RecordError::InvalidOptions {
                reason: format!("fs_hz must be a positive number, got {fs}"),
            }),
            _ => Ok(()),
        }
    }
}

/// Selects a channel of a record. Parsed from command-line strings:
///
/// | string | selector |
/// |---|---|
/// | `force`, `force [N]`, `name:1:x` | [`ChannelSpec::Name`] (case-insensitive, unit ignored) |
/// | `1:+X`, `1:1`, `node1:x`, `n3:-z`, `2:S` | [`ChannelSpec::NodeDir`] |
/// | `id:Hammer` | [`ChannelSpec::IdLine`] (exact, else unique substring, case-insensitive) |
/// | `#3` | [`ChannelSpec::Index`] (1-based, as listed in error messages) |
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ChannelSpec {
    Name(String),
    NodeDir {
        node: i64,
        direction: i32,
    },
    IdLine(String),
    /// 1-based position among the channels (the time column excluded).
    Index(usize),
}

/// Text form of a UFF direction: `+X` .. `-RZ`, `S` for scalar.
pub fn direction_label(direction: i32) -> String {
    const AXES: [&str; 6] = ["X", "Y", "Z", "RX", "RY", "RZ"];
    match direction {
        0 => "S".to_string(),
        d @ 1..=6 => format!("+{}", AXES[(d - 1) as usize]),
        d @ -6..=-1 => format!("-{}", AXES[(-d - 1) as usize]),
        d => d.to_string(),
    }
}

/// Parses `+X`, `x`, `-RZ`, `3`, `-1`, `S`, `scalar`, `0`.
pub fn parse_direction(text: &str) -> Option<i32> {
    let t = text.trim().to_ascii_uppercase();
    if let Ok(d) = t.parse::<i32>() {
        return (-6..=6).contains(&d).then_some(d);
    }
    if t == "S" || t == "SCALAR" {
        return Some(0);
    }
    let (sign, axis) = match t.as_bytes().first() {
        Some(b'+') => (1, &t[1..]),
        Some(b'-') => (-1, &t[1..]),
        _ => (1, t.as_str()),
    };
    let d = match axis {
        "X" => 1,
        "Y" => 2,
        "Z" => 3,
        "RX" => 4,
        "RY" => 5,
        "RZ" => 6,
        _ => return None,
    };
    Some(sign * d)
}

fn strip_prefix_ci<'a>(s: &'a str, prefix: &str) -> Option<&'a str> {
    let head = s.get(..prefix.len())?;
    head.eq_ignore_ascii_case(prefix)
        .then(|| &s[prefix.len()..])
}

impl FromStr for ChannelSpec {
    type Err = RecordError;

    fn from_str(s: &str) -> Result<Self, RecordError> {
        let invalid = |reason: &str| RecordError::InvalidSpec {
            spec: s.to_string(),
            reason: reason.to_string(),
        };
        let t = s.trim();
        if t.is_empty() {
            return Err(invalid("empty"));
        }
        if let Some(rest) = t.strip_prefix('#') {
            return match rest.trim().parse::<usize>() {
                Ok(k) if k >= 1 => Ok(ChannelSpec::Index(k)),
                _ => Err(invalid(
                    "'#' must be followed by a channel number, 1 or more",
                )),
            };
        }
        if let Some(rest) = strip_prefix_ci(t, "id:") {
            let rest = rest.trim();
            if rest.is_empty() {
                return Err(invalid("'id:' must be followed by (part of) an ID line"));
            }
            return Ok(ChannelSpec::IdLine(rest.to_string()));
        }
        if let Some(rest) = strip_prefix_ci(t, "name:") {
            let rest = rest.trim();
            if rest.is_empty() {
                return Err(invalid("'name:' must be followed by a channel name"));
            }
            return Ok(ChannelSpec::Name(rest.to_string()));
        }
        if let Some((node_part, dir_part)) = t.split_once(':') {
            let node_part = node_part.trim();
            let digits = strip_prefix_ci(node_part, "node")
                .or_else(|| strip_prefix_ci(node_part, "n"))
                .unwrap_or(node_part);
            if let Ok(node) = digits.trim().parse::<i64>() {
                return match parse_direction(dir_part) {
                    Some(direction) => Ok(ChannelSpec::NodeDir { node, direction }),
                    None => Err(invalid(
                        "direction must be +X, -Y, Z, RX.. or a number -6..6 (0 or S for scalar)",
                    )),
                };
            }
        }
        Ok(ChannelSpec::Name(t.to_string()))
    }
}

impl fmt::Display for ChannelSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ChannelSpec::Name(n) => {
                // Keep the text form parseable back into a name.
                match n.parse::<ChannelSpec>() {
                    Ok(ChannelSpec::Name(m)) if &m == n => f.write_str(n),
                    _ => write!(f, "name:{n}"),
                }
            }
            ChannelSpec::NodeDir { node, direction } => {
                write!(f, "{node}:{}", direction_label(*direction))
            }
            ChannelSpec::IdLine(s) => write!(f, "id:{s}"),
            ChannelSpec::Index(k) => write!(f, "#{k}"),
        }
    }
}

impl Channel {
    /// One-line description for listings: `#2 acc1 [m/s^2] (node 2 +X)`.
    fn describe(&self, index: usize) -> String {
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

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

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
                    let bare = csv::split_unit(n).0.to_lowercase();
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
    fn consistency_problem(&self) -> Option<String> {
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

/// Parses record content held in memory, recognising the format from the
/// content: UFF if the first non-blank line is the dataset delimiter
/// `-1`, CSV otherwise. `path` is used in messages (and stored).
pub fn parse_record(
    bytes: &[u8],
    path: &Path,
    opts: &ReadOptions,
) -> Result<RecordFile, RecordError> {
    if looks_like_uff(bytes) {
        parse_uff58(bytes, path, opts)
    } else {
        parse_csv(bytes, path, opts)
    }
}

fn looks_like_uff(bytes: &[u8]) -> bool {
    let body = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    body.split(|&b| b == b'\n')
        .map(|l| l.trim_ascii())
        .find(|l| !l.is_empty())
        .is_some_and(|l| l == b"-1")
}

/// Reads a record file (CSV or UFF dataset 58, ASCII or binary).
pub fn read_record(path: &Path, opts: &ReadOptions) -> Result<RecordFile, RecordError> {
    opts.validate()?;
    let bytes = std::fs::read(path).map_err(|error| RecordError::Io {
        path: path.to_path_buf(),
        op: IoOp::Read,
        error,
    })?;
    parse_record(&bytes, path, opts)
}

/// Relative tolerance on the sampling interval of records of one campaign:
/// UFF stores the interval with 6 significant digits (E13.5), so the same
/// rate read from UFF and from a CSV time column can differ by 5e-6.
pub const CAMPAIGN_DT_REL_TOL: f64 = 1e-5;

/// Reads the records of one test campaign (several hits) and checks that
/// they have the same length and sampling interval; the error names the
/// first file and the one that differs.
pub fn read_campaign<P: AsRef<Path>>(
    paths: &[P],
    opts: &ReadOptions,
) -> Result<Vec<RecordFile>, RecordError> {
    let records = paths
        .iter()
        .map(|p| read_record(p.as_ref(), opts))
        .collect::<Result<Vec<_>, _>>()?;
    check_campaign(&records)?;
    Ok(records)
}

/// Checks that records have the same length and sampling interval (within
/// [`CAMPAIGN_DT_REL_TOL`]), the first one being the reference.
pub fn check_campaign(records: &[RecordFile]) -> Result<(), RecordError> {
    let Some((first, rest)) = records.split_first() else {
        return Err(RecordError::EmptyCampaign);
    };
    for r in rest {
        let mismatch = if r.len() != first.len() {
            Some(CampaignMismatch::Length {
                reference: first.len(),
                other: r.len(),
            })
        } else if (r.dt_s - first.dt_s).abs() > CAMPAIGN_DT_REL_TOL * first.dt_s {
            Some(CampaignMismatch::SamplingInterval {
                reference_s: first.dt_s,
                other_s: r.dt_s,
            })
        } else {
            None
        };
        if let Some(mismatch) = mismatch {
            return Err(RecordError::Campaign {
                reference: first.path.clone(),
                other: r.path.clone(),
                mismatch,
            });
        }
    }
    Ok(())
}

fn refuse(path: &Path, reason: String) -> RecordError {
    RecordError::InvalidRecord {
        path: path.to_path_buf(),
        reason,
    }
}

/// Writes `rec` as CSV: header `time,<name [unit]>...`, one row per sample,
/// time in seconds computed as `start_s + i * dt_s`, every number in the
/// shortest form that reads back bit for bit. Node, direction and ID line
/// are not stored. Refuses records that would not read back unchanged.
pub fn write_csv(path: &Path, rec: &RecordFile) -> Result<(), RecordError> {
    let text = csv_text(rec).map_err(|reason| refuse(path, reason))?;
    write_atomically(path, text.as_bytes())
}

/// The content [`write_csv`] writes; the error names `rec.path`.
pub fn encode_csv(rec: &RecordFile) -> Result<String, RecordError> {
    csv_text(rec).map_err(|reason| refuse(&rec.path, reason))
}

fn csv_text(rec: &RecordFile) -> Result<String, String> {
    if let Some(reason) = rec.consistency_problem() {
        return Err(reason);
    }
    for (i, ch) in rec.channels.iter().enumerate() {
        if let Some(reason) = csv::header_round_trip_problem(ch, i) {
            return Err(reason);
        }
    }
    let n = rec.len();
    if n < 2 {
        return Err(
            "a single sample cannot carry its sampling interval in a CSV time column".into(),
        );
    }
    // The reader recovers dt from the time column; make sure it will get
    // it back (bit for bit in the usual cases, to 1e-9 always).
    let t: Vec<f64> = (0..n).map(|i| rec.time_s(i)).collect();
    match timeaxis::check_uniform(&t, &timeaxis::PrintModel::exact(), 1.0) {
        Ok(dt) if (dt - rec.dt_s).abs() <= 1e-9 * rec.dt_s => Ok(csv::render_csv(rec)),
        Ok(dt) => Err(format!(
            "with start_s = {} s the time column cannot carry dt_s = {} s (it would read back as {dt} s); use UFF",
            rec.start_s, rec.dt_s
        )),
        Err(_) => Err(format!(
            "the time stamps start_s + i*dt_s (start {} s, dt {} s) are not uniform at double precision",
            rec.start_s, rec.dt_s
        )),
    }
}

/// Writes `rec` as UFF dataset 58, one dataset per channel: binary (58b,
/// little-endian doubles, bit-exact) or ASCII as the format prescribes
/// (4E20.12, 13 significant digits). See [`write_uff58_as`].
pub fn write_uff58(path: &Path, rec: &RecordFile, binary: bool) -> Result<(), RecordError> {
    let enc = if binary {
        Uff58Encoding::Binary
    } else {
        Uff58Encoding::Ascii
    };
    write_uff58_as(path, rec, enc)
}

/// Writes `rec` as UFF dataset 58 in the given encoding. Each channel is a
/// time response (function type 1) at its node and direction (0 if
/// unknown), ID line 1 is the channel name, record 9 carries the unit.
/// Record 7 holds start and interval with 6 digits (E13.5) as prescribed;
/// the exact values are added to ID line 5 (`frameid dt_s=… start_s=…`)
/// and used by [`read_record`] when they agree with record 7.
pub fn write_uff58_as(
    path: &Path,
    rec: &RecordFile,
    enc: Uff58Encoding,
) -> Result<(), RecordError> {
    let bytes = uff58_bytes(rec, enc).map_err(|reason| refuse(path, reason))?;
    write_atomically(path, &bytes)
}

/// The content [`write_uff58_as`] writes; the error names `rec.path`.
pub fn encode_uff58(rec: &RecordFile, enc: Uff58Encoding) -> Result<Vec<u8>, RecordError> {
    uff58_bytes(rec, enc).map_err(|reason| refuse(&rec.path, reason))
}

fn uff58_bytes(rec: &RecordFile, enc: Uff58Encoding) -> Result<Vec<u8>, String> {
    if let Some(reason) = rec.consistency_problem() {
        return Err(reason);
    }
    uff::check_writable(rec)?;
    Ok(uff::render_uff58(rec, enc))
}

/// Writes `bytes` to a temporary file in the target's directory, flushes it
/// to disk and renames it over `path`. On any failure the temporary file is
/// removed and `path` is untouched.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), RecordError> {
    let io_err = |op, error| RecordError::Io {
        path: path.to_path_buf(),
        op,
        error,
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let Some(name) = path.file_name() else {
        return Err(io_err(
            IoOp::CreateTemp,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "the path names no file"),
        ));
    };
    let mut builder = tempfile::Builder::new();
    let prefix = format!(".{}.", name.to_string_lossy());
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        // Same permissions as a file created the ordinary way (0666 minus
        // the umask) instead of the private 0600 of temporary files.
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder
        .tempfile_in(dir)
        .map_err(|e| io_err(IoOp::CreateTemp, e))?;
    tmp.write_all(bytes)
        .and_then(|()| tmp.flush())
        .and_then(|()| tmp.as_file().sync_all())
        .map_err(|e| io_err(IoOp::Write, e))?;
    tmp.persist(path)
        .map_err(|e| io_err(IoOp::Replace, e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channel_spec_parsing() {
        let p = |s: &str| s.parse::<ChannelSpec>().unwrap();
        assert_eq!(p("force"), ChannelSpec::Name("force".into()));
        assert_eq!(p(" force [N] "), ChannelSpec::Name("force [N]".into()));
        assert_eq!(
            p("1:+X"),
            ChannelSpec::NodeDir {
                node: 1,
                direction: 1
            }
        );
        assert_eq!(
            p("1:1"),
            ChannelSpec::NodeDir {
                node: 1,
                direction: 1
            }
        );
        assert_eq!(
            p("node1:x"),
            ChannelSpec::NodeDir {
                node: 1,
                direction: 1
            }
        );
        assert_eq!(
            p("N12:-rz"),
            ChannelSpec::NodeDir {
                node: 12,
                direction: -6
            }
        );
        assert_eq!(
            p("3:S"),
            ChannelSpec::NodeDir {
                node: 3,
                direction: 0
            }
        );
        assert_eq!(p("id:Hammer"), ChannelSpec::IdLine("Hammer".into()));
        assert_eq!(p("#3"), ChannelSpec::Index(3));
        assert_eq!(p("name:1:x"), ChannelSpec::Name("1:x".into()));
        assert_eq!(p("acc:top"), ChannelSpec::Name("acc:top".into()));
        for bad in ["", "#0", "#x", "1:W", "1:7", "id:"] {
            let e = bad.parse::<ChannelSpec>().unwrap_err();
            assert!(matches!(e, RecordError::InvalidSpec { .. }), "{bad}: {e}");
        }
    }

    #[test]
    fn channel_spec_display_parses_back() {
        for s in [
            "force",
            "1:+X",
            "2:-RZ",
            "3:S",
            "id:Hammer 1",
            "#4",
            "name:1:x",
        ] {
            let spec: ChannelSpec = s.parse().unwrap();
            assert_eq!(
                spec.to_string().parse::<ChannelSpec>().unwrap(),
                spec,
                "{s}"
            );
        }
    }

    #[test]
    fn direction_labels() {
        assert_eq!(direction_label(1), "+X");
        assert_eq!(direction_label(-6), "-RZ");
        assert_eq!(direction_label(0), "S");
        for d in -6..=6 {
            assert_eq!(parse_direction(&direction_label(d)), Some(d));
        }
    }
}
