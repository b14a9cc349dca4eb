//! Number parsing and printing shared by the CSV and UFF code, and the
//! short number form used in messages ([`sig`]).

use std::fmt::Write as _;

/// A number with `digits` significant digits, in plain or scientific
/// notation depending on its magnitude (`630.44`, `3.2283e-5`): the form
/// of numbers in messages and tables.
pub fn sig(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == 0.0 {
        return "0".into();
    }
    let mag = x.abs().log10().floor() as i32;
    if (-3..6).contains(&mag) {
        let decimals = (digits as i32 - 1 - mag).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.prec$e}", prec = digits - 1)
    }
}

/// Why a cell is not a usable number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NumError {
    Empty,
    NotANumber,
    NonFinite,
}

/// Parses a decimal number as C, Python and spreadsheet programs print it.
/// NaN, infinities and values that overflow to infinity are refused.
pub(crate) fn parse_decimal(text: &str) -> Result<f64, NumError> {
    if text.is_empty() {
        return Err(NumError::Empty);
    }
    // `f64::from_str` accepts "inf", "infinity" and "nan" (any case): they
    // come out as non-finite values and are refused below, with their own
    // message. Anything else it refuses is not a number.
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(NumError::NonFinite),
        Err(_) => Err(NumError::NotANumber),
    }
}

/// Parses a real number as Fortran programs print it: besides the C forms,
/// a `D` exponent (`1.0D+00`) and the form without exponent letter that
/// `Ew.d` output takes for three-digit exponents (`1.23456-100`).
pub(crate) fn parse_fortran(text: &str) -> Result<f64, NumError> {
    match parse_decimal(text) {
        Err(NumError::NotANumber) => {}
        other => return other,
    }
    if !text.is_ascii() {
        return Err(NumError::NotANumber);
    }
    let mut s: String = text
        .chars()
        .map(|c| if c == 'D' || c == 'd' { 'E' } else { c })
        .collect();
    if !s.contains(['E', 'e']) {
        // A sign after the first digit or point starts the exponent.
        if let Some(pos) = s
            .char_indices()
            .skip(1)
            .find(|&(i, c)| {
                (c == '+' || c == '-') && s[..i].ends_with(|p: char| p.is_ascii_digit() || p == '.')
            })
            .map(|(i, _)| i)
        {
            s.insert(pos, 'E');
        }
    }
    parse_decimal(&s)
}

/// Shortest decimal text that parses back to exactly `x` (for finite `x`).
///
/// Rust's `Display` and `LowerExp` for `f64` both print the shortest digit
/// string that round-trips; plain notation is used for ordinary magnitudes
/// and exponent notation for tiny or huge ones, so that e.g. `1e-300` does
/// not become 300 zeros.
pub(crate) fn shortest(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-5..1e16).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Appends `x` in Fortran `Ew.d` style with a leading digit (`1PEw.d`):
/// `d` decimals, an `E`, a sign and at least two exponent digits,
/// right-aligned in `width` characters. Three-digit exponents keep their
/// `E` (one character wider than Fortran would print), because readers
/// that split on blanks or use C/Python conversions could not parse
/// Fortran's letterless form; fixed-column readers are unaffected.
pub(crate) fn push_fortran_e(out: &mut String, x: f64, width: usize, decimals: usize) {
    let s = format!("{x:.decimals$e}");
    let body = match s.split_once('e') {
        Some((mantissa, exp)) => {
            let e: i32 = exp.parse().unwrap_or(0);
            let sign = if e < 0 { '-' } else { '+' };
            format!("{mantissa}E{sign}{:02}", e.unsigned_abs())
        }
        None => s,
    };
    let _ = write!(out, "{body:>width$}");
}

/// Precision of a printed number: digits after the decimal point in plain
/// notation (negative for exponent notation of large values), and the
/// count of significant digits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Printed {
    pub decimals: i32,
    pub significant: u32,
}

