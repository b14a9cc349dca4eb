//! Channel selectors: how a user names a channel on the command line.

use std::fmt;
use std::str::FromStr;

use crate::error::RecordError;

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
    /// A channel name, compared case-insensitively without its `[unit]`.
    Name(String),
    /// A UFF response node and direction (record 6 of dataset 58).
    NodeDir {
        /// The node number as the file gives it.
        node: i64,
        /// The direction: `1..6 = +X, +Y, +Z, +RX, +RY, +RZ`, negative for
        /// minus, 0 for a scalar ([`parse_direction`]).
        direction: i32,
    },
    /// (Part of) a UFF ID line: an exact match first, else a unique
    /// case-insensitive substring.
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
