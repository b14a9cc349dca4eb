//! Units as files write them, in one table for every format.
//!
//! Record readers keep a channel's unit text as the file states it (it is
//! shown in messages and written back); what they convert is the time axis,
//! whose unit changes the sampling interval. FRF readers convert values to
//! SI: the response unit ([`MOTION_UNITS`]) over the force unit
//! ([`FORCE_UNITS`]) gives the quantity and the factor ([`frf_unit`]), and
//! the frequency axis is converted to hertz ([`FREQUENCY_UNITS`]).
//! Spellings are matched ignoring ASCII case and surrounding blanks (so no
//! table may hold spellings that differ only in case, such as mN and MN).

use ident::FrfQuantity;

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

/// Standard gravity, m/s^2 per g (the value of the CGPM, exact).
pub const STANDARD_GRAVITY: f64 = 9.806_65;

/// Metres per inch (exact).
pub const INCH_M: f64 = 0.0254;

/// Newtons per pound-force (exact by definition: 0.45359237 kg x g).
pub const POUND_FORCE_N: f64 = 4.448_221_615_260_5;

/// Response units: spellings, the FRF quantity a response in that unit over
/// a force makes (displacement: receptance, velocity: mobility,
/// acceleration: accelerance) and the SI value of one unit (m, m/s or
/// m/s^2).
pub const MOTION_UNITS: [(&[&str], FrfQuantity, f64); 16] = [
    (&["m", "meter", "metre"], FrfQuantity::Receptance, 1.0),
    (&["mm"], FrfQuantity::Receptance, 1e-3),
    (&["um", "µm", "μm", "micron"], FrfQuantity::Receptance, 1e-6),
    (&["cm"], FrfQuantity::Receptance, 1e-2),
    (&["in", "inch"], FrfQuantity::Receptance, INCH_M),
    (&["m/s"], FrfQuantity::Mobility, 1.0),
    (&["mm/s"], FrfQuantity::Mobility, 1e-3),
    (&["um/s", "µm/s", "μm/s"], FrfQuantity::Mobility, 1e-6),
    (&["cm/s"], FrfQuantity::Mobility, 1e-2),
    (&["in/s", "ips"], FrfQuantity::Mobility, INCH_M),
    (
        &["m/s^2", "m/s2", "m/s²", "m/s/s", "m/s**2", "m*s^-2"],
        FrfQuantity::Accelerance,
        1.0,
    ),
    (
        &["mm/s^2", "mm/s2", "mm/s²", "mm/s/s"],
        FrfQuantity::Accelerance,
        1e-3,
    ),
    (
        &["cm/s^2", "cm/s2", "cm/s²"],
        FrfQuantity::Accelerance,
        1e-2,
    ),
    (
        &["in/s^2", "in/s2", "in/s²", "in/s/s"],
        FrfQuantity::Accelerance,
        INCH_M,
    ),
    (
        &["g", "gn", "g0", "g's", "gs"],
        FrfQuantity::Accelerance,
        STANDARD_GRAVITY,
    ),
    (
        &["ft/s^2", "ft/s2", "ft/s²"],
        FrfQuantity::Accelerance,
        0.3048,
    ),
];

/// Force units: spellings and newtons per unit.
pub const FORCE_UNITS: [(&[&str], f64); 4] = [
    (&["n", "newton", "newtons"], 1.0),
    (&["kn", "kilonewton", "kilonewtons"], 1e3),
    (&["lbf", "lb", "lbs", "pound-force"], POUND_FORCE_N),
    (&["kgf", "kp"], STANDARD_GRAVITY),
];

/// Frequency units: spellings and hertz per unit.
pub const FREQUENCY_UNITS: [(&[&str], f64); 2] =
    [(&["hz", "1/s", "cps", "hertz"], 1.0), (&["khz"], 1e3)];

fn lookup<T: Copy>(table: &[(&[&str], T)], unit: &str) -> Option<T> {
    let u = unit.trim().to_lowercase();
    table
        .iter()
        .find(|(names, _)| names.contains(&u.as_str()))
        .map(|&(_, v)| v)
}