/// Measures how precisely `text` (already accepted as a number) is printed.
pub(crate) fn printed_precision(text: &str) -> Printed {
    let b = text.as_bytes();
    let mut i = 0;
    if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
        i += 1;
    }
    let mut frac_digits: i64 = 0;
    let mut significant: u32 = 0;
    let mut seen_nonzero = false;
    let mut after_point = false;
    while i < b.len() {
        match b[i] {
            b'0'..=b'9' => {
                if b[i] != b'0' {
                    seen_nonzero = true;
                }
                if seen_nonzero {
                    significant = significant.saturating_add(1);
                }
                if after_point {
                    frac_digits += 1;
                }
            }
            b'.' => after_point = true,
            _ => break,
        }
        i += 1;
    }
    let mut exponent: i64 = 0;
    if i < b.len() && matches!(b[i], b'e' | b'E' | b'd' | b'D') {
        i += 1;
    }
    if i < b.len() {
        let mut neg = false;
        if b[i] == b'+' || b[i] == b'-' {
            neg = b[i] == b'-';
            i += 1;
        }
        while i < b.len() && b[i].is_ascii_digit() {
            exponent = (exponent * 10 + i64::from(b[i] - b'0')).min(100_000);
            i += 1;
        }
        if neg {
            exponent = -exponent;
        }
    }
    Printed {
        decimals: (frac_digits - exponent).clamp(-100_000, 100_000) as i32,
        significant,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits() {
        assert_eq!(sig(630.4392, 5), "630.44");
        assert_eq!(sig(-0.0152, 3), "-0.0152");
        assert_eq!(sig(3.2283e-5, 5), "3.2283e-5");
        assert_eq!(sig(0.0, 5), "0");
        assert_eq!(sig(123456.7, 4), "123457");
        assert_eq!(sig(1234567.0, 4), "1.235e6");
    }

    #[test]
    fn decimal_parsing() {
        assert_eq!(parse_decimal("1.5"), Ok(1.5));
        assert_eq!(parse_decimal("-2e-3"), Ok(-2e-3));
        assert_eq!(parse_decimal(""), Err(NumError::Empty));
        assert_eq!(parse_decimal("abc"), Err(NumError::NotANumber));
        assert_eq!(parse_decimal("1,5"), Err(NumError::NotANumber));
        assert_eq!(parse_decimal("NaN"), Err(NumError::NonFinite));
        assert_eq!(parse_decimal("-inf"), Err(NumError::NonFinite));
        assert_eq!(parse_decimal("1e999"), Err(NumError::NonFinite));
    }

    #[test]
    fn fortran_parsing() {
        assert_eq!(parse_fortran("1.0D+00"), Ok(1.0));
        assert_eq!(parse_fortran("-2.5d-1"), Ok(-0.25));
        assert_eq!(parse_fortran("1.23456-100"), Ok(1.23456e-100));
        assert_eq!(parse_fortran("-1.5+002"), Ok(-150.0));
        assert_eq!(parse_fortran("-1.5"), Ok(-1.5));
        assert_eq!(parse_fortran("1-"), Err(NumError::NotANumber));
        assert_eq!(parse_fortran("--1"), Err(NumError::NotANumber));
        assert_eq!(parse_fortran("1.0D+999"), Err(NumError::NonFinite));
    }

    #[test]
    fn fortran_e_printing() {
        let mut s = String::new();
        push_fortran_e(&mut s, 1.0, 13, 5);
        push_fortran_e(&mut s, -0.00123456789, 13, 5);
        push_fortran_e(&mut s, 0.0, 20, 12);
        assert_eq!(s, "  1.00000E+00 -1.23457E-03  0.000000000000E+00");
        let mut s = String::new();
        push_fortran_e(&mut s, -1.5e-300, 13, 5);
        assert_eq!(s, "-1.50000E-300");
    }

    #[test]
    fn shortest_round_trips() {
        for x in [
            0.0,
            -0.0,
            0.1,
            1.0 / 3.0,
            1e-300,
            5e-324,
            f64::MAX,
            f64::MIN_POSITIVE,
            123456789.0,
            1e16,
            -2.5e-6,
        ] {
            let s = shortest(x);
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), x.to_bits(), "{s}");
        }
        assert_eq!(shortest(0.001), "0.001");
        assert_eq!(shortest(1e-300), "1e-300");
    }

    #[test]
    fn precision_of_printed_numbers() {
        let p = |s| printed_precision(s);
        assert_eq!(
            p("0.000488"),
            Printed {
                decimals: 6,
                significant: 3
            }
        );
        assert_eq!(
            p("4.88281E-04"),
            Printed {
                decimals: 9,
                significant: 6
            }
        );
        assert_eq!(
            p("-12"),
            Printed {
                decimals: 0,
                significant: 2
            }
        );
        assert_eq!(
            p("1e5"),
            Printed {
                decimals: -5,
                significant: 1
            }
        );
        assert_eq!(
            p("0"),
            Printed {
                decimals: 0,
                significant: 0
            }
        );
    }
}
