//! Units as files write them, in one table for every format.
//!
//! Readers keep a channel's unit text as the file states it (it is shown in
//! messages and written back); what they convert is the time axis, whose
//! unit changes the sampling interval. Spellings are matched ignoring ASCII
//! case and surrounding blanks.

/// Time units: the spellings accepted and seconds per unit.
pub const TIME_UNITS: [(&[&str], f64); 3] = [
    (&["s", "sec", "secs", "second", "seconds"], 1.0),
    (
        &["ms", "msec", "msecs", "millisecond", "milliseconds"],
        1e-3,
    ),
    (
        &[
            "us",
            "µs",
            "μs",
            "usec",
            "usecs",
            "microsecond",
            "microseconds",
        ],
        1e-6,
    ),
];

/// Seconds per `unit`, if it is a time unit of [`TIME_UNITS`].
pub fn seconds_per(unit: &str) -> Option<f64> {
    let u = unit.trim().to_lowercase();
    TIME_UNITS
        .iter()
        .find(|(names, _)| names.contains(&u.as_str()))
        .map(|&(_, scale)| scale)
}

/// The accepted time units, for messages: `s, ms or us`.
pub fn time_units_hint() -> &'static str {
    "s, ms or us"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_units() {
        assert_eq!(seconds_per("s"), Some(1.0));
        assert_eq!(seconds_per(" Secs "), Some(1.0));
        assert_eq!(seconds_per("MS"), Some(1e-3));
        assert_eq!(seconds_per("µs"), Some(1e-6));
        assert_eq!(seconds_per("min"), None);
        // Every spelling is lower case, so that matching ignores case.
        for (names, _) in TIME_UNITS {
            for n in names {
                assert_eq!(n.to_lowercase(), *n);
            }
        }
    }
}