/// The quantity and SI value (m, m/s or m/s^2) of a response unit of
/// [`MOTION_UNITS`].
pub fn motion_unit(unit: &str) -> Option<(FrfQuantity, f64)> {
    let u = unit.trim().to_lowercase();
    MOTION_UNITS
        .iter()
        .find(|(names, _, _)| names.contains(&u.as_str()))
        .map(|&(_, q, s)| (q, s))
}

/// Newtons per force unit of [`FORCE_UNITS`].
pub fn newtons_per(unit: &str) -> Option<f64> {
    let table: Vec<(&[&str], f64)> = FORCE_UNITS.to_vec();
    lookup(&table, unit)
}

/// Hertz per frequency unit of [`FREQUENCY_UNITS`].
pub fn hertz_per(unit: &str) -> Option<f64> {
    let table: Vec<(&[&str], f64)> = FREQUENCY_UNITS.to_vec();
    lookup(&table, unit)
}

/// The quantity of an FRF unit and the factor that turns values in it into
/// SI ((m, m/s or m/s^2) per N): a response unit of [`MOTION_UNITS`] over a
/// force unit of [`FORCE_UNITS`], written `num/force` or `(num)/force`,
/// blanks ignored: `(m/s^2)/N`, `m/s^2/N`, `g/N`, `mm/N`, `(in/s)/lbf`.
pub fn frf_unit(unit: &str) -> Option<(FrfQuantity, f64)> {
    let u: String = unit.chars().filter(|c| !c.is_whitespace()).collect();
    let (num, den) = u.rsplit_once('/')?;
    let num = num
        .strip_prefix('(')
        .and_then(|n| n.strip_suffix(')'))
        .unwrap_or(num);
    let (quantity, motion) = motion_unit(num)?;
    let force = newtons_per(den)?;
    Some((quantity, motion / force))
}

/// The accepted FRF units, for messages.
pub fn frf_units_hint() -> &'static str {
    "a response unit (m, mm, m/s, mm/s, in/s, m/s^2, g, ...) over a force unit (N, kN, lbf), e.g. (m/s^2)/N or g/N"
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

    #[test]
    fn frf_units() {
        let acc = FrfQuantity::Accelerance;
        assert_eq!(frf_unit("(m/s^2)/N"), Some((acc, 1.0)));
        assert_eq!(frf_unit(" m/s2 / N "), Some((acc, 1.0)));
        assert_eq!(frf_unit("g/N"), Some((acc, 9.80665)));
        assert_eq!(frf_unit("m/N"), Some((FrfQuantity::Receptance, 1.0)));
        assert_eq!(frf_unit("mm/kN"), Some((FrfQuantity::Receptance, 1e-6)));
        assert_eq!(frf_unit("(m/s)/N"), Some((FrfQuantity::Mobility, 1.0)));
        // 0.0254 m / 4.4482216152605 N, one rounding.
        assert_eq!(
            frf_unit("(in/s)/lbf"),
            Some((FrfQuantity::Mobility, 0.0254 / 4.448_221_615_260_5))
        );
        assert_eq!(frf_unit("m/s^2"), None);
        assert_eq!(frf_unit("V/N"), None);
        assert_eq!(hertz_per("Hz"), Some(1.0));
        assert_eq!(hertz_per("kHz"), Some(1e3));
        assert_eq!(hertz_per("rpm"), None);
        // Lower case, and no spelling in two entries of a table.
        let mut seen = std::collections::HashSet::new();
        for (names, _, _) in MOTION_UNITS {
            for n in names {
                assert_eq!(n.to_lowercase(), *n);
                assert!(seen.insert(*n), "{n} twice");
            }
        }
        for (names, _) in FORCE_UNITS.iter().chain(&FREQUENCY_UNITS) {
            for n in *names {
                assert_eq!(n.to_lowercase(), *n);
                assert!(seen.insert(*n), "{n} twice");
            }
        }
    }
}
