//! Plain-text tables for terminal output.

use nalgebra::DMatrix;

/// A matrix as aligned rows with 5 significant digits.
pub fn matrix(title: &str, m: &DMatrix<f64>) -> String {
    let mut s = format!("{title}\n");
    for i in 0..m.nrows() {
        s.push_str("  ");
        for j in 0..m.ncols() {
            s.push_str(&format!("{:>13}", sig(m[(i, j)], 5)));
        }
        s.push('\n');
    }
    s
}

/// A number with `digits` significant digits, in plain or scientific
/// notation depending on its magnitude.
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
}
