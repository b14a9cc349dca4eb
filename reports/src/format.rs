//! Escaping and number formatting shared by tables and charts.

/// What a missing value (NaN) is shown as.
pub const MISSING: &str = "—";

/// Escapes text for HTML element content and attribute values.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + s.len() / 8);
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            // Control characters other than tab/newline are not allowed in
            // HTML text; drop them rather than emit an invalid document.
            c if c.is_control() && c != '\n' && c != '\t' => {}
            c => out.push(c),
        }
    }
    out
}

/// Decimal exponent and mantissa digits of `v` rounded to `digits`
/// significant digits: (`"1.2346"`, -5) for 1.23456e-5. `v` must be finite
/// and non-zero.
fn sci_parts(v: f64, digits: usize) -> (String, i32) {
    let s = format!("{:.*e}", digits.saturating_sub(1), v.abs());
    let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
    (mantissa.to_string(), exp.parse().unwrap_or(0))
}

/// The value of a rounded mantissa and exponent, exact in decimal.
fn rounded(mantissa: &str, exp: i32) -> f64 {
    format!("{mantissa}e{exp}").parse().unwrap_or(f64::NAN)
}

/// `v` with `digits` significant digits: plain decimals for 1e-3 <= |v| <
/// 1e6, otherwise `1.2346e-5`. NaN is shown as "—", infinities as ±∞.
pub fn sig(v: f64, digits: usize) -> String {
    if v.is_nan() {
        return MISSING.to_string();
    }
    if v.is_infinite() {
        return if v > 0.0 { "∞" } else { "-∞" }.to_string();
    }
    if v == 0.0 {
        return "0".to_string();
    }
    let digits = digits.max(1);
    let sign = if v < 0.0 { "-" } else { "" };
    let (mantissa, exp) = sci_parts(v, digits);
    if (-3..6).contains(&exp) {
        let decimals = (digits as i32 - 1 - exp).max(0) as usize;
        format!("{sign}{:.*}", decimals, rounded(&mantissa, exp))
    } else {
        format!("{sign}{mantissa}e{exp}")
    }
}

/// Like [`sig`] but without trailing zeros after the decimal point (for
/// labels such as noise levels: 0.1, 1, 2.5).
pub fn trim(v: f64, digits: usize) -> String {
    let s = sig(v, digits);
    if !v.is_finite() || s.contains('e') || !s.contains('.') {
        return s;
    }
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// Relative error of `identified` against `truth`, `(identified - truth) /
/// |truth|`. `None` when either is not finite, or the truth is zero and the
/// identified value is not (the relative error does not exist).
pub fn relative_error(truth: f64, identified: f64) -> Option<f64> {
    if !truth.is_finite() || !identified.is_finite() {
        return None;
    }
    if truth == 0.0 {
        return (identified == 0.0).then_some(0.0);
    }
    Some((identified - truth) / truth.abs())
}

/// A signed relative error in %, 3 significant digits: "+0.123 %",
/// "-12.3 %", "+9770 %", "+3.21e-5 %".
pub fn percent(rel: f64) -> String {
    if !rel.is_finite() {
        return sig(rel, 3);
    }
    let p = rel * 100.0;
    if p == 0.0 {
        return "0 %".to_string();
    }
    let sign = if p > 0.0 { "+" } else { "-" };
    let a = p.abs();
    let body = if (0.01..1e5).contains(&a) {
        let (mantissa, exp) = sci_parts(a, 3);
        let decimals = (2 - exp).max(0) as usize;
        format!("{:.*}", decimals, rounded(&mantissa, exp))
    } else {
        let (mantissa, exp) = sci_parts(a, 3);
        format!("{mantissa}e{exp}")
    };
    format!("{sign}{body} %")
}

/// A noise level given as a fraction, in % without the sign: 0.001 -> "0.1".
pub fn noise_percent(fraction: f64) -> String {
    trim(fraction * 100.0, 3)
}

const SUPERSCRIPT: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];

/// `10` with a superscript exponent: 10⁻³.
pub fn power_of_ten(exp: i32) -> String {
    let mut s = String::from("10");
    if exp < 0 {
        s.push('⁻');
    }
    for d in exp.unsigned_abs().to_string().bytes() {
        s.push(SUPERSCRIPT[(d - b'0') as usize]);
    }
    s
}

/// A slug for ids: ASCII lowercase letters, digits and dashes.
pub fn slug(s: &str) -> String {
    let mut out = String::new();
    for c in s.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_lowercase());
        } else if !out.ends_with('-') && !out.is_empty() {
            out.push('-');
        }
    }
    while out.ends_with('-') {
        out.pop();
    }
    if out.is_empty() {
        out.push('x');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits() {
        assert_eq!(sig(630.44, 5), "630.44");
        assert_eq!(sig(0.2913, 4), "0.2913");
        assert_eq!(sig(-425.83, 5), "-425.83");
        assert_eq!(sig(9.999_96, 5), "10.000");
        assert_eq!(sig(3.2283e-5, 5), "3.2283e-5");
        assert_eq!(sig(1.5e7, 3), "1.50e7");
        assert_eq!(sig(0.0054, 2), "0.0054");
        assert_eq!(sig(123_456.7, 3), "123000");
        assert_eq!(sig(f64::NAN, 4), MISSING);
        assert_eq!(sig(f64::NEG_INFINITY, 4), "-∞");
        assert_eq!(sig(-0.0, 4), "0");
    }

    #[test]
    fn trimmed() {
        assert_eq!(noise_percent(0.001), "0.1");
        assert_eq!(noise_percent(0.01), "1");
        assert_eq!(noise_percent(0.025), "2.5");
        assert_eq!(noise_percent(0.0), "0");
        assert_eq!(trim(1e-9, 3), "1.00e-9");
    }

    #[test]
    fn relative_errors() {
        assert_eq!(
            relative_error(2.0, 2.2).map(|e| (e * 1e6).round()),
            Some(1e5)
        );
        assert_eq!(
            relative_error(-2.0, -2.2).map(|e| (e * 1e6).round()),
            Some(-1e5)
        );
        assert_eq!(relative_error(0.0, 0.0), Some(0.0));
        assert_eq!(relative_error(0.0, 1.0), None);
        assert_eq!(relative_error(f64::NAN, 1.0), None);
        assert_eq!(percent(0.001234), "+0.123 %");
        assert_eq!(percent(-0.1234), "-12.3 %");
        assert_eq!(percent(97.654), "+9770 %");
        assert_eq!(percent(3.21e-7), "+3.21e-5 %");
        assert_eq!(percent(0.0), "0 %");
        assert_eq!(percent(f64::NAN), MISSING);
    }

    #[test]
    fn escaping_and_slugs() {
        assert_eq!(
            escape("<a href=\"x\">'&'</a>\u{7}"),
            "&lt;a href=&quot;x&quot;&gt;&#39;&amp;&#39;&lt;/a&gt;"
        );
        assert_eq!(slug("Damping MKR (Frobenius)"), "damping-mkr-frobenius");
        assert_eq!(slug("ξ"), "x");
        assert_eq!(power_of_ten(-12), "10⁻¹²");
        assert_eq!(power_of_ten(0), "10⁰");
    }
}
